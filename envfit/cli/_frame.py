"""``envfit frame SCENE``: the predicted noise of a frame, from the renderer's own scene file.

Prints the image RMSE (against the converged image, over all pixels and channels) and the
pixels' RMSE percentiles at each spp, and the smallest spp that meets the target (the image
RMSE, or a percentile of the pixels' with ``--percentile``). ``--out DIR`` writes
``noise.exr`` (each pixel's predicted RMSE at the first spp), ``preview.exr`` (the converged
image the model implies) and ``frame.png`` (both side by side); ``--json`` the
:meth:`envfit.frame.FramePrediction.to_dict` form.

Example::

    envfit frame scene.xml --spp 16,64,256 --json frame.json --out frame/
"""
from __future__ import annotations

import argparse
from pathlib import Path

from envfit.cli._common import add_common_arguments, int_list, out_dir
from envfit.cli._output import CommandOutput
from envfit.cli._parse import positive_float, positive_int


def _readers() -> str:
    """The scene files read, from the registry: ".xml: Mitsuba 3", …"""
    from envfit.frame import READERS
    from envfit.renderers import get_renderer
    return ", ".join(f"{k}: {get_renderer(v).display}" for k, v in READERS.items())


def register(subparsers) -> None:
    readers = _readers()
    p = subparsers.add_parser(
        "frame", help="predict the noise of a frame from the renderer's scene file",
        description=f"Read a renderer's scene file ({readers}) with the renderer, cast its "
                    "shadow rays and predict each pixel's RMSE under the renderer's "
                    "estimator and pixel filter: the image RMSE per spp and the spp that "
                    "meets a target. Direct lighting from one environment map, diffuse and "
                    "rough conductor surfaces, the independent and ldsampler (box filter) "
                    "samplers.")
    p.add_argument("scene", type=Path, help=f"the scene file ({readers})")
    p.add_argument("--spp", type=int_list, default=None,
                   help="sample counts to predict, e.g. 16,64,256 (default: the scene's)")
    t = p.add_mutually_exclusive_group()
    t.add_argument("--target", type=positive_float, default=None,
                   help="image RMSE to meet, in the image's units")
    t.add_argument("--target-relative", type=positive_float, default=None,
                   help="image RMSE to meet relative to the image's mean (default 0.01)")
    p.add_argument("--percentile", type=positive_float, default=None,
                   help="meet the target at this percentile of the pixels' RMSE (0 < Q <= 100)")
    p.add_argument("--film-points", type=positive_int, default=2,
                   help="film points per pixel side (default 2)")
    p.add_argument("--level", type=positive_int, default=4,
                   help="the techniques' tables hold 4^LEVEL points each (2..9, default 4)")
    p.add_argument("--max-pixels", type=positive_int, default=16384,
                   help="predict every pixel up to this many, else one drawn in each cell of a "
                        "grid of about this many (default 16384)")
    add_common_arguments(p)
    p.set_defaults(func=run)


def _lines(r) -> list[str]:
    head = (f"{r.scene}: {r.renderer}, {r.size[0]}x{r.size[1]} pixels, {r.sampler} sampler "
            f"({r.scene_spp} spp in the scene), {r.integrator}, {r.filter_name} filter")
    rows = [f"  {x.spp:>7} spp  image RMSE {x.rmse:.5g}"
            + (f" +- {100 * x.rmse_se:.2g} %" if not r.exact else "")
            + f" ({100 * x.relative:.3g} % of the mean "
            f"{r.mean_value:.4g}); pixels: median {x.percentiles[50]:.4g}, "
            f"90 % {x.percentiles[90]:.4g}, 99 % {x.percentiles[99]:.4g}" for x in r.rows]
    return [head, "  predicted RMSE against the converged image:", *rows]


def _answer(r, percentile) -> str:
    what = "the image RMSE" if percentile is None else f"the {percentile:g}th percentile " \
                                                       f"of the pixels' RMSE"
    past = (f" (extrapolated past {max(r.mse_by_spp)} spp at RMSE ∝ spp^-{r.answer_rate:.2f})"
            if r.answer_rate is not None else "")
    if r.answer is None:
        return (f"answer: none: {what} misses {r.target:.5g} ({r.target_kind}) at every spp "
                f"the {r.sampler} sampler runs up to {r.below}{past}")
    return (f"answer: {r.answer} spp: {what} meets {r.target:.5g} ({r.target_kind}) "
            f"at {r.answer} spp and not at {r.below}{past}" if r.below else
            f"answer: {r.answer} spp: {what} meets {r.target:.5g} ({r.target_kind}) at "
            f"{r.answer} spp, the fewest the {r.sampler} sampler runs")


def _write(output: CommandOutput, r, out: Path) -> None:
    from envfit.frame import write_exr
    from envfit.plots import plot_frame
    n = r.rows[0].spp
    noise = r.pixel_rmse(n)
    for name, arr in (("noise.exr", noise), ("preview.exr", r.preview)):
        if output.guarded_write(out / name, write_exr, out / name, arr) is not None:
            output.say(f"wrote {out / name}")
    png = output.guarded_write(out / "frame.png", plot_frame, r.preview, noise, n,
                               out / "frame.png", Path(r.scene).name)
    if png is not None:
        output.say(f"wrote {png}")


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.frame import FrameOptions, predict_frame
    opts = FrameOptions(spp=tuple(args.spp or ()), target=args.target,
                        target_relative=args.target_relative, percentile=args.percentile,
                        side=args.film_points, level=args.level, max_pixels=args.max_pixels,
                        seed=args.seed, quiet=args.quiet)
    r = predict_frame(args.scene, opts)
    answer = _answer(r, args.percentile)
    output.say(*_lines(r), answer, *(f"  note: {x}" for x in r.notes),
               f"  ({r.seconds['read']:.1f} s reading the scene, {r.seconds['model']:.1f} s "
               f"model, {r.rays} shadow rays)")
    output.answer(answer)
    out = out_dir(args)
    if out is not None:
        _write(output, r, out)
    output.emit_json(r.to_dict())
    return 0

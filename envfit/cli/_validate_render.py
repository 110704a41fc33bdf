"""``envfit validate MAP --renderer mitsuba3|cycles``: the renderer renders envfit's sphere and
its measured RMSE is set beside the preset's prediction (:mod:`envfit.validate._rendered`);
``validate``'s other parts are not run. Parses and checks the flags, calls, prints, writes."""
from __future__ import annotations

import argparse

from envfit.cli._common import int_list, positive_float, positive_int, str_list
from envfit.cli._output import CommandOutput

#: the flags of the rendered check → their option names
_FLAGS = {"--roughness": "roughness", "--samplers": "samplers", "--spp": "spp",
          "--resolution": "resolution", "--reference-spp": "reference_spp",
          "--frames": "frames", "--max-level": "max_level", "--footprint": "footprint"}
#: ``validate --renderer``'s rules flags: not used when a renderer renders
_RULES_FLAGS = {"--renderer-pointsets": "renderer_pointsets", "--renderer-n": "renderer_n",
                "--renderer-axes": "renderer_axes"}


def add_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("rendering (--renderer mitsuba3|cycles)")
    g.add_argument("--roughness", type=positive_float, default=None, metavar="ALPHA",
                   help="microfacet alpha of --brdf ggx, beckmann or roughplastic (Mitsuba's alpha; Cycles' "
                        "Glossy roughness sqrt(alpha))")
    g.add_argument("--samplers", type=str_list, default=None, metavar="S1,S2",
                   help="the renderer's samplers (default: Mitsuba independent,ldsampler; "
                        "Cycles tabulated_sobol,blue_noise)")
    g.add_argument("--spp", type=int_list, default=None, metavar="N1,N2",
                   help="samples per pixel of the cells (default: 16,64)")
    g.add_argument("--resolution", type=positive_int, default=None, metavar="R",
                   help="pixels per side of each of the six views (default: 32)")
    g.add_argument("--reference-spp", type=positive_int, default=None, metavar="N",
                   help="spp of each of the two reference renders (default: 1024)")
    g.add_argument("--frames", type=positive_int, default=None, metavar="K",
                   help="the model's frames (a conductor or plastic; default 256) or normals "
                        "(diffuse; default 64)")
    g.add_argument("--footprint", type=positive_int, default=None, metavar="J",
                   help="normals per pixel side in the model: each rendered pixel averages "
                        "the normals it spans (default 2; 1: pixel centres, a quarter of "
                        "the model's time)")
    g.add_argument("--max-level", type=positive_int, default=None, metavar="L",
                   help="the model's finest grid level (default 9; 10 resolves nets to 512 "
                        "spp, 11 to 1024)")


def dispatch(args: argparse.Namespace, output: CommandOutput) -> int | None:
    """Check the flags of both parts (one line, exit 2, before any work); with a renderer's
    name run the rendered check and return its exit code, else None (``validate`` goes on)."""
    from envfit.base._errors import ParameterError
    from envfit.validate._rendered import RENDERERS
    if args.renderer not in (None, "rules", *RENDERERS):
        raise ParameterError(f"--renderer takes {' or '.join(RENDERERS)} (or nothing: "
                             f"envfit's rules), got {args.renderer!r}")
    check_flags(args)
    return None if args.renderer in (None, "rules") else run(args, output)


def check_flags(args: argparse.Namespace) -> None:
    """One line for flags given to the wrong part, before any work."""
    from envfit.base._errors import ParameterError
    rendered = args.renderer not in (None, "rules")
    if not rendered:
        given = [f for f, k in _FLAGS.items() if getattr(args, k) is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} need(s) --renderer mitsuba3 or cycles")
        return
    given = [f for f, k in _RULES_FLAGS.items() if getattr(args, k) is not None]
    if given:
        raise ParameterError(f"{', '.join(given)} belong(s) to --renderer alone (envfit's "
                             f"rules), not to --renderer {args.renderer}")


def options(args: argparse.Namespace, cache_dir):
    """The :class:`RenderValidationOptions` of the flags (checked: one line, exit 2)."""
    from envfit.base._errors import ParameterError
    from envfit.validate._rendered import RenderValidationOptions
    brdfs = args.brdf or ["diffuse"]
    if len(brdfs) != 1:
        raise ParameterError(f"--brdf with --renderer {args.renderer} takes one BSDF, got "
                             f"{','.join(brdfs)}")
    kw = {k: tuple(getattr(args, k)) for k in ("samplers", "strategies", "spp")
          if getattr(args, k) is not None}
    kw.update({k: getattr(args, k) for k in ("resolution", "reference_spp", "frames",
                                             "max_level", "footprint")
               if getattr(args, k) is not None})
    return RenderValidationOptions(args.renderer, brdf=brdfs[0], alpha=args.roughness,
                                   seed=args.seed, cache_dir=str(cache_dir), **kw)


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.advisor._cache import default_cache_dir
    from envfit.base._atomic import atomic_write_csv, atomic_write_json
    from envfit.base._progress import progress_bar
    from envfit.cli._common import load_map_from_args, out_dir
    from envfit.validate._rendered import check_renderer, render_validation, summary_lines
    out = out_dir(args)
    opts = options(args, (out if out is not None else default_cache_dir()) / "references")
    check_renderer(opts.renderer)
    env = load_map_from_args(args)
    output.say(f"map {env.name}: {env.width}x{env.height}; {len(opts.cells)} cell(s) to render "
               f"with {opts.renderer}")
    bar = progress_bar(len(opts.cells) + 2, desc=f"validate {opts.renderer}", unit="step",
                       quiet=args.quiet or output.json_to_stdout)
    try:
        result = render_validation(env, opts, progress=lambda name: bar.update(1))
    finally:
        bar.close()
    res = result.to_dict()
    output.say(*summary_lines(result))
    if out is not None:
        from envfit.plots._rendered import plot_rendered
        cols = ["sampler", "strategy", "spp", "spp_used", "measured_rmse", "low", "high",
                "predicted", "ratio", "inside", "mean_offset"]
        written = [output.guarded_write(out / name, fn, out / name, *a) for name, fn, a in (
            ("rendered.json", atomic_write_json, (res,)),
            ("rendered.csv", atomic_write_csv, (cols, [[r[c] for c in cols]
                                                       for r in res["rows"]])),
            ("rendered.png", lambda p, r: plot_rendered(r, p), (res,)))]
        res["files"] = [str(w) for w in written if w is not None]
        if res["files"]:
            output.say("wrote " + ", ".join(res["files"]))
    output.say(f"({sum(res['seconds'].values()):.0f} s: model {res['seconds']['model']:.0f}, "
               f"reference {res['seconds']['reference']:.0f}, renders "
               f"{res['seconds']['renders']:.0f})")
    output.emit_json(res)
    return 0

"""``envfit validate MAP --renderer NAME``: the renderer renders envfit's sphere and
its measured RMSE is set beside the renderer model's prediction (:mod:`envfit.validate._rendered`);
``validate``'s other parts are not run. Parses and checks the flags, calls, prints, writes."""
from __future__ import annotations

import argparse

from envfit.cli._common import str_list
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged

#: the ranges of the rendering options (``--help`` and the errors say these words); the
#: lower bounds and the caps of --footprint and --max-level are the model's
#: (envfit.validate._rendered.RenderValidationOptions), the others fixed caps
ALPHA = Ranged(0.05, 1, "alpha", integer=False)
ROUGHNESS = Ranged(0, 1, "R", integer=False, lo_open=True)
SPP = Ranged(1, 65536, "N", many=True)
RESOLUTION = Ranged(8, 1024, "R")
REFERENCE_SPP = Ranged(4, 2 ** 20, "N")
FRAMES = Ranged(6, 4096, "K")
FOOTPRINT = Ranged(1, 8, "J")
MAX_LEVEL = Ranged(4, 11, "L")

#: the flags of the rendered check → their option names
_FLAGS = {"--alpha": "alpha", "--roughness": "roughness", "--bsdf-param": "bsdf_param",
          "--samplers": "samplers",
          "--spp": "spp",
          "--resolution": "resolution", "--reference-spp": "reference_spp",
          "--frames": "frames", "--max-level": "max_level", "--footprint": "footprint"}
#: ``validate --renderer``'s rules flags: not used when a renderer renders
_RULES_FLAGS = {"--renderer-pointsets": "renderer_pointsets", "--renderer-n": "renderer_n",
                "--renderer-axes": "renderer_axes"}


def _rendering() -> tuple[str, str, str]:
    """From the registries: the renderers that render ('A|B'), each one's default samplers,
    each one's roughness convention."""
    from envfit.renderers import RENDERERS
    rs = [r for r in RENDERERS.values() if r.harness]
    samplers = "; ".join(f"{r.display} {','.join(r.render_samplers)}" for r in rs)
    rough = "; ".join(r.roughness.words() for r in rs)
    return "|".join(r.name for r in rs), samplers, rough


def add_arguments(p: argparse.ArgumentParser) -> None:
    names, samplers, rough = _rendering()
    g = p.add_argument_group(f"rendering (--renderer {names})")
    a = g.add_mutually_exclusive_group()
    a.add_argument("--alpha", type=ALPHA, default=None, metavar="A",
                   help=f"microfacet alpha of --brdf ggx, beckmann or roughplastic, {ALPHA}, "
                        "the same for every renderer (each is given its own roughness for "
                        "it)")
    a.add_argument("--roughness", type=ROUGHNESS, default=None, metavar="R",
                   help=f"instead of --alpha: the renderer's own roughness, {ROUGHNESS}, as "
                        f"advise --roughness reads it: {rough}")
    from envfit.cli._advise_renderer import bsdf_param, bsdf_param_words
    g.add_argument("--bsdf-param", type=bsdf_param, action="append", default=None,
                   metavar="NAME=VALUE",
                   help=f"a parameter of a --brdf that has its own (repeat for several), as "
                        f"advise --bsdf-param: {bsdf_param_words()}")
    g.add_argument("--samplers", type=str_list, default=None, metavar="S1,S2",
                   help=f"the renderer's samplers (default: {samplers})")
    g.add_argument("--spp", type=SPP, default=None, metavar="N1,N2",
                   help=f"samples per pixel of the cells, each {SPP} (default: 16,64)")
    g.add_argument("--resolution", type=RESOLUTION, default=None, metavar="R",
                   help=f"pixels per side of each of the six views, {RESOLUTION} (default: 32)")
    g.add_argument("--reference-spp", type=REFERENCE_SPP, default=None, metavar="N",
                   help=f"spp of each of the two reference renders, {REFERENCE_SPP} "
                        "(default: 1024)")
    g.add_argument("--frames", type=FRAMES, default=None, metavar="K",
                   help=f"the model's frames (a conductor or plastic; default 256) or normals "
                        f"(diffuse; default 64), {FRAMES}")
    g.add_argument("--footprint", type=FOOTPRINT, default=None, metavar="J",
                   help=f"normals per pixel side in the model, {FOOTPRINT}: each rendered "
                        "pixel averages the normals it spans (default 2; 1: pixel centres, a "
                        "quarter of the model's time)")
    g.add_argument("--max-level", type=MAX_LEVEL, default=None, metavar="L",
                   help=f"the model's finest grid level, {MAX_LEVEL} (default 9; 10 resolves "
                        "nets to 512 spp, 11 to 1024)")


def dispatch(args: argparse.Namespace, output: CommandOutput) -> int | None:
    """Check the flags of both parts (one line, exit 2, before any work); with a renderer's
    name run the rendered check and return its exit code, else None (``validate`` goes on)."""
    from envfit.base import ParameterError
    from envfit.validate import rendered_renderers
    rendered = rendered_renderers()
    if args.renderer not in (None, "rules", *rendered):
        raise ParameterError(f"--renderer takes {' or '.join(rendered)} (or nothing: "
                             f"envfit's rules), got {args.renderer!r}")
    check_flags(args)
    return None if args.renderer in (None, "rules") else run(args, output)


def check_flags(args: argparse.Namespace) -> None:
    """One line for flags given to the wrong part, before any work."""
    from envfit.base import ParameterError
    rendered = args.renderer not in (None, "rules")
    if not rendered:
        given = [f for f, k in _FLAGS.items() if getattr(args, k) is not None]
        if given:
            names = " or ".join(_rendering()[0].split("|"))
            raise ParameterError(f"{', '.join(given)} need(s) --renderer {names}")
        return
    given = [f for f, k in _RULES_FLAGS.items() if getattr(args, k) is not None]
    if given:
        raise ParameterError(f"{', '.join(given)} belong(s) to --renderer alone (envfit's "
                             f"rules), not to --renderer {args.renderer}")


def options(args: argparse.Namespace, cache_dir):
    """The :class:`RenderValidationOptions` of the flags (checked: one line, exit 2)."""
    from envfit.base import ParameterError
    from envfit.validate import RenderValidationOptions
    brdfs = args.brdf or ["diffuse"]
    if len(brdfs) != 1:
        raise ParameterError(f"--brdf with --renderer {args.renderer} takes one BSDF, got "
                             f"{','.join(brdfs)}")
    kw = {k: tuple(getattr(args, k)) for k in ("samplers", "strategies", "spp")
          if getattr(args, k) is not None}
    kw.update({k: getattr(args, k) for k in ("resolution", "reference_spp", "frames",
                                             "max_level", "footprint")
               if getattr(args, k) is not None})
    _check_samplers(args)
    from envfit.cli._advise_renderer import bsdf_params_of
    return RenderValidationOptions(args.renderer, brdf=brdfs[0],
                                   alpha=alpha_of(args, brdfs[0]),
                                   bsdf_params=bsdf_params_of(args.bsdf_param),
                                   seed=args.seed, cache_dir=str(cache_dir), **kw)


def alpha_of(args: argparse.Namespace, brdf: str | None = None) -> float | None:
    """The microfacet alpha of ``--alpha`` or of ``--roughness`` read as the renderer's own
    value (the record's roughness convention, ``brdf``'s own where it has one,
    :meth:`envfit.renderers.RoughnessConvention.to_alpha`, as ``advise``), within
    ``--alpha``'s range (one line naming the flag given)."""
    from envfit.base import ParameterError
    if args.roughness is None:
        return args.alpha
    from envfit.renderers import RENDERERS, get_renderer
    p = get_renderer(args.renderer)
    convention = p.roughness if brdf is None else p.roughness_of(brdf)
    if convention is None:
        names = tuple(r.name for r in RENDERERS.values() if r.roughness)
        raise ParameterError(f"renderer must be one of {names}, got {args.renderer!r}")
    alpha = convention.to_alpha(args.roughness)
    if not ALPHA.inside(alpha):
        rule = convention.rule
        raise ParameterError(f"--roughness {args.roughness:g} gives alpha = {alpha:g} for "
                             f"{args.renderer} ({rule}), outside {ALPHA}")
    return alpha


def _check_samplers(args: argparse.Namespace) -> None:
    """``--samplers``: names of the renderer's samplers (one line naming the flag)."""
    from envfit.base import ParameterError
    from envfit.renderers import get_renderer
    p = get_renderer(args.renderer)
    bad = [s for s in (args.samplers or ()) if s not in p.samplers]
    if bad:
        raise ParameterError(f"--samplers for {args.renderer} must be one of "
                             f"{', '.join(p.modelled_samplers)}; got {bad[0]!r}")
    for s in args.samplers or ():
        p.sampler(s)                    # one line for a sampler envfit does not predict


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.advisor import default_cache_dir
    from envfit.base import atomic_write_csv, atomic_write_json
    from envfit.base import progress_bar
    from envfit.cli._common import load_map_from_args, out_dir
    from envfit.validate import check_renderer, render_validation, rendered_summary_lines
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
    output.say(*rendered_summary_lines(result))
    if out is not None:
        from envfit.plots import plot_rendered
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

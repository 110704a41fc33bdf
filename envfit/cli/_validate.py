"""``envfit validate``: predicted errors against ground-truth shading integrals (Figs. 7–8)."""
from __future__ import annotations

import argparse

from envfit.defaults import DEFAULT_SHININESS, FIT_METHODS
from envfit.cli._common import (add_common_arguments, add_map_arguments, load_map_from_args,
                                out_dir, str_list)
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import PIXELS, Ranged, check_pixels

#: the ranges of the options (``--help`` and the errors say these words): the lower bounds
#: are envfit.validate._config.ValidateConfig's, the upper ones fixed caps (the optimal
#: weights solve an N x N system; the cells' work grows with the axes and degrees)
S_RANGE = Ranged(1, 2, "s", integer=False, lo_open=True, hi_open=True, literals=("auto",))
SHININESS = Ranged(0, 10000, "n", integer=False, lo_open=True)
N_VALUES = Ranged(2, 16384, "N", many=True)
AXES = Ranged(2, 100000, "M")
FIT_N = Ranged(10, None, "N", hi_text=PIXELS)
SH_L = Ranged(0, 64, "L", many=True)
HSH_L = Ranged(0, 32, "L", many=True)
HSH_AXES = Ranged(2, 100000, "M")
HSH_HEIGHT = Ranged(2, 1024, "H")
RENDERER_N = Ranged(1, 65536, "N", many=True)


def register(sub) -> None:
    from envfit.validate import QUICK_DESCRIPTION
    p = sub.add_parser(
        "validate",
        help="check predicted quadrature / truncation errors against measured ones on a map",
        description="For each BRDF, point set, weighting and N: the RMSE over M random axes of "
                    "the quadrature estimates (importance-sampled point sets, rotated and "
                    "twisted per axis) against the exact shading integrals, next to the "
                    "worst-case error for the map's fitted s — shape only (one fitted factor "
                    "per BRDF, as the paper) and absolute (sigma*wce under the Gaussian-process "
                    "reading). Likewise RMSE vs L for SH/HSH truncation. Writes plots and "
                    "report.md to --out; resumable there.",
        epilog=QUICK_DESCRIPTION.replace("%", "%%"))
    add_map_arguments(p)
    p.add_argument("--s", type=S_RANGE, default="auto", metavar="auto|VALUE",
                   help=f"smoothness of the prediction: 'auto' (fit it, default) or a value, "
                        f"{S_RANGE}")
    p.add_argument("--brdf", type=str_list, default=None, metavar="diffuse,glossy",
                   help="BRDFs (default: diffuse,glossy)")
    p.add_argument("--shininess", type=SHININESS, default=DEFAULT_SHININESS,
                   help=f"glossy exponent n, {SHININESS} (default: {DEFAULT_SHININESS:g})")
    p.add_argument("--pointsets", type=str_list, default=None, metavar="sf,sobol,…",
                   help="point sets among sf, sobol, lp, bnot, random, jitter (default: all six; "
                        "--quick: without bnot)")
    p.add_argument("--weights", type=str_list, default=None, metavar="equal,osw",
                   help="weightings (default: equal,osw)")
    p.add_argument("--n", type=N_VALUES, default=None, metavar="N1,N2,…",
                   help=f"numbers of samples, each {N_VALUES} (default: 16,32,…,4096; --quick: "
                        "16…1024)")
    p.add_argument("--axes", type=AXES, default=None, metavar="M",
                   help=f"number of random axes, {AXES} (default: 2000; --quick: 500)")
    p.add_argument("--scale", choices=("display", "linear", "log"), default="display",
                   help="value scale of the integrand and of the fit (default: display)")
    p.add_argument("--fit-method", choices=FIT_METHODS, default="likelihood",
                   help="criterion of the s fit for --s auto (default: likelihood)")
    p.add_argument("--fit-n", type=FIT_N, default=None, metavar="N",
                   help=f"samples of the s / sigma fit, {FIT_N} (default: 1500; --quick: 600)")
    p.add_argument("--no-truncation", action="store_true", help="skip the SH/HSH truncation part")
    p.add_argument("--sh-L", type=SH_L, default=None, metavar="L1,L2,…",
                   help=f"SH cut-off degrees, each {SH_L} (default: 0…20; --quick: 0…12)")
    p.add_argument("--hsh-L", type=HSH_L, default=None, metavar="L1,L2,…",
                   help=f"glossy HSH cut-off degrees, each {HSH_L} (default: 0…16; --quick: "
                        "0…10)")
    p.add_argument("--hsh-axes", type=HSH_AXES, default=None, metavar="M",
                   help=f"axes of the HSH measurement, {HSH_AXES} (default: 250; --quick: 100)")
    p.add_argument("--hsh-max-height", type=HSH_HEIGHT, default=None, metavar="H",
                   help=f"map rows for the HSH measurement, {HSH_HEIGHT} (default: 128; "
                        "--quick: 64)")
    p.add_argument("--quick", action="store_true",
                   help="a reduced run in under a minute (map at most 256 rows; see below)")
    _add_renderer_arguments(p)
    from envfit.cli._validate_render import add_arguments
    add_arguments(p)
    add_common_arguments(p)
    p.set_defaults(func=run)


def _add_renderer_arguments(p) -> None:
    """``--renderer`` and the options of its rules."""
    g = p.add_argument_group("renderer rules (--renderer)")
    from envfit.cli._validate_render import _rendering
    names = _rendering()[0]
    g.add_argument("--renderer", nargs="?", const="rules", default=None,
                   metavar=names,
                   help="alone: also validate the renderer estimators (BRDF, map, MIS, sources + "
                        "MIS sampling): predicted vs measured RMSE with a 95 %% interval, after "
                        "the paper's cells, on --scale (linear is what renderers integrate); "
                        f"writes renderer.png. With a renderer's name ({names.replace('|', ', ')}): that "
                        "renderer renders a sphere with --brdf (diffuse, ggx, beckmann or "
                        "roughplastic) and "
                        "its measured RMSE is set beside the renderer model's prediction; "
                        "nothing else is run (options under 'rendering')")
    g.add_argument("--strategies", type=str_list, default=None, metavar="brdf,map,mis,split",
                   help="renderer strategies (default: all four; rendered: those the renderer "
                        "renders, of brdf, map, mis)")
    g.add_argument("--renderer-pointsets", type=str_list, default=None, metavar="random,sobol,sf",
                   help="point sets of the renderer rules (default: random,sobol,sf)")
    g.add_argument("--renderer-n", type=RENDERER_N, default=None, metavar="N1,N2,…",
                   help=f"sample counts of the renderer rules, each {RENDERER_N} (default: "
                        "16,64,256,1024; --quick: 16,256)")
    g.add_argument("--renderer-axes", default=None, metavar="importance|uniform",
                   help="how the renderer measurement draws its axes: importance-sampled "
                        "from the map's axis proposal and weighted (default), or uniform")


def _check_names(args: argparse.Namespace) -> None:
    """The names of ``--brdf``, ``--pointsets``, ``--weights`` and the renderer rules' flags,
    each one of its choices (one line naming the flag given), before any work."""
    from envfit.base import ParameterError
    from envfit.defaults import BRDFS, WEIGHTINGS
    from envfit.measure import AXIS_SAMPLING
    from envfit.sampling import STRATEGIES
    from envfit.theory import POINTSETS
    rendered = args.renderer not in (None, "rules")      # its --brdf: _validate_render's check
    for flag, what, values, allowed in (
            ("--brdf", "BRDF", None if rendered else args.brdf, BRDFS),
            ("--pointsets", "point set", args.pointsets, tuple(POINTSETS)),
            ("--weights", "weighting", args.weights, WEIGHTINGS),
            ("--strategies", "strategy", None if rendered else args.strategies,
             tuple(STRATEGIES)),
            ("--renderer-pointsets", "point set", args.renderer_pointsets, tuple(POINTSETS)),
            ("--renderer-axes", "axis sampling",
             None if args.renderer_axes is None else [args.renderer_axes],
             tuple(AXIS_SAMPLING))):
        bad = [v for v in (values or ()) if str(v).strip().lower() not in allowed]
        if bad:
            raise ParameterError(f"{flag}: unknown {what} {bad[0]!r}; choose from "
                                 f"{', '.join(allowed)}")


def _config(args: argparse.Namespace):
    from envfit.fit import parse_s
    from envfit.validate import ValidateConfig
    from envfit.validate import quick_config
    s = parse_s(args.s)                      # a bad --s: ParameterError, one line, exit 2
    over = {"s": s, "shininess": args.shininess, "scale": args.scale, "seed": args.seed,
            "fit_method": args.fit_method, "truncation": not args.no_truncation}
    for key, val in (("brdfs", args.brdf), ("pointsets", args.pointsets), ("weights", args.weights),
                     ("n_values", args.n), ("axes", args.axes), ("fit_n", args.fit_n),
                     ("sh_L", args.sh_L), ("hsh_L", args.hsh_L), ("hsh_axes", args.hsh_axes),
                     ("hsh_max_height", args.hsh_max_height)):
        if val is not None:
            over[key] = val
    return quick_config(**over) if args.quick else ValidateConfig(**over)


def _renderer_config(args: argparse.Namespace, cfg):
    """The renderer validation's configuration (None without ``--renderer``); the renderer
    options without it are an error. Checked before any work."""
    from envfit.base import ParameterError
    from envfit.validate import renderer_config
    given = [flag for flag, v in (("--strategies", args.strategies),
                                  ("--renderer-pointsets", args.renderer_pointsets),
                                  ("--renderer-n", args.renderer_n),
                                  ("--renderer-axes", args.renderer_axes)) if v is not None]
    if args.renderer != "rules":
        if given:
            raise ParameterError(f"{', '.join(given)} need(s) --renderer")
        return None
    return renderer_config(args.quick, strategies=args.strategies,
                           pointsets=args.renderer_pointsets, n_values=args.renderer_n,
                           axis_sampling=args.renderer_axes, lobes=cfg.brdfs,
                           shininess=cfg.shininess, seed=cfg.seed)


def _summary(res: dict) -> list[str]:
    agr = res["agreement"]
    lo, hi = agr["slope_range"]
    lines = [f"s = {res['s']:.3f} ({res['fit']['source']}), sigma = {res['sigma']:.4g} "
             f"({res['scale']} scale), M = {res['axes']} axes"]
    if res.get("s_refined") is not None:
        lines.append(f"s' = {res['s_refined']:.3f}, sigma' = {res['sigma_refined']:.4g} (band-limited "
                     f"fit, L = {res['fit_refined'].get('band_lmax')}, samples at pixel centres: "
                     "prediction (b'))")
    lines += ["",
             f"slopes over N = {lo}…{hi} (measured / predicted / refined b'):"]
    for s in agr["slopes"]:
        f = (lambda v: "  –   " if v is None else f"{v:+.3f}")
        lines.append(f"  {s['brdf']:8s} {s['pointset']:7s} {s['weights']:6s} "
                     f"{f(s['measured'])} / {f(s['predicted'])} / {f(s.get('predicted_refined'))}")
    for k in agr["rank"]:
        tau = "–" if k["kendall_tau"] is None else f"{k['kendall_tau']:.3f}"
        lines.append(f"rank {k['brdf']}/{k['weights']}: measured {' < '.join(k['measured_order'])}; "
                     f"predicted {' < '.join(k['predicted_order'])}; tau = {tau}")
    for key, label in (("slope_range", "(b) sigma*wce"), ("slope_range_refined", "(b') refined"),
                       ("slope_range_spectral", "(c) spectral")):
        d = agr["absolute"].get(key)
        if d:
            lines.append(f"{label}: predicted/measured median {d['median_ratio']:.2f}, range "
                         f"{d['min_ratio']:.2f}…{d['max_ratio']:.2f}, {d['fraction_within']:.0%} within "
                         f"{agr['absolute']['tolerance']:.0%}")
    a = agr["acceptance"]
    lines.append(f"acceptance: slopes {'ok' if a['slopes_ok'] else 'NO'} "
                 f"({a['slopes_within']}/{a['slopes_checked']}), rank {'ok' if a['rank_ok'] else 'NO'}, "
                 f"absolute (b) {'ok' if a['absolute_ok'] else 'NO'}")
    return lines


#: ``--quick`` without ``--max-height``: the map downscaled to at most this many rows
QUICK_HEIGHT = 256


def _checked_inputs(args: argparse.Namespace):
    """The configurations and the map, every option checked before the work."""
    _check_names(args)
    cfg = _config(args)
    rcfg = _renderer_config(args, cfg)
    env = load_map_from_args(args, quick_height=QUICK_HEIGHT)
    if args.s == "auto":
        check_pixels(FIT_N, "--fit-n", cfg.fit_n, env)    # the fit's N, before the work
    return cfg, rcfg, env


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.base import atomic_write_json
    from envfit.cli._validate_render import dispatch
    from envfit.validate import run_validation
    rendered = dispatch(args, output)        # --renderer NAME: that renderer's check only
    if rendered is not None:
        return rendered
    cfg, rcfg, env = _checked_inputs(args)
    out = out_dir(args)
    for note in getattr(env, "notes", []):
        output.say(f"note: {note}")
    output.say(f"map {env.name}: {env.width}x{env.height}, {env.channels} channel(s)"
               + (f"; cells in {out} (resumable)" if out else "; use --out DIR for plots, report.md "
                                                         "and resuming"))
    resumed = []

    def on_cell(key, was_resumed):
        if was_resumed:
            resumed.append(key)

    result = run_validation(env, cfg, out=out, quiet=args.quiet, on_cell=on_cell, renderer=rcfg)
    output.record_unwritten(result.unwritten)
    res = result.to_json()                   # what the report, the plots and --json take
    res["resumed_cells"] = len(resumed)
    if resumed:
        output.say(f"resumed {len(resumed)} finished cell(s) from {out}")
    output.say(*_summary(res))
    if res.get("renderer"):
        from envfit.validate import summary_lines
        output.say("", *summary_lines(res["renderer"]))
    if out is not None:
        from envfit.plots import plot_all
        from envfit.validate import write_report
        files = output.guarded_write(f"the figures in {out}", plot_all, res, out)
        files = {} if files is None else files
        if res.get("renderer"):
            from envfit.plots import plot_renderer
            png = output.guarded_write(out / "renderer.png", plot_renderer, res["renderer"],
                                       out / "renderer.png")
            if png is not None:
                files["renderer"] = str(png)
        figures = len(files)
        report = output.guarded_write(out / "report.md", write_report, res, out / "report.md", files)
        if report is not None:
            files["report.md"] = str(report)
        res["files"] = files
        if output.guarded_write(out / "validate.json", atomic_write_json, out / "validate.json",
                                res) is not None:
            res["files"]["validate.json"] = str(out / "validate.json")
        written = ([f"{figures} figure(s)"] if figures else []) + [
            files[k] for k in ("report.md", "validate.json") if k in files]
        if written:
            output.say("wrote " + ", ".join(written))
    output.say(f"({res['timings']['total']:.0f} s)")
    output.emit_json(res)
    return 0

"""``envfit advise``: how many samples, or which SH/HSH degree, for this map, BRDF and target error."""
from __future__ import annotations

import argparse
from pathlib import Path

from envfit.base._notes import NoteKind, note_kind
from envfit.defaults import BRDFS, DEFAULT_SHININESS, MICROFACET_BSDFS, PREDICTOR_CHOICES
from envfit.cli._common import (add_common_arguments, add_map_arguments, load_map_from_args,
                                out_dir, positive_float, positive_int, str_list)
from envfit.cli._advise_preset import add_preset_arguments, reject_without_renderer, run_preset
from envfit.cli._output import CommandOutput


def register(sub) -> None:
    p = sub.add_parser(
        "advise",
        help="smallest N per point set / weighting and smallest SH/HSH degree for a target error",
        description="Predict the RMS shading error of each rule two ways and find the "
                    "smallest N (bisection) or L whose prediction is at most the target "
                    "(default: 1%% of the map's mean shading value, on the linear scale). "
                    "(b'): fit the map's smoothness s' and scale sigma' under the model of an "
                    "H-row map (kernel band-limited at degree H-1, samples at pixel centres; "
                    "cached); sigma' times the rule's worst-case error summed to degree H-1 "
                    "with degree l weighted by the bilinear lookup's transfer tau_l (Eq. 42; "
                    "Eqs. 51-52 for SH/HSH truncation), plus the error on the map's mean when "
                    "the weights do not sum to 1. (c): the map's own power per degree (of its "
                    "bilinear interpolant, to degree 2H-1) times the rule's error power, the "
                    "exact mean over random rotations (SH truncation too; HSH: (b') only). "
                    "--predictor auto (default) sizes by (c) on the linear scale and wherever "
                    "(b') and (c) disagree by more than 1.25x (with a warning line), else by "
                    "(b'). Prints a table sorted by cost (N samples, or (L+1)^2 coefficients) "
                    "and a recommendation; --check measures the actual RMSE at the chosen N/L "
                    "on the map.")
    add_map_arguments(p)
    p.add_argument("--brdf", choices=BRDFS + MICROFACET_BSDFS, default="diffuse",
                   help="weight function (default: diffuse); with --renderer only: ggx, "
                        "beckmann (white conductors), roughplastic (Mitsuba's), with --roughness")
    p.add_argument("--shininess", type=positive_float, default=DEFAULT_SHININESS,
                   help=f"glossy exponent n (default: {DEFAULT_SHININESS:g})")
    tg = p.add_mutually_exclusive_group()
    tg.add_argument("--target-rmse", type=positive_float, metavar="E",
                    help="target RMS shading error, on the --scale values")
    tg.add_argument("--target-relative", type=positive_float, metavar="F",
                    help="target as a fraction (0 < F < 1) of the map's mean shading value "
                         "(default, when neither is given: 0.01)")
    p.add_argument("--scale", choices=("linear", "display", "log"), default="linear",
                   help="value scale of the integrand and the fit (default: linear, the raw "
                        "radiance a renderer integrates)")
    p.add_argument("--predictor", choices=PREDICTOR_CHOICES, default="auto",
                   help="prediction that sizes N/L: auto (default: (c) on the linear scale and "
                        "where (b') and (c) disagree by > 1.25x, else (b')), bandlimited (b'), "
                        "spectral (c)")
    p.add_argument("--pointsets", type=str_list, default=None, metavar="sf,sobol,…",
                   help="point sets among sf, sobol, lp, bnot, random, jitter (default: "
                        "sf,sobol,lp,random,jitter; bnot costs ~15 s per realisation at N = 4096)")
    p.add_argument("--weights", type=str_list, default=None, metavar="equal,osw",
                   help="weightings (default: equal,osw)")
    p.add_argument("--bases", type=str_list, default=None, metavar="sh,hsh",
                   help="truncations to size (default: sh,hsh; 'none' for none)")
    p.add_argument("--s", default="auto", metavar="auto|VALUE",
                   help="smoothness: 'auto' (band-limited likelihood fit, default) or a value "
                        "in (1, 2) (sigma then by the band-limited likelihood at that s)")
    p.add_argument("--fit-n", type=positive_int, default=None, help="samples of the fit (default: 3000)")
    p.add_argument("--nmin", type=positive_int, default=None, help="smallest N searched (default: 4)")
    p.add_argument("--nmax", type=positive_int, default=None, help="largest N searched (default: 65536)")
    p.add_argument("--osw-nmax", type=positive_int, default=None,
                   help="largest N searched with optimal weights (an NxN solve; default: 4096)")
    p.add_argument("--realisations", type=positive_int, default=None, metavar="K",
                   help="realisations averaged per N for random/jitter/bnot (default: 4)")
    _add_check_and_cache_arguments(p)
    add_preset_arguments(p)
    add_common_arguments(p)
    p.set_defaults(func=run)


def _add_check_and_cache_arguments(p) -> None:
    """--check and its axes, the renderer rows' options, the cache's options."""
    p.add_argument("--check", action="store_true",
                   help="measure the RMSE at the chosen N/L on the map, beside the prediction")
    p.add_argument("--axes", type=positive_int, default=1000, metavar="M",
                   help="random axes of --check (default: 1000, seeded by --seed)")
    _add_renderer_arguments(p)
    p.add_argument("--no-cache", action="store_true",
                   help="neither read nor write the cache of fits and wce curves")
    p.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                   help="cache folder (default: $ENVFIT_CACHE_DIR or ~/.cache/envfit)")


def _add_renderer_arguments(p) -> None:
    """The renderer rows' options (strategies, point sets, spectra, check axes)."""
    rg = p.add_argument_group("renderer rows")
    rg.add_argument("--strategies", type=str_list, default=None, metavar="brdf,map,mis,split",
                    help="renderer strategies to size: brdf (BRDF sampling), map (map importance "
                         "sampling), mis (multi-sample MIS, N/2 each), split (bright sources "
                         "integrated exactly + MIS on the rest) (default: all four)")
    rg.add_argument("--renderer-pointsets", type=str_list, default=None,
                    metavar="sobol,sf,random",
                    help="point sets of the renderer rules (default: sobol,sf,random; also "
                         "jitter, lp, bnot)")
    rg.add_argument("--no-renderer", action="store_true",
                    help="no renderer rows: the quadrature and SH/HSH table only")
    rg.add_argument("--renderer-grid", type=positive_int, default=None, metavar="G",
                    help="grid of the warped spectra (a multiple of 4; QMC predictions exact to "
                         "N ~ (G/8)^2; default: 512)")
    rg.add_argument("--renderer-spectrum-axes", type=positive_int, default=None, metavar="K",
                    help="axes of the warped spectra's sample over the sphere (default: 32)")
    rg.add_argument("--renderer-axes-start", type=positive_int, default=None, metavar="M",
                    help="--check of the renderer rows: axes of the first round of the adaptive "
                         "measurement (default: 250)")
    rg.add_argument("--renderer-max-axes", type=positive_int, default=None, metavar="M",
                    help="--check of the renderer rows: at most this many axes (the measurement "
                         "doubles them until its 95%% interval is within +-10%%; default: 4000)")


def _header(adv) -> list[str]:
    lines = [f"map {adv.map}: {adv.map_size[0]}x{adv.map_size[1]}, {adv.channels} channel(s); "
             f"{adv.scale_description}"]
    if adv.s_interval:
        s_txt = f"s = {adv.s:.3f} (95% {adv.s_interval[0]:.3f}…{adv.s_interval[1]:.3f})"
    else:
        s_txt = f"s = {adv.s:.3f} (given)"
    kern = (f"kernel band-limited at l <= {adv.fit_band_lmax}, {adv.fit_samples} pixel "
            f"centres" if adv.fit_kernel == "bandlimited" else f"{adv.fit_kernel} kernel")
    lines.append(f"{s_txt}, sigma = {adv.sigma:.4g} ({kern}"
                 + ("; cached fit)" if adv.fit_cached else f"; {adv.fit_source})"))
    lobe = adv.brdf if adv.shininess is None else f"glossy n = {adv.shininess:g}"
    rel = (f" = {adv.target_relative:g} x mean shading {adv.mean_shading:.4g}"
           if adv.target_relative is not None else
           f" ({adv.target_rmse / adv.mean_shading:.2%} of the mean shading {adv.mean_shading:.4g})"
           if adv.mean_shading > 0 else "")
    lines.append(f"target RMSE {adv.target_rmse:.4g}{rel}; {lobe}; map band limit l <= "
                 f"{adv.band_lmax}")
    tau = adv.lookup_transfer
    if tau:
        degrees = sorted({min(20, len(tau) - 1), len(tau) // 2, len(tau) - 1})
        lines.append("bilinear lookup transfer tau_l: "
                     + ", ".join(f"{tau[l]:.3f} at l = {l}" for l in degrees))
    lines.append("(b') = sigma * sqrt(sum_{l<=H-1} a_l tau_l e_l) (+ mean term of sum(w) != 1; "
                 "SH with tau, HSH without); (c) = sqrt(mean_c sum_{l<=2H-1} P_lc e_l), the "
                 f"map's own power to l = {adv.spectral_lmax} (no (c) for HSH); pred = the one "
                 "that chose N/L; sigma*wce = unrestricted Eq. 41 / Eqs. 51-52")
    return lines


def _check_lines(adv) -> list[str]:
    c = adv.check or {}
    out = [f"check: RMSE over {c.get('axes')} random axes (seed {adv.settings['seed']}) at the "
           f"chosen N/L"]
    if "median_measured_over_predicted" in c:
        out.append(f"measured/predicted (the predictor used): median "
                   f"{c['median_measured_over_predicted']:.2f}, range "
                   f"{c['min_measured_over_predicted']:.2f}…{c['max_measured_over_predicted']:.2f}"
                   + "".join(f"; measured/{lab} median {c[k]:.2f}" for lab, k in
                             (("(b')", "median_measured_over_bandlimited"),
                              ("(c)", "median_measured_over_spectral")) if k in c))
    if "recommended_measured_rmse" in c:
        out.append(f"recommended rule: measured {c['recommended_measured_rmse']:.3g} = "
                   f"{c['recommended_measured_over_target']:.2f} x target")
    return out


def _renderer_lines(adv) -> list[str]:
    """The renderer section: its sources, target and table (none without it)."""
    r = adv.renderer
    if r is None:
        return []
    src = (f"{len(r.sources)} bright source(s), {r.source_pixels} pixel(s) (the split's exact "
           f"integral visits each once per shading point: its cost beside N)"
           if r.sources else "no bright source (split = MIS on the whole map)")
    lines = [f"renderer rules (strategy/point set; N on a renderer's grid from {r.nmin} to "
             f"{r.nmax}; predicted by the warped spectra, grid {r.grid}, {r.spectrum_axes} "
             f"axes{'; cached' if r.spectra_computed == 0 else ''}): {src}"]
    lines += r.table_lines()
    c = r.check
    if c is not None:
        lines.append(f"renderer check: adaptive RMSE (95% bootstrap interval, to +-10%) over "
                     f"{c['axes_start']}..{c['max_axes']} random axes (seed {c['seed']}); max "
                     f"measured/target "
                     + ("–" if c["max_measured_over_target"] is None
                        else f"{c['max_measured_over_target']:.2f}")
                     + (f"; above 1.25: {', '.join(c['rows_over_1_25'])}"
                        if c["rows_over_1_25"] else ""))
    return lines


def options_from_args(args: argparse.Namespace):
    """The :class:`envfit.advisor._options.AdviseOptions` of the command line (an option not
    given keeps the dataclass's default; ``--bases none`` is no basis)."""
    from envfit.advisor._options import AdviseOptions
    given = {"pointsets": args.pointsets, "weights": args.weights, "fit_n": args.fit_n,
             "nmin": args.nmin, "nmax": args.nmax, "osw_nmax": args.osw_nmax,
             "seeds": args.realisations, "strategies": args.strategies,
             "renderer_pointsets": args.renderer_pointsets,
             "renderer_grid": args.renderer_grid,
             "renderer_spectrum_axes": args.renderer_spectrum_axes,
             "renderer_axes_start": args.renderer_axes_start,
             "renderer_max_axes": args.renderer_max_axes}
    if args.bases is not None:
        given["bases"] = () if [b.lower() for b in args.bases] == ["none"] else tuple(args.bases)
    return AdviseOptions(
        brdf=args.brdf, target_rmse=args.target_rmse, target_relative=args.target_relative,
        shininess=args.shininess, scale=args.scale, predictor=args.predictor, s=args.s,
        seed=args.seed, check=args.check,
        axes=args.axes, cache=not args.no_cache, cache_dir=args.cache_dir, quiet=args.quiet,
        renderer=not args.no_renderer, renderer_curves=args.out is not None,
        **{k: v for k, v in given.items() if v is not None})


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.advisor._advise import advise_with
    from envfit.base._atomic import atomic_write_csv, atomic_write_json
    if args.renderer is not None:
        return run_preset(args, output)
    reject_without_renderer(args)
    opts = options_from_args(args)          # bad names and values: one line, before the map
    env = load_map_from_args(args)
    out = out_dir(args)
    output.say(*(f"note: {n}" for n in env.notes))      # the map's notes, before the work
    adv = advise_with(env, opts)
    said_before = output.has_note(NoteKind.CACHE_OFF)    # on stderr, before the work
    for note in adv.notes:
        if (said_before and note_kind(note) is NoteKind.CACHE_OFF) or note in env.notes:
            continue
        output.say(f"note: {note}")
    output.say(*_header(adv), *adv.table_lines(), *_renderer_lines(adv),
               *(f"warning: {w}" for w in adv.warnings), adv.recommendation)
    if adv.renderer is not None:
        output.say(adv.renderer.recommendation)
    if adv.check is not None:
        output.say(*_check_lines(adv))
    t = adv.timings
    output.say(f"({t['total']:.1f} s: fit {t['fit']:.1f}, search {t['search']:.1f}"
               + (f", renderer model {t['renderer_model']:.1f}, renderer rows "
                 f"{t['renderer_search']:.1f}" if adv.renderer is not None else "")
               + (f", check {t['check']:.1f}" if adv.check is not None else "")
               + (f", renderer check {t['renderer_check']:.1f}" if "renderer_check" in t else "")
               + f"; cache {adv.cache['hits']} hit(s), {adv.cache['writes']} write(s))")
    d = adv.to_dict()
    if out is not None and adv.renderer is not None:
        from envfit.plots._advise import plot_advise
        png = output.guarded_write(out / "advise.png", plot_advise, d, out / "advise.png")
        if png is not None:
            output.say(f"wrote {png}")
    if out is not None:
        from envfit.plots._advise_rules import plot_advise_rules
        png = output.guarded_write(out / "advise_rules.png", plot_advise_rules, d,
                                   out / "advise_rules.png")
        if png is not None:
            output.say(f"wrote {png}")
        cols = ["label", "method", "pointset", "weights", "n", "L", "cost", "predictor",
                "predicted_rmse", "predicted_rmse_spectral", "predicted_rmse_spectral_band",
                "predicted_rmse_plain", "measured_rmse", "measured_over_predicted", "note"]
        csv_path = output.guarded_write(out / "advise.csv", atomic_write_csv, out / "advise.csv",
                                        cols, [[r.get(c) for c in cols] for r in d["rows"]])
        json_path = output.guarded_write(out / "advise.json", atomic_write_json,
                                         out / "advise.json", d)
        d["files"] = {k: str(v) for k, v in (("csv", csv_path), ("json", json_path))
                      if v is not None}
        if d["files"]:
            output.say("wrote " + " and ".join(d["files"].values()))
    output.emit_json(d)
    return 0

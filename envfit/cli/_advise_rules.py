"""envfit's own rules in ``envfit advise``: their options from the command line, their run
(:func:`run_rules`) and their printed answer (the head, the renderer rows' section, the check),
which ``--renderer --rules`` (:mod:`~envfit.cli._advise_renderer`) prints too."""
from __future__ import annotations

import argparse

from envfit.base import ParameterError
from envfit.base import NoteKind, note_kind
from envfit.cli._output import CommandOutput

__all__ = ["header_lines", "check_lines", "renderer_lines", "options_from_args", "run_rules",
           "rules_lines"]


def header_lines(adv) -> list[str]:
    """The answer's head: the map, the fit of s and sigma, the target, the lookup transfer and
    what (b') and (c) are."""
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


def check_lines(adv) -> list[str]:
    """The --check lines: measured over predicted at the chosen N/L."""
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


def renderer_lines(adv) -> list[str]:
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
    from envfit.advisor import AdviseOptions
    _check_pairs(args, AdviseOptions())
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


def _check_pairs(args: argparse.Namespace, defaults) -> None:
    """The options whose range is another's (``--nmax`` ≥ ``--nmin``, ``--renderer-max-axes``
    ≥ ``--renderer-axes-start``): one line naming the flags given."""
    for hi, lo, hi_dest, lo_dest in (("--nmax", "--nmin", "nmax", "nmin"),
                                     ("--renderer-max-axes", "--renderer-axes-start",
                                      "renderer_max_axes", "renderer_axes_start")):
        top, bottom = getattr(args, hi_dest), getattr(args, lo_dest)
        if top is None or top >= (getattr(defaults, lo_dest) if bottom is None else bottom):
            continue
        raise ParameterError(f"{hi} {top} is below " + (
            f"{lo} {bottom}" if bottom is not None else
            f"the default {lo} {getattr(defaults, lo_dest)}"))


def rules_lines(rules_adv) -> list[str]:
    """``--renderer --rules``: envfit's rules' answer under its heading."""
    out = ["envfit's rules (quadrature and SH/HSH truncation on this map, as without "
           "--renderer):", *header_lines(rules_adv), *rules_adv.table_lines(),
           *(f"warning: {w}" for w in rules_adv.warnings), rules_adv.recommendation]
    if rules_adv.check is not None:
        out += check_lines(rules_adv)
    return out


def run_rules(args: argparse.Namespace, output: CommandOutput) -> int:
    """``envfit advise MAP`` without ``--renderer``: options → map (its notes said) →
    :func:`envfit.advisor.advise_with` → print → files and JSON."""
    from envfit.advisor import advise_with
    from envfit.base import atomic_write_csv, atomic_write_json
    from envfit.cli._common import load_map_from_args, out_dir
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
    output.say(*header_lines(adv), *adv.table_lines(), *renderer_lines(adv),
               *(f"warning: {w}" for w in adv.warnings), adv.recommendation)
    output.answer(adv.recommendation)                   # --quiet: the answer alone
    if adv.renderer is not None:
        output.say(adv.renderer.recommendation)
    if adv.check is not None:
        output.say(*check_lines(adv))
    t = adv.timings
    output.say(f"({t['total']:.1f} s: fit {t['fit']:.1f}, search {t['search']:.1f}"
               + (f", renderer model {t['renderer_model']:.1f}, renderer rows "
                 f"{t['renderer_search']:.1f}" if adv.renderer is not None else "")
               + (f", check {t['check']:.1f}" if adv.check is not None else "")
               + (f", renderer check {t['renderer_check']:.1f}" if "renderer_check" in t else "")
               + f"; cache {adv.cache['hits']} hit(s), {adv.cache['writes']} write(s))")
    d = adv.to_dict()
    if out is not None and adv.renderer is not None:
        from envfit.plots import plot_advise
        png = output.guarded_write(out / "advise.png", plot_advise, d, out / "advise.png")
        if png is not None:
            output.say(f"wrote {png}")
    if out is not None:
        from envfit.plots import plot_advise_rules
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

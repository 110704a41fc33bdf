"""``envfit theory figures``: PNG + CSV for the paper's Figs. 1–5 and a BNOT check.

A helper module of :mod:`envfit.cli._theory` (which registers it; not a subcommand of its own).
The numerics are in :mod:`envfit.theory._figures`, the checked claims in
:mod:`envfit.theory._claims`, the plots in :mod:`envfit.plots._theory`; this module parses,
prints and writes files.
"""
from __future__ import annotations

import argparse
import math
import time

from envfit.base import ParameterError
from envfit.defaults import DEFAULT_SHININESS
from envfit.cli._common import add_common_arguments, out_dir, str_list
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged
from envfit.cli._theory_common import (DEFAULT_SPLIT_LMAX, LMAX_CAP, MORPH_HELP, N_CAP,
                                       S_RANGE, SHININESS_HELP, SHININESS_RANGE,
                                       check_positive_int, check_s, check_shininess,
                                       progress_callback)

#: default folder of ``figures`` when --out is not given
DEFAULT_FIGURES_DIR = "theory_figures"
FIGURE_NAMES = ("1", "2", "3", "4", "5", "bnot")
#: the ranges of figures' options (``--help`` and the errors say these words); --n is also
#: the BNOT check's N (about 15 s at 4096, minutes at 8192)
FIG_N = Ranged(2, 8192, "N")
FIG_NMAX = Ranged(16, N_CAP, "N")
FIG_LMAX = Ranged(10, LMAX_CAP, "L")
CUTOFF_MAX = Ranged(1, 200, "L")
QMC_NMAX = Ranged(2, N_CAP, "N")


def register_figures(tsub) -> None:
    f = tsub.add_parser(
        "figures", help="PNG + CSV for the paper's Figs. 1-5 and a BNOT check",
        description="Fig. 1 power spectra d_l^2, C_l^2 (equal weights) and C_l^2 (OSW) of the six "
                    "point sets; Fig. 2 the first 10 C_l^2 (diffuse), equal vs OSW; Fig. 3 error "
                    "spectra e_l^2 = a_l (d_l^2 + C_l^2); Fig. 4 worst-case error vs N with "
                    "fitted slopes; Fig. 5 truncation error vs L with the QMC-equivalent N; and "
                    "the radial power spectrum and capacity check of BNOT. " + MORPH_HELP)
    f.add_argument("--n", type=FIG_N, default=256, metavar="N",
                   help=f"N of Figs. 1-3 and the BNOT check, {FIG_N} (default 256; BNOT takes "
                        "about 15 s at 4096, minutes at the top)")
    f.add_argument("--s", type=S_RANGE, default=1.5,
                   help=f"Sobolev smoothness, {S_RANGE} (default 1.5)")
    f.add_argument("--shininess", type=SHININESS_RANGE, default=DEFAULT_SHININESS,
                   help=SHININESS_HELP)
    f.add_argument("--nmax", type=FIG_NMAX, default=2048, metavar="N",
                   help=f"largest N of Fig. 4 (powers of two from 16), {FIG_NMAX} (default 2048; "
                        "a cap: each rule's closed form is an O(N^2) pair sum)")
    f.add_argument("--lmax", type=FIG_LMAX, default=DEFAULT_SPLIT_LMAX, metavar="L",
                   help=f"highest degree l of the spectra of Figs. 1 and 3, {FIG_LMAX} "
                        f"(default {DEFAULT_SPLIT_LMAX})")
    f.add_argument("--cutoff-max", type=CUTOFF_MAX, default=20, metavar="L",
                   help=f"largest cut-off degree L of Fig. 5, {CUTOFF_MAX} (default 20)")
    f.add_argument("--qmc-nmax", type=QMC_NMAX, default=16384, metavar="N",
                   help=f"top of the tabulated QMC curve E(N) inverted for Fig. 5, {QMC_NMAX} "
                        "(default 16384; "
                        "beyond it the N are extrapolated and marked so)")
    f.add_argument("--only", type=str_list, default=None, metavar="F1,F2,...",
                   help=f"draw only these figures, from {','.join(FIGURE_NAMES)} (default: all)")
    f.add_argument("--no-morph", action="store_true",
                   help="lift the points of Figs. 1-4 uniformly (no importance sampling)")
    add_common_arguments(f)
    f.set_defaults(func=run_figures, out_default=DEFAULT_FIGURES_DIR)  # preflight checks it


def _csv(path, comment: str, header, rows):
    """CSV with a leading ``# comment`` line (read with ``comment='#'``)."""
    import csv
    import io
    from envfit.base import atomic_write_text, to_jsonable
    buf = io.StringIO()
    buf.write("# " + comment.replace("\n", " ") + "\n")
    wr = csv.writer(buf)
    wr.writerow(header)
    for r in rows:
        wr.writerow(["" if (isinstance(v, float) and not math.isfinite(v)) else to_jsonable(v)
                     for v in r])
    return atomic_write_text(path, buf.getvalue())


def _morph_note(morphed: bool) -> str:
    return ("points morphed for the BRDF (importance sampling, Sec. 7.2)" if morphed
            else "points NOT morphed (uniform on the hemisphere)")


def _yes(claim, yes: str = "yes", no: str = "NO") -> str:
    return yes if claim.holds else no


def _sci(x: float) -> str:
    """Short scientific notation as the paper writes it: 4.4e-3, 1e-4."""
    m, e = f"{x:.1e}".split("e")
    return f"{m.rstrip('0').rstrip('.')}e{int(e)}"


def _int_or(x, empty):
    return int(x) if math.isfinite(x) else empty


class _FigureRun:
    """What every figure of one ``figures`` run shares: parameters, output folder, writer."""

    def __init__(self, args: argparse.Namespace, output: CommandOutput):
        self.args = args
        self.output = output
        self.s = check_s(args.s)
        self.shin = check_shininess(args.shininess)
        self.n = check_positive_int(args.n, "--n", 2)
        self.nmax = check_positive_int(args.nmax, "--nmax", 16)
        self.lmax = check_positive_int(args.lmax, "--lmax", 10)
        self.cutoff = check_positive_int(args.cutoff_max, "--cutoff-max", 1)
        self.qnmax = check_positive_int(args.qmc_nmax, "--qmc-nmax", 2)
        self.only = args.only or list(FIGURE_NAMES)
        bad = [x for x in self.only if x not in FIGURE_NAMES]
        if bad:
            raise ParameterError(f"--only: unknown figure(s) {bad}; choose from {list(FIGURE_NAMES)}")
        self.morphed = not args.no_morph
        self.seed = args.seed
        self.out = None
        self.files: dict[str, str] = {}
        self.common = (f"s = {self.s:g}, glossy n = {self.shin:g}, seed {self.seed}, "
                       f"{_morph_note(self.morphed)}")

    def save(self, name: str, write, *wargs) -> None:
        """Write one figure / CSV (``write(*wargs)``); a failure is recorded, not raised, so
        the other figures are still computed and the numbers printed."""
        path = self.output.guarded_write(self.out / name, write, *wargs)
        if path is not None:
            self.files[name] = str(path)

    def csv(self, name: str, comment: str, header, rows) -> None:
        self.save(name, _csv, self.out / name, comment, header, rows)

    def bar(self, total: int, desc: str):
        from envfit.base import progress_bar
        return progress_bar(total, desc=desc, quiet=self.args.quiet)


def run_figures(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.base import check_memory

    run = _FigureRun(args, output)
    m = max(run.n, run.nmax)
    check_memory(8 * m ** 2, f"the {m}x{m} kernel matrix of the optimal weights",
                 hint="lower --n / --nmax")
    run.out = out_dir(args, DEFAULT_FIGURES_DIR)
    result: dict = {"n": run.n, "s": run.s, "shininess": run.shin, "nmax": run.nmax,
                    "lmax": run.lmax, "seed": run.seed, "morphed": run.morphed,
                    "out": str(run.out), "files": run.files}
    t_all = time.perf_counter()
    if {"1", "2", "3"} & set(run.only):
        result["spectra"] = _figures_spectra(run)
    if "4" in run.only:
        result["convergence"] = _figure_convergence(run)
    if "5" in run.only:
        result["truncation"] = _figure_truncation(run)
    if "bnot" in run.only:
        result["bnot"] = _figure_bnot(run)
    result["seconds"] = time.perf_counter() - t_all
    output.say(f"wrote {len(run.files)} files to {run.out} in {result['seconds']:.1f} s")
    output.emit_json(result)
    return 0


def _figures_spectra(run: _FigureRun) -> dict:
    """Figs. 1-3: files, printed lines and the JSON part."""
    from envfit.theory import claims as C, figures as F
    import envfit.plots as P
    t0, n, out = time.perf_counter(), run.n, run.out
    with run.bar(len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS), "spectra (Figs. 1-3)") as bar:
        sd = F.spectra_data(n, run.s, run.shin, run.lmax, seed=run.seed, morph=run.morphed,
                            progress=progress_callback(bar))
    recs = sd.records.items()
    closeup = F.low_order_closeup(sd, "diffuse", 10)
    if "1" in run.only:
        run.save("fig1_power_spectra.png", P.plot_power_spectra, sd, out / "fig1_power_spectra.png")
        run.csv("fig1_power_spectra.csv",
                f"Fig. 1: zonal d_l^2 = (b_l - c_l0)^2 and anisotropic C_l^2 power spectra, N = {n}, "
                f"one realization; {run.common}", ("brdf", "pointset", "weights", "n", "l", "d2", "C2"),
                [(b, p, w, n, l, r.d2[l], r.C2[l]) for (b, w, p), r in recs for l in range(r.l.size)])
    if "2" in run.only:
        run.save("fig2_low_order_C2.png", P.plot_low_order_closeup,
                 closeup, n, run.morphed, out / "fig2_low_order_C2.png")
        run.csv("fig2_low_order_C2.csv",
                f"Fig. 2: first 10 anisotropic C_l^2 (l = 1..10), diffuse, N = {n}; {run.common}",
                ("pointset", "l", "C2_equal", "C2_osw"),
                [(ps, int(l), closeup.C2_equal[ps][i], closeup.C2_osw[ps][i])
                 for ps in sd.pointsets for i, l in enumerate(closeup.l)])
    if "3" in run.only:
        run.save("fig3_error_spectra.png", P.plot_error_spectra, sd, out / "fig3_error_spectra.png")
        run.csv("fig3_error_spectra.csv",
                f"Fig. 3: error spectra e_l^2 = a_l (d_l^2 + C_l^2), N = {n}; {run.common}",
                ("brdf", "pointset", "weights", "n", "l", "a", "d2", "C2", "e2"),
                [(b, p, w, n, l, r.a[l], r.d2[l], r.C2[l], r.e2[l])
                 for (b, w, p), r in recs for l in range(r.l.size)])
    dom, red = C.anisotropic_dominance_claim(sd), C.osw_low_order_claim(closeup)
    low = {ps: {"equal": red.values["sum_equal"][ps], "osw": red.values["sum_osw"][ps],
                "ratio": red.values["ratio"][ps]} for ps in sd.pointsets}
    lab, za = F.POINTSET_LABELS, dom.values["zonal_over_anisotropic"]
    run.output.say(f"Figs. 1-3 (N = {n}, l <= {run.lmax}): {time.perf_counter() - t0:.1f} s",
                   "  Fig. 2, sum of C_l^2 over l = 1..10 (diffuse), OSW / equal: "
                   + ", ".join(f"{lab[p]} {v['ratio']:.3g}" for p, v in low.items())
                   + _yes(red, "", "  (OSW do NOT reduce it for every set)"),
                   "  E_Z / E_A (diffuse, equal weights, l <= lmax): "
                   + ", ".join(f"{lab[p]} {za[p]:.2g}" for p in sd.pointsets)
                   + _yes(dom, "  (the anisotropic part dominates)",
               "  (the anisotropic part does NOT dominate for every set)"))
    return {"wce": {f"{b}/{w}/{p}": r.wce for (b, w, p), r in recs},
            "wce_zonal": {f"{b}/{w}/{p}": r.wce_zonal for (b, w, p), r in recs},
            "wce_anisotropic": {f"{b}/{w}/{p}": r.wce_anisotropic for (b, w, p), r in recs},
            "low_order_C2_sum_l1_10_diffuse": low}


def _figure_convergence(run: _FigureRun) -> dict:
    """Fig. 4: files, printed lines (slopes, claims) and the JSON part."""
    from envfit.theory import claims as C, figures as F
    import envfit.plots as P
    t0, out = time.perf_counter(), run.out
    with run.bar(len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS), "wce vs N (Fig. 4)") as bar:
        cd = F.convergence_data(run.nmax, run.s, run.shin, seed=run.seed, morph=run.morphed,
                                progress=progress_callback(bar))
    lo, hi = cd.fit_range
    run.save("fig4_wce_vs_n.png", P.plot_convergence, cd, out / "fig4_wce_vs_n.png")
    run.csv("fig4_wce_vs_n.csv",
            f"Fig. 4: worst-case error (Eq. 41) vs N, one realization, raw values; {run.common}",
            ("brdf", "weights", "pointset", "n", "wce"),
            [(b, w, p, int(nn), e) for (b, w, p), arr in cd.wce.items() for nn, e in zip(cd.ns, arr)])
    run.csv("fig4_slopes.csv",
            f"Fig. 4: least-squares slope of log wce vs log N over N = {lo:g}..{hi:g}; {run.common}",
            ("brdf", "weights", "pointset", "slope", "fit_nmin", "fit_nmax"),
            [(b, w, p, k, lo, hi) for (b, w, p), k in cd.slopes.items()])
    slope = {c.id: c for c in C.random_slope_claims(cd)}
    beats = C.structured_beat_random_claims(cd)
    lab = F.POINTSET_LABELS
    lines = [f"Fig. 4 (N = {int(cd.ns[0])}..{int(cd.ns[-1])}): {time.perf_counter() - t0:.1f} s",
             f"  convergence slopes (fit over N = {lo:g}..{hi:g}):"]
    lines += [f"    {b:<8}{w:<6}" + "  ".join(f"{lab[p]} {cd.slopes[(b, w, p)]:+.3f}" for p in cd.pointsets)
              for b in cd.brdfs for w in cd.weightings]
    for b in cd.brdfs:
        ce, co = slope[f"fig4.random-slope-equal.{b}"], slope[f"fig4.random-slope-osw.{b}"]
        lines.append(f"  claim (Sec. 7.2), {b}: random converges like N^-0.5 with equal weights "
                     f"(ours N^{ce.values['slope']:.2f}: {_yes(ce)}) and like N^-0.75 with OSW "
                     f"(ours N^{co.values['slope']:.2f}: {_yes(co)}; within ±{co.threshold:g})")
    for c in beats:
        b = c.id.rsplit(".", 1)[1]
        lines.append(f"  structured sets beat random at equal weights for every N >= {c.values['nmin']} "
                     f"({b}): " + ", ".join(f"{lab[p]} {'yes' if v['all'] else 'NO'} "
                                            f"(max ratio {v['ratio_max']:.2f})"
                                            for p, v in c.values["per_pointset"].items()))
    if not beats:
        lines.append(f"  (no N >= {C.BEATS_RANDOM_NMIN}: raise --nmax for the structured-vs-random "
                     "comparison)")
    run.output.say(*lines)
    return {"ns": cd.ns, "fit_range": [lo, hi],
            "slopes": {f"{b}/{w}/{p}": k for (b, w, p), k in cd.slopes.items()},
            "beats_random_equal_N_ge_256": {c.id.rsplit(".", 1)[1]: c.values["per_pointset"]
                                            for c in beats}}


def _figure_truncation(run: _FigureRun) -> dict:
    """Fig. 5: files, printed lines (the caption claim) and the JSON part."""
    from envfit.theory import claims as C, figures as F, wce_curves as W
    import envfit.plots as P
    t0, out, s, shin, per_oct = time.perf_counter(), run.out, run.s, run.shin, 8
    with run.bar(2 * W.log_grid(run.qnmax, per_oct).size, "QMC curves (Fig. 5)") as bar:
        td = F.truncation_figure_data(s, shin, run.cutoff, qmc_nmax=run.qnmax, per_octave=per_oct,
                                      progress=progress_callback(bar))
    run.save("fig5_truncation.png", P.plot_truncation, td, out / "fig5_truncation.png")
    run.csv("fig5_truncation.csv",
            f"Fig. 5: truncation error E(L) (Eq. 52 from L+1) and QMC-equivalent N (spherical "
            f"Fibonacci, equal weights, points morphed for the BRDF (Sec. 7.2); tabulated to N = "
            f"{run.qnmax}, empty beyond; extrapolated by a power law fitted to the top 2 octaves); "
            f"s = {s:g}, glossy n = {shin:g}",
            ("case", "L", "wce", "qmc_points", "qmc_points_extrapolated"),
            [(case, int(L), td.wce[case][L], _int_or(td.qmc_points[case][L], ""),
              _int_or(td.qmc_points_extrapolated[case][L], "")) for case in td.wce for L in td.L])
    run.csv("fig5_qmc_curve.csv",
            f"Fig. 5: wce(N) of spherical Fibonacci points, equal weights, points morphed for the "
            f"BRDF (Sec. 7.2), {per_oct} N per octave; s = {s:g}, glossy n = {shin:g}",
            ("brdf", "n", "wce"),
            [(b, int(nn), e) for b, (ns_, es) in td.qmc_curve.items() for nn, e in zip(ns_, es)])
    lines = [f"Fig. 5 (L <= {run.cutoff}, QMC curve to N = {run.qnmax}): "
             f"{time.perf_counter() - t0:.1f} s",
             "  QMC-equivalent N at L = 0..8: " + "; ".join(
                 f"{c} " + " ".join(str(_int_or(x, "-")) for x in td.qmc_points[c][:9]) for c in td.wce)]
    cap = C.caption_fig5a_claim(td)
    if cap is not None:
        v = cap.values
        lines.append(f"  Fig. 5(a) caption: L = 3 -> E = {_sci(v['paper_wce'])}, ≈ {v['paper_qmc_points']} "
                     f"points; ours E(3) "
                     + (f"= E(2) = {v['wce_L3']:.3g} (b_3 = 0)" if v["b3_zero"] else f"= {v['wce_L3']:.3g}")
                     + ", N = " + ("-" if v["qmc_points_L3"] is None else str(v["qmc_points_L3"])))
    run.output.say(*lines)
    return {"L": td.L, "wce": td.wce,
            "qmc_points": {k: [_int_or(x, None) for x in v] for k, v in td.qmc_points.items()},
            "qmc_points_extrapolated": {k: [_int_or(x, None) for x in v]
                                        for k, v in td.qmc_points_extrapolated.items()},
            "qmc_slope": td.qmc_slope}


def _figure_bnot(run: _FigureRun) -> dict:
    """BNOT check: files, printed lines (capacity and blue-noise claims) and the JSON part."""
    from envfit.theory import claims as C, figures as F
    import envfit.plots as P
    t0, n = time.perf_counter(), run.n
    bd = F.bnot_figure_data(n, run.seed)
    run.save("bnot_spectrum.png", P.plot_bnot, bd, run.out / "bnot_spectrum.png")
    run.csv("bnot_spectrum.csv",
            f"BNOT vs random: radially averaged periodogram on the unit square (before the "
            f"Lambert lift, not morphed), N = {n}, seed {run.seed}",
            ("radius", "power_bnot", "power_random"),
            zip(bd.radius, bd.power_bnot, bd.power_random))
    db, dr = bd.diagnostics_bnot, bd.diagnostics_random
    cap, blue = C.bnot_capacity_claim(bd), C.bnot_blue_noise_claim(bd)
    run.output.say(f"BNOT check (N = {n}): {time.perf_counter() - t0:.1f} s",
                   f"  blue noise: mean power for |k| < sqrt(N)/2 = {bd.low_band:.3g}: BNOT "
                   f"{bd.low_power_bnot:.3g}, random {bd.low_power_random:.3g}"
                   + _yes(blue, "", f" (NOT blue: BNOT >= {blue.threshold:g} x random)"),
                   f"  capacity: cell areas = 1/N within {db.max_relative_area_error:.1e} relative "
                   f"({_yes(cap, 'OK', 'FAILED')}, required {_sci(cap.threshold)}); centroid residual "
                   f"|b_i - x_i| sqrt(N): BNOT {db.centroid_residual:.3g}, random {dr.centroid_residual:.3g}; "
                   f"min distance x sqrt(N): BNOT {db.min_distance_normalised:.3g}, "
                   f"random {dr.min_distance_normalised:.3g}")
    return {"low_band": bd.low_band, "low_power_bnot": bd.low_power_bnot,
            "low_power_random": bd.low_power_random,
            "max_relative_area_error": db.max_relative_area_error,
            "capacity_ok": cap.holds, "centroid_residual_bnot": db.centroid_residual,
            "centroid_residual_random": dr.centroid_residual,
            "min_distance_normalised_bnot": db.min_distance_normalised,
            "min_distance_normalised_random": dr.min_distance_normalised}

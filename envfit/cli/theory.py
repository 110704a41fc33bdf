"""``envfit theory``: worst-case errors, the paper's Table 1 and Figs. 1–5 (Secs. 7–8).

Sub-subcommands:

* ``wce``     — worst-case error (Eq. 41) and its spectrum (Eq. 42) of one quadrature rule;
* ``table1``  — Table 1: SH/HSH cut-offs and the equivalent numbers of QMC points;
* ``figures`` — PNG + CSV for Figs. 1–5 and a BNOT check.

The numerics are in :mod:`theory` (pure); this module parses, prints and writes files.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from envfit.base.errors import ParameterError
from .common import (add_common_arguments, emit_json, finite_float, guarded_write, nonneg_int,
                     out_dir, positive_float, positive_int, say, str_list)

#: the paper's highest spectral degree (default --lmax of ``figures``)
DEFAULT_SPLIT_LMAX = 170
#: cap of the automatic degree of ``wce`` (ducc0 adjoint synthesis ≈ 1-2 s at 2048)
AUTO_LMAX_CAP = 2048


def auto_split_lmax(n: int) -> int:
    """Degree of the E_Z / E_A split of ``wce`` without --lmax: min(2048, max(170, ⌈16√N⌉)).

    The truncated spectral sum misses a tail that is ≈ √N/lmax of E² for equal weights
    (C_l² → (2l+1)/(4π)Σw²); 16√N leaves ≈ 3-30 % of E² (reported) at ≈ 1 s for N = 10⁴.
    """
    return int(min(AUTO_LMAX_CAP, max(DEFAULT_SPLIT_LMAX, math.ceil(16.0 * math.sqrt(n)))))
#: default folder of ``figures`` when --out is not given
DEFAULT_FIGURES_DIR = "theory_figures"
FIGURE_NAMES = ("1", "2", "3", "4", "5", "bnot")

_SHININESS_HELP = ("glossy exponent n (default 30, the paper's); n of about 10 or less is slow "
                   "on first use (minutes: the lobe's jump at the horizon, e^-n, makes the "
                   "engine sum the kernel embedding to SH degree 32768)")
_MORPH_HELP = ("Points are morphed for the BRDF by default: their heights are importance-sampled "
               "from p (diffuse z = sqrt(z'), glossy Eq. 67; Sec. 7.2), so that equal weights "
               "1/N estimate the normalised shading integral (Eq. 17).")


def register(sub) -> None:
    p = sub.add_parser(
        "theory", help="worst-case errors, the paper's Table 1 and Figs. 1-5",
        description="Theory of Marques, Bouville & Bouatouch (Secs. 5-8): worst-case errors of "
                    "quadrature rules for shading integrals in a Sobolev space H^s, their spectra, "
                    "and the error of SH/HSH truncation.")
    tsub = p.add_subparsers(dest="theory_command", metavar="WHAT")
    p.set_defaults(func=lambda args: _usage(p))

    # -- wce -------------------------------------------------------------------------
    w = tsub.add_parser(
        "wce", help="worst-case error (Eq. 41) and its spectrum (Eq. 42) of one quadrature rule",
        description="Worst-case error E of a quadrature rule for the normalised shading integral "
                    "(Eq. 17) over the unit ball of H^s: the closed form Eq. 41 (no truncation), "
                    "its zonal and anisotropic parts (Eqs. 46-47) summed to --lmax, and the tail "
                    "E^2 - sum_{l<=lmax} e_l^2. " + _MORPH_HELP)
    w.add_argument("--brdf", choices=("diffuse", "glossy"), required=True)
    w.add_argument("--shininess", type=positive_float, default=30.0, help=_SHININESS_HELP)
    w.add_argument("--pointset", choices=("sf", "sobol", "lp", "bnot", "random", "jitter"),
                   required=True, help="point set of Sec. 7.1 (bnot is slow beyond a few thousand)")
    w.add_argument("--weights", choices=("equal", "osw"), default="equal",
                   help="equal 1/N or the optimal sample weights K^-1 z (default: equal)")
    w.add_argument("--n", type=positive_int, required=True, help="number of points N")
    w.add_argument("--s", type=finite_float, default=1.5, help="Sobolev smoothness in (1, 2) (default 1.5)")
    w.add_argument("--lmax", type=nonneg_int, default=None,
                   help="also report the spectrum d_l^2, C_l^2, e_l^2 for l = 0..LMAX; without it "
                        f"E_Z and E_A are summed to l = min({AUTO_LMAX_CAP}, max({DEFAULT_SPLIT_LMAX}, "
                        "16 sqrt(N))) and no spectrum is listed; the tail beyond lmax is reported")
    w.add_argument("--no-morph", action="store_true",
                   help="lift the points uniformly (no importance sampling); equal weights then "
                        "do not estimate the weighted integral and E is large")
    add_common_arguments(w)
    w.set_defaults(func=run_wce)

    # -- table1 ----------------------------------------------------------------------
    t = tsub.add_parser(
        "table1", help="the paper's Table 1: cut-off degrees L and equivalent QMC points",
        description="For diffuse SH, glossy SH and glossy HSH: the truncation error curve E(L) "
                    "(Eq. 52 summed from L+1, errata), the smallest L with E(L) <= target "
                    "(strict) and with E(L) <= 1.1 target (the paper's reading off its log "
                    "plot), and the number of QMC points (spherical Fibonacci, equal weights, "
                    "morphed for the BRDF) with the same worst-case error. Printed beside the "
                    "paper's values (Table 1, Sec. 8.2, Fig. 5(a) caption).")
    t.add_argument("--target", type=positive_float, default=2.5e-3, help="worst-case error (default 2.5e-3)")
    t.add_argument("--s", type=finite_float, default=1.5, help="Sobolev smoothness in (1, 2) (default 1.5)")
    t.add_argument("--shininess", type=positive_float, default=30.0, help=_SHININESS_HELP)
    add_common_arguments(t)
    t.set_defaults(func=run_table1)

    # -- figures ---------------------------------------------------------------------
    f = tsub.add_parser(
        "figures", help="PNG + CSV for the paper's Figs. 1-5 and a BNOT check",
        description="Fig. 1 power spectra d_l^2, C_l^2 (equal weights) and C_l^2 (OSW) of the six "
                    "point sets; Fig. 2 the first 10 C_l^2 (diffuse), equal vs OSW; Fig. 3 error "
                    "spectra e_l^2 = a_l (d_l^2 + C_l^2); Fig. 4 worst-case error vs N with "
                    "fitted slopes; Fig. 5 truncation error vs L with the QMC-equivalent N; and "
                    "the radial power spectrum and capacity check of BNOT. " + _MORPH_HELP)
    f.add_argument("--n", type=positive_int, default=256, help="N of Figs. 1-3 and the BNOT check (default 256)")
    f.add_argument("--s", type=finite_float, default=1.5, help="Sobolev smoothness in (1, 2) (default 1.5)")
    f.add_argument("--shininess", type=positive_float, default=30.0, help=_SHININESS_HELP)
    f.add_argument("--nmax", type=positive_int, default=2048,
                   help="largest N of Fig. 4 (powers of two from 16; default 2048)")
    f.add_argument("--lmax", type=positive_int, default=DEFAULT_SPLIT_LMAX,
                   help=f"highest degree l of the spectra of Figs. 1 and 3 (default {DEFAULT_SPLIT_LMAX})")
    f.add_argument("--cutoff-max", type=positive_int, default=20, metavar="L",
                   help="largest cut-off degree L of Fig. 5 (default 20)")
    f.add_argument("--qmc-nmax", type=positive_int, default=16384, metavar="N",
                   help="top of the tabulated QMC curve E(N) inverted for Fig. 5 (default 16384; "
                        "beyond it the N are extrapolated and marked so)")
    f.add_argument("--only", type=str_list, default=None, metavar="F1,F2,...",
                   help=f"draw only these figures, from {','.join(FIGURE_NAMES)} (default: all)")
    f.add_argument("--no-morph", action="store_true",
                   help="lift the points of Figs. 1-4 uniformly (no importance sampling)")
    add_common_arguments(f)
    f.set_defaults(func=run_figures, out_default=DEFAULT_FIGURES_DIR)  # preflight checks it


def _usage(p: argparse.ArgumentParser) -> int:
    p.print_help()
    return 2


def _check_s(s: float) -> float:
    from envfit.theory.errors import check_smoothness
    return check_smoothness(s)


def _check_positive_int(v: int, name: str, lo: int = 1) -> int:
    if v is None or int(v) < lo:
        raise ParameterError(f"{name} must be an integer >= {lo}, got {v}")
    return int(v)


def _check_shininess(n: float) -> float:
    if not (math.isfinite(n) and n > 0):
        raise ParameterError(f"--shininess must be > 0, got {n:g}")
    return float(n)


def _progress_callback(bar):
    def cb(label: str) -> None:
        bar.set_postfix_str(label)
        bar.update(1)
    return cb


# ============================================================================ wce
def run_wce(args: argparse.Namespace) -> int:
    from envfit.theory.figures import make_weight, quadrature_rule
    from envfit.theory.quadrature import error_spectrum
    from envfit.base.resources import check_memory

    s = _check_s(args.s)
    n = _check_positive_int(args.n, "--n")
    shin = _check_shininess(args.shininess)
    if args.lmax is not None:
        _check_positive_int(args.lmax, "--lmax", 0)
    lmax = auto_split_lmax(n) if args.lmax is None else int(args.lmax)
    if args.weights == "osw":
        check_memory(8 * n * n, f"the {n}x{n} kernel matrix of the optimal weights",
                     hint="use fewer points or --weights equal")
    if args.pointset == "bnot" and n > 8192:
        say(args, f"note: BNOT with N = {n} takes minutes (≈ 15 s at 4096)")
    weight = make_weight(args.brdf, shin)
    morphed = not args.no_morph
    t0 = time.perf_counter()
    u, w = quadrature_rule(args.pointset, n, weight, s, args.weights, seed=args.seed, morph=morphed)
    sp = error_spectrum(u, w, weight, s, lmax)
    secs = time.perf_counter() - t0
    e2 = sp.wce ** 2
    result = {"wce": sp.wce, "wce_zonal": sp.wce_zonal, "wce_anisotropic": sp.wce_anisotropic,
              "tail": sp.tail, "lmax": lmax, "lmax_automatic": args.lmax is None,
              "tail_fraction": (sp.tail / e2) if e2 > 0 else None,
              "brdf": args.brdf, "shininess": shin if args.brdf == "glossy" else None,
              "pointset": args.pointset, "weights": args.weights, "n": n, "s": s,
              "seed": args.seed, "morphed": morphed, "sum_weights": float(np.sum(w)),
              "seconds": secs}
    if args.lmax is not None:
        result["spectrum"] = [{"l": int(l), "d2": float(d), "C2": float(c), "e2": float(e)}
                              for l, d, c, e in zip(sp.l, sp.d2, sp.C2, sp.e2)]
    lobe = "diffuse" if args.brdf == "diffuse" else f"glossy n = {shin:g}"
    say(args,
        f"{lobe}, {args.pointset}, N = {n}, {args.weights} weights, s = {s:g}, "
        + ("points morphed for the BRDF (importance sampling)" if morphed else "points NOT morphed"),
        f"  worst-case error E = {sp.wce:.6e}   (closed form Eq. 41, no truncation)",
        f"  zonal E_Z = {sp.wce_zonal:.6e}, anisotropic E_A = {sp.wce_anisotropic:.6e}"
        f"   (Eqs. 46-47, l <= {lmax}{'' if args.lmax is not None else ', automatic'})",
        f"  tail E^2 - sum_(l<={lmax}) e_l^2 = {sp.tail:.3e}"
        + (f"  ({100 * sp.tail / e2:.2f} % of E^2, mostly anisotropic: C_l^2 -> "
           f"(2l+1)/(4 pi) sum w_j^2)" if e2 > 0 else ""),
        f"  ({secs:.2f} s)")
    if args.lmax is not None and not args.quiet and str(args.json) != "-":
        show = list(range(min(lmax, 10) + 1))
        print("  l      d_l^2        C_l^2        e_l^2")
        for l in show:
            print(f"  {l:<4d} {sp.d2[l]:12.4e} {sp.C2[l]:12.4e} {sp.e2[l]:12.4e}")
        if lmax > show[-1]:
            print(f"  … (l up to {lmax} in --json)")
    if args.out is not None:
        from envfit.base.atomic import atomic_write_text
        d = out_dir(args)
        rows = [f"{l},{a:.17g},{dd:.17g},{c:.17g},{e:.17g}"
                for l, a, dd, c, e in zip(sp.l, sp.a, sp.d2, sp.C2, sp.e2)]
        head = (f"# envfit theory wce: {lobe}, {args.pointset}, N = {n}, {args.weights} weights, "
                f"s = {s:g}, seed {args.seed}, "
                + ("points morphed for the BRDF (Sec. 7.2)" if morphed else "points not morphed")
                + f"; E = {sp.wce:.10e}\nl,a,d2,C2,e2\n")
        path = guarded_write(args, d / "wce_spectrum.csv", atomic_write_text,
                             d / "wce_spectrum.csv", head + "\n".join(rows) + "\n")
        if path is not None:
            say(args, f"wrote {path}")
    emit_json(args, result)
    return 0


# ============================================================================ table1
def _fmt_int(v) -> str:
    return "-" if v is None else str(v)


def format_table1(table, comparison: list[dict]) -> str:
    """Table 1 beside the paper's values, the E(L) curves and the comparison notes."""
    from envfit.theory.table1 import PAPER_SHININESS, PAPER_S, PAPER_TABLE1
    paper_ok = table.target == PAPER_TABLE1["target"] and table.s == PAPER_S
    lines = [f"Table 1 — target worst-case error E = {table.target:.3g}, s = {table.s:g}, "
             f"glossy n = {table.shininess:g}",
             f"{'case':<12}{'L strict':>9}{'E(L)':>11}{'L reading':>11}{'E(L)':>11}"
             f"{'QMC points':>12}{'E(QMC)':>11}" + ("   | paper:   L    QMC" if paper_ok else "")]
    for r in table.rows:
        paper = ""
        if paper_ok and (r.brdf == "diffuse" or table.shininess == PAPER_SHININESS):
            paper = (f"   |     {PAPER_TABLE1['L'][r.case]:>3d}"
                     f"{PAPER_TABLE1['qmc_points'][r.case]:>7d}")
        lines.append(f"{r.case:<12}{r.L:>9d}{r.wce_at_L:>11.3e}{r.L_paper_reading:>11d}"
                     f"{r.wce_at_L_paper_reading:>11.3e}{_fmt_int(r.qmc_points):>12}"
                     + (f"{r.qmc_wce:>11.3e}" if r.qmc_wce is not None else f"{'-':>11}") + paper)
    lines.append(f"(L strict: smallest L with E(L) <= target; L reading: E(L) <= "
                 f"{1 + table.rtol_paper_reading:g} x target, the paper's reading of its log plot; "
                 f"QMC: spherical Fibonacci, equal weights, morphed for the BRDF)")
    lines.append("")
    lines.append("E(L), L = 0, 1, 2, …:")
    for r in table.rows:
        vals = " ".join(f"{x:.3g}" for x in r.wce_by_L)
        lines.append(f"  {r.case:<11} {vals}")
    if comparison:
        lines.append("")
        lines.append("Comparison with the paper:")
        for c in comparison:
            ours = c["ours_strict"]
            if isinstance(ours, float):
                ours_txt = f"{ours:.3g}"
            elif c["ours_paper_reading"] != ours:
                ours_txt = f"{ours} (strict), {c['ours_paper_reading']} (reading)"
            else:
                ours_txt = f"{ours}"
            mark = "agrees" if c["agrees"] else "DIFFERS"
            why = "" if c["why"] == "agrees" else f" — {c['why']}"
            lines.append(f"  {c['what']}: paper {c['paper']:g}, ours {ours_txt}: {mark}{why}")
    elif table.s != PAPER_S:
        lines.append("")
        lines.append(f"(no comparison: the paper's values are for s = {PAPER_S:g})")
    return "\n".join(lines)


def run_table1(args: argparse.Namespace) -> int:
    from envfit.theory.brdf import Diffuse
    from envfit.theory.table1 import PAPER_FIG5A_CAPTION, PAPER_S, paper_comparison, table1
    from envfit.theory.truncation import equivalent_qmc_points

    s = _check_s(args.s)
    shin = _check_shininess(args.shininess)
    if not (math.isfinite(args.target) and args.target > 0):
        raise ParameterError(f"--target must be > 0, got {args.target:g}")
    t0 = time.perf_counter()
    tab = table1(args.target, s, shin)
    caption_q = None
    if s == PAPER_S:
        caption_q = equivalent_qmc_points(PAPER_FIG5A_CAPTION["wce"], Diffuse(), s)
    comp = paper_comparison(tab, caption_qmc_points=caption_q)
    secs = time.perf_counter() - t0
    say(args, format_table1(tab, comp), "", f"computed in {secs:.1f} s")
    result = tab.to_dict()
    result["paper_comparison"] = comp
    result["seconds"] = secs
    if args.out is not None:
        from envfit.base.atomic import atomic_write_csv
        d = out_dir(args)
        p1 = guarded_write(args, d / "table1.csv", atomic_write_csv, d / "table1.csv",
                           ("case", "L", "wce_at_L", "L_paper_reading", "wce_at_L_paper_reading",
                            "qmc_points", "qmc_wce"),
                           [(r.case, r.L, r.wce_at_L, r.L_paper_reading, r.wce_at_L_paper_reading,
                             r.qmc_points, r.qmc_wce) for r in tab.rows])
        p2 = guarded_write(args, d / "table1_wce_by_L.csv", atomic_write_csv,
                           d / "table1_wce_by_L.csv", ("case", "L", "wce"),
                           [(r.case, L, float(e)) for r in tab.rows
                            for L, e in enumerate(r.wce_by_L)])
        written = [str(p) for p in (p1, p2) if p is not None]
        if written:
            say(args, "wrote " + " and ".join(written))
    emit_json(args, result)
    return 0


# ============================================================================ figures
def _csv(path, comment: str, header, rows):
    """CSV with a leading ``# comment`` line (read with ``comment='#'``)."""
    import csv
    import io
    from envfit.base.atomic import atomic_write_text, to_jsonable
    buf = io.StringIO()
    buf.write("# " + comment.replace("\n", " ") + "\n")
    wr = csv.writer(buf)
    wr.writerow(header)
    for r in rows:
        wr.writerow(["" if (isinstance(v, float) and not math.isfinite(v)) else to_jsonable(v)
                     for v in r])
    return atomic_write_text(path, buf.getvalue())


def _za(rec) -> float:
    return rec.wce_zonal / rec.wce_anisotropic if rec.wce_anisotropic > 0 else float("nan")


def _morph_note(morphed: bool) -> str:
    return ("points morphed for the BRDF (importance sampling, Sec. 7.2)" if morphed
            else "points NOT morphed (uniform on the hemisphere)")


def run_figures(args: argparse.Namespace) -> int:
    from envfit.theory import figures as F
    from envfit.plots import theory as P
    from envfit.base.progress import progress_bar

    s = _check_s(args.s)
    shin = _check_shininess(args.shininess)
    n = _check_positive_int(args.n, "--n", 2)
    nmax = _check_positive_int(args.nmax, "--nmax", 16)
    lmax = _check_positive_int(args.lmax, "--lmax", 10)
    cutoff = _check_positive_int(args.cutoff_max, "--cutoff-max", 1)
    qnmax = _check_positive_int(args.qmc_nmax, "--qmc-nmax", 2)
    only = args.only or list(FIGURE_NAMES)
    bad = [x for x in only if x not in FIGURE_NAMES]
    if bad:
        raise ParameterError(f"--only: unknown figure(s) {bad}; choose from {list(FIGURE_NAMES)}")
    from envfit.base.resources import check_memory
    check_memory(8 * max(n, nmax) ** 2, f"the {max(n, nmax)}x{max(n, nmax)} kernel matrix of the "
                 "optimal weights", hint="lower --n / --nmax")
    morphed = not args.no_morph
    out = out_dir(args, DEFAULT_FIGURES_DIR)
    seed = args.seed
    files: dict[str, str] = {}

    def save(name: str, write, *wargs) -> None:
        """Write one figure / CSV (``write(*wargs)``); a failure is recorded, not raised, so
        the other figures are still computed and the numbers printed."""
        path = guarded_write(args, out / name, write, *wargs)
        if path is not None:
            files[name] = str(path)

    result: dict = {"n": n, "s": s, "shininess": shin, "nmax": nmax, "lmax": lmax, "seed": seed,
                    "morphed": morphed, "out": str(out), "files": files}
    t_all = time.perf_counter()
    common = f"s = {s:g}, glossy n = {shin:g}, seed {seed}, {_morph_note(morphed)}"

    # ---------------------------------------------------------------- Figs. 1-3
    if {"1", "2", "3"} & set(only):
        t0 = time.perf_counter()
        total = len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS)
        with progress_bar(total, desc="spectra (Figs. 1-3)", quiet=args.quiet) as bar:
            sd = F.spectra_data(n, s, shin, lmax, seed=seed, morph=morphed,
                                progress=_progress_callback(bar))
        rows1, rows3 = [], []
        for (brdf, wt, ps), r in sd.records.items():
            for l in range(r.l.size):
                rows1.append((brdf, ps, wt, n, l, r.d2[l], r.C2[l]))
                rows3.append((brdf, ps, wt, n, l, r.a[l], r.d2[l], r.C2[l], r.e2[l]))
        if "1" in only:
            save("fig1_power_spectra.png", P.plot_power_spectra, sd, out / "fig1_power_spectra.png")
            save("fig1_power_spectra.csv", _csv,
                out / "fig1_power_spectra.csv",
                f"Fig. 1: zonal d_l^2 = (b_l - c_l0)^2 and anisotropic C_l^2 power spectra, N = {n}, "
                f"one realization; {common}",
                ("brdf", "pointset", "weights", "n", "l", "d2", "C2"), rows1)
        closeup = F.low_order_closeup(sd, "diffuse", 10)
        if "2" in only:
            save("fig2_low_order_C2.png", P.plot_low_order_closeup,
                closeup, n, morphed, out / "fig2_low_order_C2.png")
            save("fig2_low_order_C2.csv", _csv,
                out / "fig2_low_order_C2.csv",
                f"Fig. 2: first 10 anisotropic C_l^2 (l = 1..10), diffuse, N = {n}; {common}",
                ("pointset", "l", "C2_equal", "C2_osw"),
                [(ps, int(l), closeup.C2_equal[ps][i], closeup.C2_osw[ps][i])
                 for ps in sd.pointsets for i, l in enumerate(closeup.l)])
        if "3" in only:
            save("fig3_error_spectra.png", P.plot_error_spectra, sd, out / "fig3_error_spectra.png")
            save("fig3_error_spectra.csv", _csv,
                out / "fig3_error_spectra.csv",
                f"Fig. 3: error spectra e_l^2 = a_l (d_l^2 + C_l^2), N = {n}; {common}",
                ("brdf", "pointset", "weights", "n", "l", "a", "d2", "C2", "e2"), rows3)
        low = {ps: {"equal": float(closeup.C2_equal[ps].sum()), "osw": float(closeup.C2_osw[ps].sum()),
                    "ratio": closeup.reduction[ps]} for ps in sd.pointsets}
        result["spectra"] = {
            "wce": {f"{b}/{w}/{p}": r.wce for (b, w, p), r in sd.records.items()},
            "wce_zonal": {f"{b}/{w}/{p}": r.wce_zonal for (b, w, p), r in sd.records.items()},
            "wce_anisotropic": {f"{b}/{w}/{p}": r.wce_anisotropic for (b, w, p), r in sd.records.items()},
            "low_order_C2_sum_l1_10_diffuse": low}
        say(args, f"Figs. 1-3 (N = {n}, l <= {lmax}): {time.perf_counter() - t0:.1f} s",
            "  Fig. 2, sum of C_l^2 over l = 1..10 (diffuse), OSW / equal: "
            + ", ".join(f"{F.POINTSET_LABELS[p]} {v['ratio']:.3g}" for p, v in low.items()),
            "  E_Z / E_A (diffuse, equal weights, l <= lmax): "
            + ", ".join(f"{F.POINTSET_LABELS[p]} {_za(sd.get('diffuse', 'equal', p)):.2g}"
                        for p in sd.pointsets)
            + "  (the anisotropic part dominates)")

    # ---------------------------------------------------------------- Fig. 4
    if "4" in only:
        t0 = time.perf_counter()
        total = len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS)
        with progress_bar(total, desc="wce vs N (Fig. 4)", quiet=args.quiet) as bar:
            cd = F.convergence_data(nmax, s, shin, seed=seed, morph=morphed,
                                    progress=_progress_callback(bar))
        save("fig4_wce_vs_n.png", P.plot_convergence, cd, out / "fig4_wce_vs_n.png")
        save("fig4_wce_vs_n.csv", _csv,
            out / "fig4_wce_vs_n.csv",
            f"Fig. 4: worst-case error (Eq. 41) vs N, one realization, raw values; {common}",
            ("brdf", "weights", "pointset", "n", "wce"),
            [(b, w, p, int(nn), e) for (b, w, p), arr in cd.wce.items() for nn, e in zip(cd.ns, arr)])
        lo, hi = cd.fit_range
        save("fig4_slopes.csv", _csv,
            out / "fig4_slopes.csv",
            f"Fig. 4: least-squares slope of log wce vs log N over N = {lo:g}..{hi:g}; {common}",
            ("brdf", "weights", "pointset", "slope", "fit_nmin", "fit_nmax"),
            [(b, w, p, k, lo, hi) for (b, w, p), k in cd.slopes.items()])
        beats = {b: cd.beats_random(b, "equal", 256) for b in cd.brdfs} if cd.ns.max() >= 256 else {}
        result["convergence"] = {
            "ns": cd.ns, "fit_range": [lo, hi],
            "slopes": {f"{b}/{w}/{p}": k for (b, w, p), k in cd.slopes.items()},
            "beats_random_equal_N_ge_256": beats}
        lines = [f"Fig. 4 (N = {int(cd.ns[0])}..{int(cd.ns[-1])}): {time.perf_counter() - t0:.1f} s",
                 f"  convergence slopes (fit over N = {lo:g}..{hi:g}):"]
        for b in cd.brdfs:
            for w in cd.weightings:
                lines.append(f"    {b:<8}{w:<6}" + "  ".join(
                    f"{F.POINTSET_LABELS[p]} {cd.slopes[(b, w, p)]:+.3f}" for p in cd.pointsets))
        for b in cd.brdfs:
            ke, ko = cd.slopes[(b, "equal", "random")], cd.slopes[(b, "osw", "random")]
            lines.append(f"  claim (Sec. 7.2), {b}: random converges like N^-0.5 with equal weights "
                         f"(ours N^{ke:.2f}: {'yes' if abs(ke + 0.5) <= 0.1 else 'NO'}) and like "
                         f"N^-0.75 with OSW (ours N^{ko:.2f}: {'yes' if abs(ko + 0.75) <= 0.1 else 'NO'}; "
                         "within ±0.1)")
        for b, d in beats.items():
            lines.append(f"  structured sets beat random at equal weights for every N >= 256 ({b}): "
                         + ", ".join(f"{F.POINTSET_LABELS[p]} {'yes' if v['all'] else 'NO'} "
                                     f"(max ratio {v['ratio_max']:.2f})" for p, v in d.items()))
        if not beats:
            lines.append("  (no N >= 256: raise --nmax for the structured-vs-random comparison)")
        say(args, *lines)

    # ---------------------------------------------------------------- Fig. 5
    if "5" in only:
        t0 = time.perf_counter()
        per_oct = 8
        total = 2 * F.log_grid(qnmax, per_oct).size
        with progress_bar(total, desc="QMC curves (Fig. 5)", quiet=args.quiet) as bar:
            td = F.truncation_figure_data(s, shin, cutoff, qmc_nmax=qnmax, per_octave=per_oct,
                                          progress=_progress_callback(bar))
        save("fig5_truncation.png", P.plot_truncation, td, out / "fig5_truncation.png")
        rows = []
        for case in td.wce:
            for L in td.L:
                q, qx = td.qmc_points[case][L], td.qmc_points_extrapolated[case][L]
                rows.append((case, int(L), td.wce[case][L], int(q) if math.isfinite(q) else "",
                             int(qx) if math.isfinite(qx) else ""))
        save("fig5_truncation.csv", _csv,
            out / "fig5_truncation.csv",
            f"Fig. 5: truncation error E(L) (Eq. 52 from L+1) and QMC-equivalent N (spherical "
            f"Fibonacci, equal weights, points morphed for the BRDF (Sec. 7.2); tabulated to N = "
            f"{qnmax}, empty beyond; extrapolated by a power law fitted to the top 2 octaves); "
            f"s = {s:g}, glossy n = {shin:g}",
            ("case", "L", "wce", "qmc_points", "qmc_points_extrapolated"), rows)
        save("fig5_qmc_curve.csv", _csv,
            out / "fig5_qmc_curve.csv",
            f"Fig. 5: wce(N) of spherical Fibonacci points, equal weights, points morphed for the "
            f"BRDF (Sec. 7.2), {per_oct} N per octave; s = {s:g}, glossy n = {shin:g}",
            ("brdf", "n", "wce"),
            [(b, int(nn), e) for b, (ns_, es) in td.qmc_curve.items() for nn, e in zip(ns_, es)])
        result["truncation"] = {
            "L": td.L, "wce": td.wce,
            "qmc_points": {k: [None if not math.isfinite(x) else int(x) for x in v]
                           for k, v in td.qmc_points.items()},
            "qmc_points_extrapolated": {k: [None if not math.isfinite(x) else int(x) for x in v]
                                        for k, v in td.qmc_points_extrapolated.items()},
            "qmc_slope": td.qmc_slope}
        d3 = td.qmc_points["diffuse-sh"]
        say(args, f"Fig. 5 (L <= {cutoff}, QMC curve to N = {qnmax}): {time.perf_counter() - t0:.1f} s",
            "  QMC-equivalent N at L = 0..8: " + "; ".join(
                f"{c} " + " ".join("-" if not math.isfinite(x) else str(int(x)) for x in td.qmc_points[c][:9])
                for c in td.wce),
            f"  Fig. 5(a) caption: L = 3 -> E = 4.4e-3, ≈ 930 points; ours E(3) = E(2) = "
            f"{td.wce['diffuse-sh'][3]:.3g} (b_3 = 0), N = "
            + ("-" if not math.isfinite(d3[3]) else str(int(d3[3]))))

    # ---------------------------------------------------------------- BNOT
    if "bnot" in only:
        t0 = time.perf_counter()
        bd = F.bnot_figure_data(n, seed)
        save("bnot_spectrum.png", P.plot_bnot, bd, out / "bnot_spectrum.png")
        save("bnot_spectrum.csv", _csv,
            out / "bnot_spectrum.csv",
            f"BNOT vs random: radially averaged periodogram on the unit square (before the "
            f"Lambert lift, not morphed), N = {n}, seed {seed}",
            ("radius", "power_bnot", "power_random"),
            zip(bd.radius, bd.power_bnot, bd.power_random))
        db, dr = bd.diagnostics_bnot, bd.diagnostics_random
        ok = db.max_relative_area_error <= 1e-4
        result["bnot"] = {"low_band": bd.low_band, "low_power_bnot": bd.low_power_bnot,
                          "low_power_random": bd.low_power_random,
                          "max_relative_area_error": db.max_relative_area_error,
                          "capacity_ok": ok, "centroid_residual_bnot": db.centroid_residual,
                          "centroid_residual_random": dr.centroid_residual,
                          "min_distance_normalised_bnot": db.min_distance_normalised,
                          "min_distance_normalised_random": dr.min_distance_normalised}
        say(args, f"BNOT check (N = {n}): {time.perf_counter() - t0:.1f} s",
            f"  blue noise: mean power for |k| < sqrt(N)/2 = {bd.low_band:.3g}: BNOT "
            f"{bd.low_power_bnot:.3g}, random {bd.low_power_random:.3g}",
            f"  capacity: cell areas = 1/N within {db.max_relative_area_error:.1e} relative "
            f"({'OK' if ok else 'FAILED'}, required 1e-4); centroid residual |b_i - x_i| sqrt(N): "
            f"BNOT {db.centroid_residual:.3g}, random {dr.centroid_residual:.3g}; "
            f"min distance x sqrt(N): BNOT {db.min_distance_normalised:.3g}, "
            f"random {dr.min_distance_normalised:.3g}")

    result["seconds"] = time.perf_counter() - t_all
    say(args, f"wrote {len(files)} files to {out} in {result['seconds']:.1f} s")
    emit_json(args, result)
    return 0

"""``envfit theory``: worst-case errors, the paper's Table 1 and Figs. 1–5 (Secs. 7–8).

Sub-subcommands:

* ``wce``     — worst-case error (Eq. 41) and its spectrum (Eq. 42) of one quadrature rule;
* ``table1``  — Table 1: SH/HSH cut-offs and the equivalent numbers of QMC points;
* ``figures`` — PNG + CSV for Figs. 1–5 and a BNOT check (:mod:`envfit.cli._theory_figures`).

The numerics are in :mod:`theory` (pure); this module parses, prints and writes files.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from envfit.base import ParameterError
from envfit.defaults import ALL_POINTSETS, BRDFS, DEFAULT_SHININESS, WEIGHTINGS
from envfit.cli._common import add_common_arguments, out_dir
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged
from envfit.cli._theory_common import (DEFAULT_SPLIT_LMAX, LMAX_CAP, MORPH_HELP, N_CAP,
                                       S_RANGE, SHININESS_HELP, SHININESS_RANGE,
                                       check_positive_int, check_s, check_shininess)
from envfit.cli._theory_figures import register_figures

#: cap of the automatic degree of ``wce`` (ducc0 adjoint synthesis ≈ 1-2 s at 2048)
AUTO_LMAX_CAP = 2048
#: the ranges of wce's and table1's own options (``--help`` and the errors say these words)
WCE_N = Ranged(1, N_CAP, "N")
WCE_LMAX = Ranged(0, LMAX_CAP, "LMAX")
TARGET = Ranged(1e-4, 1, "E", integer=False)


def auto_split_lmax(n: int) -> int:
    """Degree of the E_Z / E_A split of ``wce`` without --lmax: min(2048, max(170, ⌈16√N⌉)).

    The rule is :func:`envfit.theory._figures.split_lmax`; this fixes its floor and cap to
    the CLI's defaults.
    """
    from envfit.theory import split_lmax
    return split_lmax(n, floor=DEFAULT_SPLIT_LMAX, cap=AUTO_LMAX_CAP)


def register(sub) -> None:
    p = sub.add_parser(
        "theory", help="worst-case errors, the paper's Table 1 and Figs. 1-5",
        description="Theory of Marques, Bouville & Bouatouch (Secs. 5-8): worst-case errors of "
                    "quadrature rules for shading integrals in a Sobolev space H^s, their spectra, "
                    "and the error of SH/HSH truncation.")
    tsub = p.add_subparsers(dest="theory_command", metavar="WHAT")
    p.set_defaults(func=lambda args, output: _usage(p))
    _register_wce(tsub)
    _register_table1(tsub)
    register_figures(tsub)


def _register_wce(tsub) -> None:
    w = tsub.add_parser(
        "wce", help="worst-case error (Eq. 41) and its spectrum (Eq. 42) of one quadrature rule",
        description="Worst-case error E of a quadrature rule for the normalised shading integral "
                    "(Eq. 17) over the unit ball of H^s: the closed form Eq. 41 (no truncation), "
                    "its zonal and anisotropic parts (Eqs. 46-47) summed to --lmax, and the tail "
                    "E^2 - sum_{l<=lmax} e_l^2. " + MORPH_HELP)
    w.add_argument("--brdf", choices=BRDFS, required=True)
    w.add_argument("--shininess", type=SHININESS_RANGE, default=DEFAULT_SHININESS,
                   help=SHININESS_HELP)
    w.add_argument("--pointset", choices=ALL_POINTSETS,
                   required=True, help="point set of Sec. 7.1 (bnot is slow beyond a few thousand)")
    w.add_argument("--weights", choices=WEIGHTINGS, default="equal",
                   help="equal 1/N or the optimal sample weights K^-1 z (default: equal)")
    w.add_argument("--n", type=WCE_N, required=True,
                   help=f"number of points, {WCE_N} (a cap: the closed form Eq. 41 is an O(N^2) "
                        "pair sum, about a minute at the top; --weights osw also needs the N x N "
                        "matrix in memory)")
    w.add_argument("--s", type=S_RANGE, default=1.5,
                   help=f"Sobolev smoothness, {S_RANGE} (default 1.5)")
    w.add_argument("--lmax", type=WCE_LMAX, default=None,
                   help=f"also report the spectrum d_l^2, C_l^2, e_l^2 for l = 0..LMAX, {WCE_LMAX} "
                        "(a cap: about 5 s of SH synthesis at the top); without it "
                        f"E_Z and E_A are summed to l = min({AUTO_LMAX_CAP}, max({DEFAULT_SPLIT_LMAX}, "
                        "16 sqrt(N))) and no spectrum is listed; the tail beyond lmax is reported")
    w.add_argument("--no-morph", action="store_true",
                   help="lift the points uniformly (no importance sampling); equal weights then "
                        "do not estimate the weighted integral and E is large")
    add_common_arguments(w)
    w.set_defaults(func=run_wce)


def _register_table1(tsub) -> None:
    t = tsub.add_parser(
        "table1", help="the paper's Table 1: cut-off degrees L and equivalent QMC points",
        description="For diffuse SH, glossy SH and glossy HSH: the truncation error curve E(L) "
                    "(Eq. 52 summed from L+1, see docs/ERRATA.md), the smallest L with E(L) <= target "
                    "(strict) and with E(L) <= 1.1 target (the paper's reading off its log "
                    "plot), and the number of QMC points (spherical Fibonacci, equal weights, "
                    "morphed for the BRDF) with the same worst-case error. Printed beside the "
                    "paper's values (Table 1, Sec. 8.2, Fig. 5(a) caption).")
    t.add_argument("--target", type=TARGET, default=2.5e-3,
                   help=f"worst-case error, {TARGET} (default 2.5e-3; about 40 s at 1e-4)")
    t.add_argument("--s", type=S_RANGE, default=1.5,
                   help=f"Sobolev smoothness, {S_RANGE} (default 1.5)")
    t.add_argument("--shininess", type=SHININESS_RANGE, default=DEFAULT_SHININESS,
                   help=SHININESS_HELP)
    add_common_arguments(t)
    t.set_defaults(func=run_table1)


def _usage(p: argparse.ArgumentParser) -> int:
    p.print_help()
    return 2


# ============================================================================ wce
def run_wce(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.theory import make_weight, quadrature_rule
    from envfit.theory import error_spectrum
    from envfit.base import check_memory

    s = check_s(args.s)
    n = check_positive_int(args.n, "--n")
    shin = check_shininess(args.shininess)
    if args.lmax is not None:
        check_positive_int(args.lmax, "--lmax", 0)
    lmax = auto_split_lmax(n) if args.lmax is None else int(args.lmax)
    if args.weights == "osw":
        check_memory(8 * n * n, f"the {n}x{n} kernel matrix of the optimal weights",
                     hint="use fewer points or --weights equal")
    if args.pointset == "bnot" and n > 8192:
        output.say(f"note: BNOT with N = {n} takes minutes (≈ 15 s at 4096)")
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
    _print_wce(args, output, sp, lobe, result)
    if args.out is not None:
        _write_wce_csv(args, output, sp, lobe, result)
    output.emit_json(result)
    return 0


def _print_wce(args, output: CommandOutput, sp, lobe: str, result: dict) -> None:
    """The wce lines (N, s, l_max, morphing and time from ``result``, the command's JSON)."""
    n, s, lmax, morphed = result["n"], result["s"], result["lmax"], result["morphed"]
    secs = result["seconds"]
    e2 = sp.wce ** 2
    output.say(
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


def _write_wce_csv(args, output: CommandOutput, sp, lobe: str, result: dict) -> None:
    n, s, morphed = result["n"], result["s"], result["morphed"]
    from envfit.base import atomic_write_text
    d = out_dir(args)
    rows = [f"{l},{a:.17g},{dd:.17g},{c:.17g},{e:.17g}"
            for l, a, dd, c, e in zip(sp.l, sp.a, sp.d2, sp.C2, sp.e2)]
    head = (f"# envfit theory wce: {lobe}, {args.pointset}, N = {n}, {args.weights} weights, "
            f"s = {s:g}, seed {args.seed}, "
            + ("points morphed for the BRDF (Sec. 7.2)" if morphed else "points not morphed")
            + f"; E = {sp.wce:.10e}\nl,a,d2,C2,e2\n")
    path = output.guarded_write(d / "wce_spectrum.csv", atomic_write_text,
                                d / "wce_spectrum.csv", head + "\n".join(rows) + "\n")
    from envfit.plots import plot_wce_spectrum
    png = output.guarded_write(d / "wce_spectrum.png", plot_wce_spectrum, sp,
                               d / "wce_spectrum.png", head.splitlines()[0][2:])
    written = [str(p) for p in (path, png) if p is not None]
    if written:
        output.say("wrote " + " and ".join(written))


# ============================================================================ table1
def _fmt_int(v) -> str:
    return "-" if v is None else str(v)


def format_table1(table, comparison: list[dict]) -> str:
    """Table 1 beside the paper's values, the E(L) curves and the comparison notes."""
    from envfit.theory import PAPER_S, paper_table1_values
    printed = paper_table1_values(table)
    lines = [f"Table 1 — target worst-case error E = {table.target:.3g}, s = {table.s:g}, "
             f"glossy n = {table.shininess:g}",
             f"{'case':<12}{'L strict':>9}{'E(L)':>11}{'L reading':>11}{'E(L)':>11}"
             f"{'QMC points':>12}{'E(QMC)':>11}" + ("   | paper:   L    QMC" if printed else "")]
    for r in table.rows:
        pv = printed.get(r.case)
        paper = f"   |     {pv['L']:>3d}{pv['qmc_points']:>7d}" if pv else ""
        lines.append(f"{r.case:<12}{r.L:>9d}{r.wce_at_L:>11.3e}{r.L_paper_reading:>11d}"
                     f"{r.wce_at_L_paper_reading:>11.3e}{_fmt_int(r.qmc_points):>12}"
                     + (f"{r.qmc_wce:>11.3e}" if r.qmc_wce is not None else f"{'-':>11}") + paper)
    lines.append(f"(L strict: smallest L with E(L) <= target; L reading: E(L) <= "
                 f"{1 + table.rtol_paper_reading:g} x target, the paper's reading of its log plot; "
                 f"QMC: spherical Fibonacci, equal weights, morphed for the BRDF)")
    lines += ["", "E(L), L = 0, 1, 2, …:"]
    lines += [f"  {r.case:<11} " + " ".join(f"{x:.3g}" for x in r.wce_by_L) for r in table.rows]
    if comparison:
        lines += ["", "Comparison with the paper:"]
        lines += [_format_comparison(c) for c in comparison]
    elif table.s != PAPER_S:
        lines += ["", f"(no comparison: the paper's values are for s = {PAPER_S:g})"]
    return "\n".join(lines)


def _format_comparison(c: dict) -> str:
    ours = c["ours_strict"]
    if isinstance(ours, float):
        ours_txt = f"{ours:.3g}"
    elif c["ours_paper_reading"] != ours:
        ours_txt = f"{ours} (strict), {c['ours_paper_reading']} (reading)"
    else:
        ours_txt = f"{ours}"
    mark = "agrees" if c["agrees"] else "DIFFERS"
    why = "" if c["why"] == "agrees" else f" — {c['why']}"
    return f"  {c['what']}: paper {c['paper']:g}, ours {ours_txt}: {mark}{why}"


def run_table1(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.theory import table1_report

    s = check_s(args.s)
    shin = check_shininess(args.shininess)
    if not (math.isfinite(args.target) and args.target > 0):
        raise ParameterError(f"--target must be > 0, got {args.target:g}")
    t0 = time.perf_counter()
    tab, comp = table1_report(args.target, s, shin)
    secs = time.perf_counter() - t0
    output.say(format_table1(tab, comp), "", f"computed in {secs:.1f} s")
    result = tab.to_dict()
    result["paper_comparison"] = comp
    result["seconds"] = secs
    if args.out is not None:
        from envfit.base import atomic_write_csv
        d = out_dir(args)
        p1 = output.guarded_write(d / "table1.csv", atomic_write_csv, d / "table1.csv",
                                  ("case", "L", "wce_at_L", "L_paper_reading", "wce_at_L_paper_reading",
                            "qmc_points", "qmc_wce"),
                                  [(r.case, r.L, r.wce_at_L, r.L_paper_reading, r.wce_at_L_paper_reading,
                             r.qmc_points, r.qmc_wce) for r in tab.rows])
        p2 = output.guarded_write(d / "table1_wce_by_L.csv", atomic_write_csv,
                                  d / "table1_wce_by_L.csv", ("case", "L", "wce"),
                                  [(r.case, L, float(e)) for r in tab.rows
                            for L, e in enumerate(r.wce_by_L)])
        from envfit.plots import plot_table1
        p3 = output.guarded_write(d / "table1.png", plot_table1, tab, d / "table1.png")
        written = [str(p) for p in (p1, p2, p3) if p is not None]
        if written:
            output.say("wrote " + ", ".join(written))
    output.emit_json(result)
    return 0



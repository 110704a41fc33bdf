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

    The rule is :func:`envfit.theory.figures.split_lmax`; this fixes its floor and cap to
    the CLI's defaults.
    """
    from envfit.theory.figures import split_lmax
    return split_lmax(n, floor=DEFAULT_SPLIT_LMAX, cap=AUTO_LMAX_CAP)


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
    _register_wce(tsub)
    _register_table1(tsub)
    _register_figures(tsub)


def _register_wce(tsub) -> None:
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


def _register_table1(tsub) -> None:
    t = tsub.add_parser(
        "table1", help="the paper's Table 1: cut-off degrees L and equivalent QMC points",
        description="For diffuse SH, glossy SH and glossy HSH: the truncation error curve E(L) "
                    "(Eq. 52 summed from L+1, see docs/ERRATA.md), the smallest L with E(L) <= target "
                    "(strict) and with E(L) <= 1.1 target (the paper's reading off its log "
                    "plot), and the number of QMC points (spherical Fibonacci, equal weights, "
                    "morphed for the BRDF) with the same worst-case error. Printed beside the "
                    "paper's values (Table 1, Sec. 8.2, Fig. 5(a) caption).")
    t.add_argument("--target", type=positive_float, default=2.5e-3, help="worst-case error (default 2.5e-3)")
    t.add_argument("--s", type=finite_float, default=1.5, help="Sobolev smoothness in (1, 2) (default 1.5)")
    t.add_argument("--shininess", type=positive_float, default=30.0, help=_SHININESS_HELP)
    add_common_arguments(t)
    t.set_defaults(func=run_table1)


def _register_figures(tsub) -> None:
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
    _print_wce(args, sp, lobe, n, s, lmax, morphed, secs)
    if args.out is not None:
        _write_wce_csv(args, sp, lobe, n, s, morphed)
    emit_json(args, result)
    return 0


def _print_wce(args, sp, lobe: str, n: int, s: float, lmax: int, morphed: bool, secs: float) -> None:
    e2 = sp.wce ** 2
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


def _write_wce_csv(args, sp, lobe: str, n: int, s: float, morphed: bool) -> None:
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


# ============================================================================ table1
def _fmt_int(v) -> str:
    return "-" if v is None else str(v)


def format_table1(table, comparison: list[dict]) -> str:
    """Table 1 beside the paper's values, the E(L) curves and the comparison notes."""
    from envfit.theory.table1 import PAPER_S, paper_table1_values
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


def run_table1(args: argparse.Namespace) -> int:
    from envfit.theory.table1 import table1_report

    s = _check_s(args.s)
    shin = _check_shininess(args.shininess)
    if not (math.isfinite(args.target) and args.target > 0):
        raise ParameterError(f"--target must be > 0, got {args.target:g}")
    t0 = time.perf_counter()
    tab, comp = table1_report(args.target, s, shin)
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

    def __init__(self, args: argparse.Namespace):
        self.args = args
        self.s = _check_s(args.s)
        self.shin = _check_shininess(args.shininess)
        self.n = _check_positive_int(args.n, "--n", 2)
        self.nmax = _check_positive_int(args.nmax, "--nmax", 16)
        self.lmax = _check_positive_int(args.lmax, "--lmax", 10)
        self.cutoff = _check_positive_int(args.cutoff_max, "--cutoff-max", 1)
        self.qnmax = _check_positive_int(args.qmc_nmax, "--qmc-nmax", 2)
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
        path = guarded_write(self.args, self.out / name, write, *wargs)
        if path is not None:
            self.files[name] = str(path)

    def csv(self, name: str, comment: str, header, rows) -> None:
        self.save(name, _csv, self.out / name, comment, header, rows)

    def bar(self, total: int, desc: str):
        from envfit.base.progress import progress_bar
        return progress_bar(total, desc=desc, quiet=self.args.quiet)


def run_figures(args: argparse.Namespace) -> int:
    from envfit.base.resources import check_memory

    run = _FigureRun(args)
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
    say(args, f"wrote {len(run.files)} files to {run.out} in {result['seconds']:.1f} s")
    emit_json(args, result)
    return 0


def _figures_spectra(run: _FigureRun) -> dict:
    """Figs. 1-3: files, printed lines and the JSON part."""
    from envfit.theory import figures as F
    from envfit.plots import theory as P
    t0, n, out = time.perf_counter(), run.n, run.out
    with run.bar(len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS), "spectra (Figs. 1-3)") as bar:
        sd = F.spectra_data(n, run.s, run.shin, run.lmax, seed=run.seed, morph=run.morphed,
                            progress=_progress_callback(bar))
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
    dom, red = F.anisotropic_dominance_claim(sd), F.osw_low_order_claim(closeup)
    low = {ps: {"equal": red.values["sum_equal"][ps], "osw": red.values["sum_osw"][ps],
                "ratio": red.values["ratio"][ps]} for ps in sd.pointsets}
    lab, za = F.POINTSET_LABELS, dom.values["zonal_over_anisotropic"]
    say(run.args, f"Figs. 1-3 (N = {n}, l <= {run.lmax}): {time.perf_counter() - t0:.1f} s",
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
    from envfit.theory import figures as F
    from envfit.plots import theory as P
    t0, out = time.perf_counter(), run.out
    with run.bar(len(F.BRDFS) * len(F.POINTSET_ORDER) * len(F.WEIGHTINGS), "wce vs N (Fig. 4)") as bar:
        cd = F.convergence_data(run.nmax, run.s, run.shin, seed=run.seed, morph=run.morphed,
                                progress=_progress_callback(bar))
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
    slope = {c.id: c for c in F.random_slope_claims(cd)}
    beats = F.structured_beat_random_claims(cd)
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
        lines.append(f"  (no N >= {F.BEATS_RANDOM_NMIN}: raise --nmax for the structured-vs-random "
                     "comparison)")
    say(run.args, *lines)
    return {"ns": cd.ns, "fit_range": [lo, hi],
            "slopes": {f"{b}/{w}/{p}": k for (b, w, p), k in cd.slopes.items()},
            "beats_random_equal_N_ge_256": {c.id.rsplit(".", 1)[1]: c.values["per_pointset"]
                                            for c in beats}}


def _figure_truncation(run: _FigureRun) -> dict:
    """Fig. 5: files, printed lines (the caption claim) and the JSON part."""
    from envfit.theory import figures as F
    from envfit.plots import theory as P
    t0, out, s, shin, per_oct = time.perf_counter(), run.out, run.s, run.shin, 8
    with run.bar(2 * F.log_grid(run.qnmax, per_oct).size, "QMC curves (Fig. 5)") as bar:
        td = F.truncation_figure_data(s, shin, run.cutoff, qmc_nmax=run.qnmax, per_octave=per_oct,
                                      progress=_progress_callback(bar))
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
    cap = F.caption_fig5a_claim(td)
    if cap is not None:
        v = cap.values
        lines.append(f"  Fig. 5(a) caption: L = 3 -> E = {_sci(v['paper_wce'])}, ≈ {v['paper_qmc_points']} "
                     f"points; ours E(3) "
                     + (f"= E(2) = {v['wce_L3']:.3g} (b_3 = 0)" if v["b3_zero"] else f"= {v['wce_L3']:.3g}")
                     + ", N = " + ("-" if v["qmc_points_L3"] is None else str(v["qmc_points_L3"])))
    say(run.args, *lines)
    return {"L": td.L, "wce": td.wce,
            "qmc_points": {k: [_int_or(x, None) for x in v] for k, v in td.qmc_points.items()},
            "qmc_points_extrapolated": {k: [_int_or(x, None) for x in v]
                                        for k, v in td.qmc_points_extrapolated.items()},
            "qmc_slope": td.qmc_slope}


def _figure_bnot(run: _FigureRun) -> dict:
    """BNOT check: files, printed lines (capacity and blue-noise claims) and the JSON part."""
    from envfit.theory import figures as F
    from envfit.plots import theory as P
    t0, n = time.perf_counter(), run.n
    bd = F.bnot_figure_data(n, run.seed)
    run.save("bnot_spectrum.png", P.plot_bnot, bd, run.out / "bnot_spectrum.png")
    run.csv("bnot_spectrum.csv",
            f"BNOT vs random: radially averaged periodogram on the unit square (before the "
            f"Lambert lift, not morphed), N = {n}, seed {run.seed}",
            ("radius", "power_bnot", "power_random"),
            zip(bd.radius, bd.power_bnot, bd.power_random))
    db, dr = bd.diagnostics_bnot, bd.diagnostics_random
    cap, blue = F.bnot_capacity_claim(bd), F.bnot_blue_noise_claim(bd)
    say(run.args, f"BNOT check (N = {n}): {time.perf_counter() - t0:.1f} s",
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

"""Benchmark: the iterative solver (envfit.sobolev._iterative) against the dense Cholesky.

Run:  nice -n 5 python bench/bench_solver.py [--quick] [--map forest.exr] [--n 5000,20000,80000,200000]
      [--s 1.1,1.5,1.9] [--cell-n 20000] [--no-verify] [--json out.json] [--csv out.csv]

Sections, each measured in this run (the load average is recorded with every row):

(a) **Scaling**: for each N and s, ``SobolevInterpolator(points, values, s,
    solver="iterative")`` on N spherical-Fibonacci samples of the map (3 channels, display
    scale): setup (kd-tree, near matrix, local Lagrange functions, coarse factor) and solve
    seconds, CG iterations, full products, relative residual, the bound of the RMSE change,
    the Ritz range of the preconditioned spectrum, peak RSS; beside the bare LAPACK ``dpotrf``
    of the same N x N matrix (own child process, :func:`bench_cholesky.run_child`, with
    ``OPENBLAS_CORETYPE=Haswell`` on AVX-512 CPUs where a bare threaded ``dpotrf`` segfaults
    for N >= 16 000) where it fits in memory and N <= ``--dense-max``.
(b) **Table 2 cell** on the map at ``--cell-n``: solve + evaluation at every pixel with the
    iterative solver (:func:`envfit.fit._table2.run_table2`), its ratio to (a)'s bare
    ``dpotrf``, and (unless ``--no-verify``) the same cell with the Cholesky: RMSE relative
    difference (target <= 1e-6).
(c) **Crossover** (``auto``'s constant): fit time of both solvers for N in ``--cross-n``.

The CPU model (AVX level) and the load average are printed with the figures.
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cholesky import cpu_description, run_child  # noqa: E402

from envfit.base._atomic import atomic_write_csv, atomic_write_json  # noqa: E402  # internal: the product's atomic, numpy-aware writers
from envfit.base._resources import memory_budget_bytes  # noqa: E402  # internal: the memory guard's own budget
from envfit.fit import run_table2, sample_directions  # noqa: E402
from envfit.sobolev import SobolevInterpolator  # noqa: E402
from envfit.maps import fit_scale, load_envmap  # noqa: E402

DEFAULT_MAP = "/work/shared/envmaps/forest.exr"
FIELDS = ("section", "n", "s", "solver", "setup_s", "solve_s", "evaluate_s", "iterations",
          "products", "residual", "rmse", "rmse_rel_diff", "rmse_change_bound", "lambda_min",
          "lambda_max", "dpotrf_s", "ratio", "peak_rss_gb", "load")


def _peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def _dpotrf_method() -> str:
    return "dpotrf-haswell" if "AVX-512" in cpu_description() else "dpotrf"


def bare_dpotrf(n: int, s: float, dense_max: int) -> float | None:
    """Seconds of the bare ``dpotrf`` of the N x N kernel matrix (child process) or None."""
    if n > dense_max or 8.0 * n * n * 1.1 > memory_budget_bytes():
        return None
    r = run_child(_dpotrf_method(), n, s)
    return r.get("seconds")


def _samples(env, n: int) -> tuple[np.ndarray, np.ndarray]:
    scaled = env.with_data(np.asarray(fit_scale("display", env).apply(env.data), np.float64))
    p = sample_directions(n, up=env.up)
    return p, scaled.lookup(p).reshape(n, env.channels)


def section_scaling(env, ns, ss, dense_max, log) -> list[dict]:
    rows = []
    for n in ns:
        p, v = _samples(env, n)
        for s in ss:
            it = SobolevInterpolator(p, v, s, solver="iterative")
            i = it.solve_info
            row = {"section": "scaling", "n": n, "s": s, "solver": "iterative",
                   "setup_s": it.timings["setup"], "solve_s": i.seconds_solve,
                   "iterations": i.iterations, "products": i.products,
                   "residual": max(i.residual), "rmse_change_bound": max(i.error_bound),
                   "lambda_min": i.lambda_min, "lambda_max": i.lambda_max,
                   "peak_rss_gb": _peak_gb(), "load": os.getloadavg()[0]}
            del it
            d = bare_dpotrf(n, s, dense_max)
            row["dpotrf_s"] = d
            row["ratio"] = d / (row["setup_s"] + row["solve_s"]) if d else None
            rows.append(row)
            log(f"(a) N={n:7d} s={s:.1f}: setup {row['setup_s']:6.2f} s, solve {row['solve_s']:6.2f} s,"
                f" {i.iterations:3d} it ({i.products} products), residual {row['residual']:.1e},"
                f" bound {row['rmse_change_bound']:.1e}, BK in [{i.lambda_min:.3f}, {i.lambda_max:.3f}]"
                + (f"; bare dpotrf {d:6.2f} s (x{row['ratio']:.1f})" if d else "; dpotrf: n/a")
                + f"; peak {row['peak_rss_gb']:.2f} GB, load {row['load']:.1f}")
    return rows


def section_cell(env, n, ss, dpotrf, verify, log) -> list[dict]:
    rows = []
    for s in ss:
        cells = {}
        for solver in ("iterative",) + (("cholesky",) if verify else ()):
            c = run_table2(env, [s], [n], solver=solver, save_reconstructions=False).cells[0]
            cells[solver] = c
            d = dpotrf.get((n, s))
            row = {"section": "cell", "n": n, "s": s, "solver": c.solver,
                   "solve_s": c.seconds_fit, "evaluate_s": c.seconds_evaluate,
                   "iterations": c.iterations, "residual": c.residual, "rmse": c.rmse,
                   "rmse_change_bound": c.rmse_change_bound, "dpotrf_s": d,
                   "ratio": d / c.seconds if d else None, "peak_rss_gb": _peak_gb(),
                   "load": os.getloadavg()[0]}
            if solver == "cholesky":
                row["rmse_rel_diff"] = abs(cells["iterative"].rmse - c.rmse) / c.rmse
                rows[-1]["rmse_rel_diff"] = row["rmse_rel_diff"]
            rows.append(row)
            log(f"(b) N={n} s={s:.1f} {c.solver:9s}: fit {c.seconds_fit:6.2f} s + evaluation "
                f"{c.seconds_evaluate:5.2f} s = {c.seconds:6.2f} s, RMSE {c.rmse:.10f}"
                + (f", {c.iterations} it, bound {c.rmse_change_bound:.1e}" if c.iterations else "")
                + (f"; bare dpotrf {d:.2f} s: x{row['ratio']:.1f} faster" if d else "")
                + (f"; |RMSE - Cholesky's| / RMSE = {row['rmse_rel_diff']:.1e}"
                   if "rmse_rel_diff" in row else "") + f" (load {row['load']:.1f})")
    return rows


def section_crossover(env, ns, s, log) -> list[dict]:
    rows = []
    for n in ns:
        p, v = _samples(env, n)
        for solver in ("cholesky", "iterative"):
            t0 = time.perf_counter()
            it = SobolevInterpolator(p, v, s, solver=solver)
            sec = time.perf_counter() - t0
            rows.append({"section": "crossover", "n": n, "s": s, "solver": solver, "solve_s": sec,
                         "iterations": it.solve_info.iterations, "load": os.getloadavg()[0]})
            del it
        ch, ic = rows[-2]["solve_s"], rows[-1]["solve_s"]
        log(f"(c) N={n:6d} s={s:.1f}: cholesky {ch:6.2f} s, iterative {ic:6.2f} s "
            f"-> {'iterative' if ic < ch else 'cholesky'} faster (x{max(ch, ic) / min(ch, ic):.2f})")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", default=DEFAULT_MAP)
    ap.add_argument("--quick", action="store_true",
                    help="N 2000,5000; s 1.1,1.9; cell N 5000 on the map at 128 rows; crossover 1000-4000")
    ap.add_argument("--n", default=None, help="scaling N (default 5000,20000,80000,200000)")
    ap.add_argument("--s", default="1.1,1.5,1.9")
    ap.add_argument("--cell-n", type=int, default=None)
    ap.add_argument("--cross-n", default=None, help="crossover N (default 1000,2000,4000,8000)")
    ap.add_argument("--dense-max", type=int, default=20000)
    ap.add_argument("--no-verify", action="store_true", help="skip the Cholesky cell of (b)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--csv", type=Path, default=None)
    args = ap.parse_args(argv)
    ss = [float(x) for x in args.s.split(",")]
    if args.quick:
        ss = [1.1, 1.9] if args.s == "1.1,1.5,1.9" else ss
    ns = [int(x) for x in (args.n or ("2000,5000" if args.quick else "5000,20000,80000,200000")).split(",")]
    cross = [int(x) for x in (args.cross_n or ("1000,2000,4000" if args.quick else "1000,2000,4000,8000")).split(",")]
    cell_n = args.cell_n or (5000 if args.quick else 20000)
    env = load_envmap(args.map, max_height=128 if args.quick else None)
    head = (f"CPU: {cpu_description()}; map {env.name} {env.width}x{env.height}; "
            f"load average at start {os.getloadavg()[0]:.2f}")
    print(head, flush=True)

    def log(msg):
        print(msg, flush=True)

    SobolevInterpolator(sample_directions(500), np.ones(500), ss[0], solver="iterative")  # warm-up
    rows = section_scaling(env, ns, ss, args.dense_max, log)
    dpotrf = {(r["n"], r["s"]): r["dpotrf_s"] for r in rows if r.get("dpotrf_s")}
    for s in ss:
        if (cell_n, s) not in dpotrf and (d := bare_dpotrf(cell_n, s, args.dense_max)):
            dpotrf[(cell_n, s)] = d
    rows += section_cell(env, cell_n, ss, dpotrf, not args.no_verify, log)
    rows += section_crossover(env, cross, 1.5, log)
    growth = {}
    for s in ss:
        its = {r["n"]: r["iterations"] for r in rows if r["section"] == "scaling" and r["s"] == s}
        if len(its) >= 2:
            lo, hi = min(its), max(its)
            growth[s] = its[hi] / max(its[lo], 1)
            log(f"iterations at s={s:.1f}: " + ", ".join(f"N={k}: {v}" for k, v in sorted(its.items()))
                + f" (x{growth[s]:.2f} from N={lo} to N={hi})")
    log(f"load average at end {os.getloadavg()[0]:.2f}")
    if args.json:
        atomic_write_json(args.json, {"cpu": cpu_description(), "header": head, "rows": rows,
                                      "iteration_growth": {str(k): v for k, v in growth.items()}})
    if args.csv:
        atomic_write_csv(args.csv, FIELDS, [[r.get(f) for f in FIELDS] for r in rows])
    return 0


if __name__ == "__main__":
    sys.exit(main())

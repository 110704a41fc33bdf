"""Benchmark of the theory engine and ``envfit theory table1``.

Run:  /tmp/venv/bin/python bench/bench_theory.py [--quick] [--repeat 3] [--json out.json]

Measures (wall clock, median of ``--repeat`` fresh calls unless noted, this machine's
threads; the machine load average is recorded because the numbers scale with it):

1. ``worst_case_error`` (closed form Eq. 41, O(N²)) for N = 10 000 (target < 1.5 s), with
   1 and 2 worker threads, and N = 100 000 once (reported; skipped with --quick);
2. ``error_spectrum`` N = 1000, lmax = 1500 (ducc0 adjoint SH synthesis; target < 3 s), and
   once the O(N² lmax) Legendre pair form of Eq. 44 (``envfit.theory._sh._power_spectrum_legendre_pairs``)
   as the baseline, in the same process: the speed ratio and the agreement of C_l²;
3. ``optimal_weights`` N = 4096 (float64 Cholesky; target < 5 s);
4. ``envfit theory table1`` end to end in a fresh Python process (target < 30 s).

Points: spherical Fibonacci / random, morphed for the diffuse lobe (Sec. 7.2), s = 1.5.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


from envfit.theory import (Diffuse, equal_weights, error_spectrum, generate,  # noqa: E402
                           optimal_weights, worst_case_error)
from envfit.theory._sh import _power_spectrum_legendre_pairs  # noqa: E402  # internal: the O(N² L) form timed against the public one

S = 1.5


def _timed(fn, repeat=3):
    times, out = [], None
    for _ in range(max(1, repeat)):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times, out


def _entry(name, median, times, target=None, **extra):
    e = {"name": name, "median_s": median, "times_s": times, "target_s": target,
         "ok": None if target is None else bool(median < target)}
    e.update(extra)
    return e


def _line(e):
    tgt = ("" if e["target_s"] is None
           else f"  (target < {e['target_s']:g} s: {'OK' if e['ok'] else 'MISSED'})")
    reps = len(e["times_s"])
    return f"{e['name']:<58} {e['median_s']:8.3f} s  [{reps} run{'s' if reps > 1 else ''}]{tgt}"


def bench_wce(repeat, quick):
    out = []
    w = Diffuse()
    u = generate("sf", 10_000, morph=w.morph)
    wt = equal_weights(10_000)
    worst_case_error(u[:64], equal_weights(64), w, S)          # warm the embedding caches
    for workers in (1, 2):
        med, ts, e = _timed(lambda: worst_case_error(u, wt, w, S, workers=workers), repeat)
        out.append(_entry(f"worst_case_error N=10000 (workers={workers})", med, ts,
                          1.5 if workers == 1 else None, wce=e))
    if not quick:
        u = generate("sf", 100_000, morph=w.morph)
        wt = equal_weights(100_000)
        for workers in (1, 2):
            med, ts, e = _timed(lambda: worst_case_error(u, wt, w, S, workers=workers), 1)
            out.append(_entry(f"worst_case_error N=100000 (workers={workers})", med, ts, None, wce=e))
    return out


def bench_spectrum(repeat):
    w = Diffuse()
    n, lmax = 1000, 1500
    u = generate("random", n, seed=0, morph=w.morph)
    wt = equal_weights(n)
    error_spectrum(u[:64], equal_weights(64), w, S, 16)          # warm-up (imports, caches)
    med, ts, sp = _timed(lambda: error_spectrum(u, wt, w, S, lmax), repeat)
    fast = _entry(f"error_spectrum N={n} lmax={lmax} (ducc0)", med, ts, 3.0,
                  wce=sp.wce, tail_fraction=sp.tail / sp.wce ** 2)
    # baseline: Eq. 44 by the Legendre pair sum, O(N^2 lmax); block 64 keeps its
    # (lmax+1) x 64 x N Legendre table at 0.8 GB
    t0 = time.perf_counter()
    c0, S_l = _power_spectrum_legendre_pairs(u, wt, lmax, block=64)
    tb = time.perf_counter() - t0
    C2_ref = S_l - c0 ** 2
    l = np.arange(1, lmax + 1)
    dev = float(np.max(np.abs(sp.C2[l] - C2_ref[l])) / np.max(S_l))
    base = _entry(f"baseline Legendre pairs N={n} lmax={lmax} (once)", tb, [tb], None,
                  ratio_vs_fast=tb / med, max_abs_C2_difference_rel_to_max_S=dev)
    return [fast, base]


def bench_osw(repeat):
    w = Diffuse()
    n = 4096
    u = generate("sf", n, morph=w.morph)
    optimal_weights(u[:64], w, S)
    med, ts, wt = _timed(lambda: optimal_weights(u, w, S), repeat)
    e_osw = worst_case_error(u, wt, w, S)
    e_eq = worst_case_error(u, equal_weights(n), w, S)
    return [_entry(f"optimal_weights N={n}", med, ts, 5.0, wce_osw=e_osw, wce_equal=e_eq)]


def bench_table1(repeat):
    code = "import sys; from envfit.cli import main; sys.exit(main(sys.argv[1:]))"
    with tempfile.TemporaryDirectory() as d:
        js = Path(d) / "t.json"
        cmd = [sys.executable, "-c", code, "theory", "table1", "--quiet", "--json", str(js)]

        def run():
            r = subprocess.run(cmd, capture_output=True, text=True,
                               cwd=str(Path(__file__).resolve().parents[1]))
            if r.returncode != 0:
                raise RuntimeError(f"envfit theory table1 failed: {r.stderr.strip()}")
            return json.loads(js.read_text())

        med, ts, res = _timed(run, repeat)
    rows = {r["case"]: (r["L"], r["L_paper_reading"], r["qmc_points"]) for r in res["rows"]}
    return [_entry("envfit theory table1 (fresh process, end to end)", med, ts, 30.0,
                   rows=rows, inner_seconds=res["seconds"])]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="one run each, skip N = 100 000")
    ap.add_argument("--repeat", type=int, default=3, help="runs per timing (default 3)")
    ap.add_argument("--json", type=Path, default=None, help="write the results to FILE")
    args = ap.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    info = {"cpus": os.cpu_count(), "loadavg_start": os.getloadavg(), "quick": args.quick,
            "repeat": repeat, "python": sys.version.split()[0], "numpy": np.__version__}
    print(f"bench_theory: {info['cpus']} CPUs, load average {info['loadavg_start'][0]:.2f} at start, "
          f"{'quick' if args.quick else f'{repeat} runs'}")
    results = []
    for part in (lambda: bench_wce(repeat, args.quick), lambda: bench_spectrum(repeat),
                 lambda: bench_osw(repeat), lambda: bench_table1(repeat)):
        for e in part():
            results.append(e)
            print(_line(e), flush=True)
            if "ratio_vs_fast" in e:
                print(f"{'':<58} baseline / ducc0 = {e['ratio_vs_fast']:.1f}x; max |ΔC_l²| / max S_l "
                      f"= {e['max_abs_C2_difference_rel_to_max_S']:.1e}")
            if "rows" in e:
                print(f"{'':<58} (L strict, L paper reading, QMC points): {e['rows']}")
    info["loadavg_end"] = os.getloadavg()
    print(f"load average at end {info['loadavg_end'][0]:.2f}")
    if args.json:
        from envfit.base._atomic import atomic_write_json  # internal: the product's atomic, numpy-aware writers
        atomic_write_json(args.json, {"info": info, "results": results})
        print(f"wrote {args.json}")
    missed = [e["name"] for e in results if e["ok"] is False]
    if missed:
        print("targets missed: " + "; ".join(missed))
    return 0


if __name__ == "__main__":
    sys.exit(main())

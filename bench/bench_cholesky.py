"""Benchmark: envfit's blocked Cholesky (envfit.theory._cholesky) against bare LAPACK ``dpotrf``.

Run:  python bench/bench_cholesky.py [--n 4000,8000,12000,16000,20000] [--s 1.5]
      [--repeats 1] [--json out.json]

Every factorisation runs in its own child process (``--worker``), so a crash of bare
``dpotrf`` (OpenBLAS's threaded ``dsyrk`` overruns its buffer on AVX-512 CPUs with two or
more threads for N >= 16 000, see ``theory/_cholesky.py``) is recorded as "SIGSEGV" instead
of ending the run. Methods, interleaved per N so that they see the same machine load:

* ``blocked``  -- :func:`envfit.theory._cholesky.cholesky_inplace`, all BLAS threads;
* ``dpotrf``   -- bare ``scipy.linalg.lapack.dpotrf(lower=1, overwrite_a=1)``, all threads;
* ``dpotrf-1t`` -- bare ``dpotrf`` with one BLAS thread (threadpoolctl): a known-safe
  workaround, shown for its cost;
* ``dpotrf-haswell`` -- bare ``dpotrf`` with ``OPENBLAS_CORETYPE=Haswell`` (AVX2 kernels):
  the other workaround, which a user would have to set before Python starts.

The matrix is the paper's K_gd^(s) (Eq. 14) at N spherical-Fibonacci nodes, written in
Fortran order by envfit's numba kernel (the Table 2 cell's matrix). Each worker reports the
factorisation's wall time and log det K; the log dets of the methods must agree to ~1e-12
relative (the factor is the same up to rounding). The CPU model, its AVX level, the
OpenBLAS core type and the load average are printed with the figures.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

METHODS = ("blocked", "dpotrf", "dpotrf-1t", "dpotrf-haswell")


def _matrix(n: int, s: float):
    import numpy as np
    from envfit.sobolev import _interpolation_kernels as _kernels  # internal: the numba kernel-matrix fill, timed bare
    from envfit.theory import kernel_constant
    j = np.arange(n)
    z = 1.0 - (2 * j + 1) / n
    phi = 2 * np.pi * np.mod(j / ((1 + 5 ** 0.5) / 2), 1.0)
    r = np.sqrt(np.maximum(0.0, 1 - z * z))
    px, py, pz = (np.ascontiguousarray(v) for v in (r * np.cos(phi), r * np.sin(phi), z))
    a = np.zeros((n, n), order="F")
    _kernels.fill_kernel_matrix(px, py, pz, s - 1.0, _kernels.power_kind(s - 1.0),
                                kernel_constant(s), a)
    return a


def worker(method: str, n: int, s: float) -> dict:
    """Factorise one matrix with ``method``; the result as a dict (printed as JSON)."""
    import numpy as np
    from scipy.linalg import lapack
    from threadpoolctl import threadpool_info, threadpool_limits
    from envfit.theory._cholesky import cholesky_inplace  # internal: the blocked kernel under test
    a = _matrix(n, s)
    limit = 1 if method == "dpotrf-1t" else None
    with threadpool_limits(limits=limit, user_api="blas"):
        t0 = time.perf_counter()
        if method == "blocked":
            info = cholesky_inplace(a)
        else:
            a, info = lapack.dpotrf(a, lower=1, overwrite_a=1, clean=0)
        seconds = time.perf_counter() - t0
        blas = [i for i in threadpool_info() if "scipy" in i.get("filepath", "")]
    return {"method": method, "n": n, "s": s, "seconds": seconds, "info": int(info),
            "log_det": float(2 * np.sum(np.log(np.diagonal(a)))),
            "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
            "coretype": blas[0].get("architecture") if blas else None,
            "threads": blas[0].get("num_threads") if blas else None}


def run_child(method: str, n: int, s: float) -> dict:
    env = dict(os.environ)
    if method == "dpotrf-haswell":
        env["OPENBLAS_CORETYPE"] = "Haswell"
    p = subprocess.run([sys.executable, __file__, "--worker", method, "--n", str(n), "--s", str(s)],
                       capture_output=True, text=True, env=env)
    if p.returncode != 0:
        sig = -p.returncode if p.returncode < 0 else None
        what = signal.Signals(sig).name if sig else f"exit {p.returncode}"
        return {"method": method, "n": n, "s": s, "crashed": what,
                "stderr": p.stderr.strip().splitlines()[-1:] }
    return json.loads(p.stdout.strip().splitlines()[-1])


def cpu_description() -> str:
    model, flags = platform.processor() or "?", ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and model in ("", "?", platform.machine()):
                model = line.split(":", 1)[1].strip()
            if line.startswith("flags") and not flags:
                flags = line
    except OSError:
        pass
    avx = "AVX-512" if "avx512f" in flags else ("AVX2" if "avx2" in flags else "no AVX2")
    return f"{model}, {avx}, {os.cpu_count()} CPUs"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="4000,8000,12000,16000,20000")
    ap.add_argument("--s", type=float, default=1.5)
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker, int(args.n), args.s)))
        return 0
    ns = [int(x) for x in args.n.split(",")]
    methods = [m for m in args.methods.split(",") if m]
    print(f"CPU: {cpu_description()}; load average at start {os.getloadavg()[0]:.2f}")
    rows = []
    for n in ns:
        for _ in range(args.repeats):
            for m in methods:
                r = run_child(m, n, args.s)
                r["load"] = os.getloadavg()[0]
                rows.append(r)
        base = {m: min((r["seconds"] for r in rows if r["n"] == n and r["method"] == m
                        and "seconds" in r), default=None) for m in methods}
        ref = next((r["log_det"] for r in rows if r["n"] == n and r.get("method") == "blocked"
                    and "log_det" in r), None)
        for m in methods:
            r = next(r for r in rows if r["n"] == n and r["method"] == m and "seconds" in r) \
                if base[m] is not None else next(r for r in rows if r["n"] == n and r["method"] == m)
            if "crashed" in r:
                print(f"N={n:6d} {m:15s} crashed ({r['crashed']})")
                continue
            ref_m = next((b for b in ("dpotrf", "dpotrf-haswell", "dpotrf-1t") if base.get(b)), None)
            ratio = f"{base[m] / base[ref_m]:.3f}x {ref_m}" if ref_m else "no bare dpotrf survived"
            rel = abs(r["log_det"] - ref) / abs(ref) if ref else float("nan")
            print(f"N={n:6d} {m:15s} {base[m]:8.2f} s  {ratio:26s} log det rel. diff {rel:.1e}  "
                  f"peak RSS {r['peak_rss_gb']:.2f} GB  [{r['coretype']}, {r['threads']} threads, "
                  f"load {r['load']:.2f}]")
    if args.json:
        args.json.write_text(json.dumps({"cpu": cpu_description(), "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

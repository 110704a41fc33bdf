"""Acceptance of ``envfit advise`` on Gaussian-process maps, where the model is exactly true.

For each GP map (``envfit.data_gen.gaussian_process_map(s0, height, seed, channels=3)``, linear
scale, s' and sigma' fitted by the likelihood of the kernel band-limited at the map's Nyquist
degree, as ``envfit advise`` does) and each target RMSE, the advisor picks the
smallest N for spherical Fibonacci and random points with equal and optimal weights; the
RMSE is then measured at that N over random axes (``check=True``: ground-truth shading
integrals, rules rotated and twisted per axis, random points as the RMS over the same
realisations the prediction averages). Prints measured/target and measured/predicted per
rule, whether |measured/target - 1| <= 25 %, and the time of a second, cached call.

    python bench/advise_check.py                              # s0 = 1.5 and 1.3, 256 rows
    python bench/advise_check.py --height 128 --targets 1e-2  # quicker
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time


import numpy as np  # noqa: E402

from envfit import EnvMap, advise  # noqa: E402
from envfit.data_gen import gaussian_process_map  # noqa: E402

TOLERANCE = 0.25
#: default targets per s0: N in the hundreds to a few thousand for sf
DEFAULT_TARGETS = {1.5: (1e-2, 3e-3), 1.3: (2e-2, 6e-3)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--s0", type=lambda t: [float(x) for x in t.split(",")], default=[1.5, 1.3])
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--seed", type=int, default=1, help="seed of the GP maps")
    ap.add_argument("--targets", type=lambda t: [float(x) for x in t.split(",")], default=None,
                    help="target RMSE values (default: per s0, see DEFAULT_TARGETS)")
    ap.add_argument("--brdf", default="diffuse")
    ap.add_argument("--axes", type=int, default=1000)
    ap.add_argument("--fit-n", type=int, default=3000)
    ap.add_argument("--cache-dir", default=None, help="default: a fresh temporary folder")
    args = ap.parse_args(argv)
    cache_dir = args.cache_dir or tempfile.mkdtemp(prefix="advise_check_")
    print(f"cache: {cache_dir}; {args.brdf}; {args.height} rows; {args.axes} axes; linear scale")
    print(f"{'map':<22s} {'target':>8s} {'rule':<13s} {'N':>6s} {'predicted':>10s} "
          f"{'measured':>10s} {'meas/target':>11s} {'meas/pred':>9s}  within 25%")
    ok_all, ratios, timing = True, [], []
    for s0 in args.s0:
        env = EnvMap(gaussian_process_map(s0, args.height, seed=args.seed, channels=3),
                     name=f"gp(s0={s0},H={args.height},seed={args.seed})")
        targets = args.targets or DEFAULT_TARGETS.get(s0, (1e-2,))
        for target in targets:
            kw = dict(scale="linear", fit_n=args.fit_n, pointsets=("sf", "random"),
                      weights=("equal", "osw"), bases=(), seed=0, cache_dir=cache_dir)
            a = advise(env, args.brdf, target, check=True, axes=args.axes, quiet=False, **kw)
            t0 = time.perf_counter()
            again = advise(env, args.brdf, target, **kw)
            dt = time.perf_counter() - t0
            timing.append((env.name, target, dt, again.fit_cached, again.cache["writes"]))
            for r in a.rows:
                if not r.reached:
                    print(f"{env.name:<22s} {target:>8.1e} {r.label:<13s} {r.setting:>6s}  "
                          f"{r.note}")
                    continue
                mt = r.measured_rmse / target
                ratios.append(mt)
                ok = abs(mt - 1.0) <= TOLERANCE
                ok_all &= ok
                print(f"{env.name:<22s} {target:>8.1e} {r.label:<13s} {r.n:>6d} "
                      f"{r.predicted_rmse:>10.3e} {r.measured_rmse:>10.3e} {mt:>11.3f} "
                      f"{r.measured_over_predicted:>9.3f}  {'yes' if ok else 'NO'}")
            print(f"  (s' fitted {a.s:.3f}, sigma' {a.sigma:.4f} ({a.fit_kernel} kernel, l <= "
                  f"{a.fit_band_lmax}); tau at l = H-1: {a.lookup_transfer[-1]:.3f}; "
                  f"first call {a.timings['total']:.1f} s "
                  f"= fit {a.timings['fit']:.1f} + search {a.timings['search']:.1f} + check "
                  f"{a.timings['check']:.1f})")
    r = np.array(ratios)
    print(f"measured/target over {r.size} rules: median {np.median(r):.3f}, range "
          f"{r.min():.3f}…{r.max():.3f}; all within {TOLERANCE:.0%}: {'yes' if ok_all else 'NO'}")
    for name, target, dt, fc, writes in timing:
        print(f"second call {name} target {target:g}: {dt:.3f} s in-process (cached fit: {fc}, "
              f"cache writes: {writes})")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())

"""Why Table 2 on a GP map of known s0 does not pick s0 (issue 22, item 10).

For s0 in {1.25, 1.5} and N in {1000, 2000, 4000}: the closed-form expected RMSE of Table 2's
reconstruction (envfit.fit._kriging, the map as data_gen synthesizes it: band-limited at
l <= H - 1, read through the bilinear lookup) against s, beside Table 2's measured RMSE on
data_gen maps (linear scale, seeds 0, 1, 2, 3 channels each), and the s that minimises each.
At the smallest N it also splits the shift into its causes: the full process seen exactly
(minimal at s0: the best linear predictor), + the synthesis band limit, + the lookup.

    python bench/known_s.py                      # 512x256 maps, about 20-40 min on 2 cores
    python bench/known_s.py --height 64 --n 300,600 --seeds 0   # a minute
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from envfit.data_gen import gaussian_process_map
from envfit.fit import (SynthesisModel, expected_interpolation_mse,
                                 expected_profiled_likelihood)
from envfit.fit import run_table2
from envfit.maps import EnvMap

S_GRID = (1.1, 1.25, 1.4, 1.5, 1.6, 1.7, 1.9)


def measured(s0, height, seeds, s_values, n_values):
    """Table 2 (linear scale, per-pixel RMSE) on data_gen maps: {seed: (len(s), len(N))}."""
    out = {}
    for seed in seeds:
        f = gaussian_process_map(s0, height, seed=seed, channels=3)
        f = f - f.min() + 0.1 * (f.max() - f.min())         # as `envfit synth` (offset auto)
        env = EnvMap(f, name=f"gp(s0={s0},seed={seed})")
        res = run_table2(env, s_values, n_values, scale="linear", solver="cholesky")
        out[seed] = res.rmse_table()
    return out


def attribution(s0, height, n, s_values, max_pixels):
    """Expected per-pixel RMSE for the chain of models, one line each."""
    lines = [f"  causes at N = {n} (expected per-pixel RMSE; best s of the grid, parabola vertex):"]
    for label, m in (("full process, exact values  ", SynthesisModel(s0, height, None, lookup=False)),
                     ("+ band limit l <= H-1       ", SynthesisModel.data_gen(s0, height, lookup=False)),
                     ("+ bilinear lookup (Table 2) ", SynthesisModel.data_gen(s0, height))):
        c = expected_interpolation_mse(m, s_values, n, max_pixels=max_pixels)
        lines.append(f"    {label} " + " ".join(f"{v:.5f}" for v in np.sqrt(c.mse_pixel))
                     + f"  best {c.s_best:g} (vertex {c.s_vertex():.2f})")
    return lines


def likelihood_line(s0, height, n):
    """Where envfit fit's likelihood (full kernel, lookups) converges on such maps."""
    grid = [round(s0 + d, 3) for d in (-0.05, 0.0, 0.05, 0.1, 0.15, 0.2, 0.25)]
    v = expected_profiled_likelihood(SynthesisModel.data_gen(s0, height), grid, n)
    k = int(np.clip(np.argmin(v), 1, len(grid) - 2))
    c = np.polyfit(grid[k - 1:k + 2], v[k - 1:k + 2], 2)
    return (f"  likelihood fit (full kernel, lookups), N = {n}: expected optimum s = "
            f"{-c[1] / (2 * c[0]):.3f} (grid {grid[0]:g}..{grid[-1]:g})")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--height", type=int, default=256)
    p.add_argument("--s0", default="1.25,1.5")
    p.add_argument("--n", default="1000,2000,4000")
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--max-pixels", type=int, default=8192,
                   help="closed form: evaluation pixels (evenly spaced rows)")
    p.add_argument("--likelihood-n", type=int, default=3000,
                   help="N of the expected likelihood optimum (envfit fit's default); 0: skip")
    a = p.parse_args()
    s_values = list(S_GRID)
    n_values = [int(v) for v in a.n.split(",")]
    seeds = [int(v) for v in a.seeds.split(",") if v != ""]
    print(f"maps {2 * a.height}x{a.height}, linear scale, s grid {s_values}")
    for s0 in (float(v) for v in a.s0.split(",")):
        t0 = time.perf_counter()
        meas = measured(s0, a.height, seeds, s_values, n_values) if seeds else {}
        print(f"\ns0 = {s0:g}  (measured: Table 2 on seeds {seeds}, 3 channels each)")
        for k, n in enumerate(n_values):
            c = expected_interpolation_mse(SynthesisModel.data_gen(s0, a.height), s_values, n,
                                           max_pixels=a.max_pixels)
            print(f"  N = {n}:  s     expected RMSE   " + "  ".join(f"seed {s}" for s in seeds))
            for i, s in enumerate(s_values):
                print(f"          {s:<5g} {np.sqrt(c.mse_pixel[i]):.5f}        "
                      + "  ".join(f"{meas[sd][i, k]:.5f}" for sd in seeds))
            best = "  ".join(f"{s_values[int(np.argmin(meas[sd][:, k]))]:<6g}" for sd in seeds)
            print(f"          best  {c.s_best:<5g} (vertex {c.s_vertex():.2f}) {best}")
        for line in attribution(s0, a.height, n_values[0], s_values, a.max_pixels):
            print(line)
        if a.likelihood_n:
            print(likelihood_line(s0, a.height, a.likelihood_n))
        print(f"  ({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()

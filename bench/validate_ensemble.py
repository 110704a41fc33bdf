"""Ensemble check of prediction (b') on independent Gaussian-process maps.

One map is one realisation of the field; prediction (b') is an expectation over the
ensemble. This script runs :func:`envfit.validate.run_validation` (diffuse, equal weights,
random and spherical Fibonacci points) on ``--maps`` independent GP maps of ``--channels``
channels each and prints, per map, the ratio predicted (b') / measured per N, the expected
one-map spread (``model_scatter``) and the map's realised power at l = 1 relative to the
fitted model, then the mean and standard deviation of the ratio over the maps.

    python bench/validate_ensemble.py                    # s fitted per map (8 maps)
    python bench/validate_ensemble.py --s 1.5 --maps 4   # the true s0 instead of the fit
    python bench/validate_ensemble.py --brdfs diffuse,glossy
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


from envfit.data_gen import gaussian_process_map  # noqa: E402
from envfit.maps import EnvMap  # noqa: E402
from envfit.validate import ValidateConfig, run_validation  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--s0", type=float, default=1.5, help="smoothness of the synthesized maps")
    ap.add_argument("--s", default="auto", help="s used for the prediction: auto (fitted) or a value")
    ap.add_argument("--maps", type=int, default=8)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--channels", type=int, default=12)
    ap.add_argument("--axes", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=100, help="first map's seed (maps use seed+1 …)")
    ap.add_argument("--brdfs", default="diffuse", help="comma-separated: diffuse,glossy")
    args = ap.parse_args(argv)
    ns = (64, 256, 1024, 4096)
    brdfs = tuple(b.strip() for b in args.brdfs.split(",") if b.strip())
    ratios: dict[tuple, list] = {(b, p): [] for b in brdfs for p in ("random", "sf")}
    for k in range(1, args.maps + 1):
        env = EnvMap(gaussian_process_map(args.s0, args.height, seed=args.seed + k,
                                          channels=args.channels), name=f"gp{k}")
        cfg = ValidateConfig(s=args.s, brdfs=brdfs, pointsets=("random", "sf"),
                             weights=("equal",), n_values=ns, axes=args.axes, scale="linear",
                             truncation=False)
        r = run_validation(env, cfg)
        rho1 = r.map_stats["power_ratio_low_degrees"]["1"]
        for e in r.results:
            q = np.array(e["predicted_rmse_refined"]) / np.array(e["measured_rmse"])
            ratios[(e["brdf"], e["pointset"])].append(q)
            print(f"map {k} s={r.s:.3f} s_refined={r.s_refined:.3f} {e['brdf']:7s} "
                  f"{e['pointset']:6s} (b')/measured {np.round(q, 3)} "
                  f"expected sd {np.round(e['model_scatter'], 3)} rho_1 {rho1:.2f}", flush=True)
    for (b, ps), qs in ratios.items():
        q = np.array(qs)
        sd = q.std(0, ddof=1).round(3) if len(q) > 1 else "– (one map)"
        print(f"{b:7s} {ps:6s} N = {ns}: mean ratio {q.mean(0).round(3)}, sd {sd}, "
              f"max |ratio - 1| {np.abs(q - 1).max():.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

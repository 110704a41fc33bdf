"""One rendered cell of bench/render_check.py, rendered again with K fresh seeds: is its
measured RMSE a rare event, or the bulk of the pixels?

For each seed: the RMSE over the sphere with its bootstrap 95 % interval, and the share of the
squared error held by the top 1, 10 and 100 pixels (a rare event: one pixel holding a large
share); at the end the RMSE of the seeds' mean MSE and the median seed's. The references are
those of render_check (``--cache``: the same folder gives the same references).

    python bench/render_seeds.py /work/shared/envmaps/city.exr --renderer cycles \\
        --sampler tabulated_sobol --strategy mis --spp 1024 --seeds 3 --cache /tmp/rc/cache
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from render_check import _cpu, _session, load_map  # noqa: E402  (bench helpers)

from envfit.renderers import sphere_error  # noqa: E402


def top_shares(d: np.ndarray, w: np.ndarray, counts=(1, 10, 100)) -> list[float]:
    """The share of the weighted squared error sum(w d) held by the ``counts`` largest pixels."""
    x = np.sort((w * d).ravel())[::-1]
    total = x.sum()
    return [float(x[:k].sum() / total) for k in counts]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("map", help="map file, or sun-gp-1.5 / sun-gp-1.3")
    ap.add_argument("--renderer", choices=("mitsuba3", "cycles"), default="mitsuba3")
    ap.add_argument("--sampler", required=True)
    ap.add_argument("--strategy", required=True)
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=100)
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference-sampler", default="independent")
    ap.add_argument("--synth-height", type=int, default=256)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--cache", required=True, help="reference cache folder")
    args = ap.parse_args(argv)
    name, env = load_map(args.map, args.synth_height)
    sessions = _session(args.renderer, env, args)
    s = sessions["plain"]
    try:
        ref = s.reference()
        g = s.geometry
        w = np.broadcast_to(g.weight[g.keep], (6, int(g.keep.sum())))
        v = (0.25 * (ref.a - ref.b) ** 2).mean(axis=-1)[:, g.keep]
        mid = 0.5 * (ref.a + ref.b)
        mses = []
        for k in range(args.seeds):
            imgs, _ = s.render(args.strategy, args.sampler, args.spp,
                               np.random.default_rng(args.first_seed + k))
            d = ((imgs - mid) ** 2).mean(axis=-1)[:, g.keep] - v
            e = sphere_error(imgs, ref.a, ref.b, g, seed=0)
            mses.append(float(np.sum(w * d) / np.sum(w)))
            t1, t10, t100 = top_shares(d, w)
            print(f"seed {args.first_seed + k}: RMSE {e.rmse:.4g} [{e.low:.4g}, {e.high:.4g}]; "
                  f"top 1 / 10 / 100 pixels hold {100 * t1:.1f} / {100 * t10:.1f} / "
                  f"{100 * t100:.1f} % of the squared error", flush=True)
    finally:
        for x in set(sessions.values()):
            x.close()
    m = np.array(mses)
    print(f"{name} {args.renderer} {args.sampler} {args.strategy} {args.spp} spp: RMSE of the "
          f"mean MSE {np.sqrt(max(m.mean(), 0)):.4g}, median seed {np.sqrt(max(np.median(m), 0)):.4g}"
          f" ({len(m)} seeds); CPU {_cpu()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

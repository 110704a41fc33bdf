"""Mitsuba 3's ``path`` (its default integrator) against ``direct`` with one sample of each
technique, rendered (issue 41): the same sphere, map, sampler, spp and seeds, the two
integrators' RMSE over the sphere (bootstrap 95 % intervals) and their ratio.

On envfit's lone sphere the two estimates differ only in where the BSDF's draws stand among
the sampler's dimensions (``envfit.renderers.mitsuba3._envmap``: ``_path_draws``,
``_direct_draws``), so samplers whose dimensions are alike (``independent``, ``stratified``,
``multijitter``, ``ldsampler`` without a footprint) measure the same, and ``orthogonal``,
whose BSDF points take another Bose pattern, does not.

    python bench/mitsuba_path_check.py MAP.exr --samplers independent ldsampler orthogonal \\
        --spp 16 64 256 --resolution 32 --out /tmp/pc

Writes ``OUT/mitsuba_path_check.json`` (rows and the CPU) and prints the table.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from envfit.base._atomic import atomic_write_json  # internal: the product's atomic writer
from envfit.maps import load_envmap
from envfit.renderers import get_renderer

sys.path.insert(0, str(Path(__file__).parent))
from render_check import _cpu  # noqa: E402  (bench helper: the CPU's name)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("map")
    ap.add_argument("--samplers", nargs="+", default=["independent", "ldsampler", "orthogonal"])
    ap.add_argument("--spp", nargs="+", type=int, default=[16, 64, 256])
    ap.add_argument("--resolution", type=int, default=32)
    ap.add_argument("--max-height", type=int, default=64)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()

    harness = get_renderer("mitsuba3").harness_module()      # Mitsuba3Sphere, its options
    env = load_envmap(args.map, max_height=args.max_height)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, t0 = [], time.perf_counter()
    opts = harness.Mitsuba3Options(resolution=args.resolution, reference_spp=args.reference_spp,
                                   cache_dir=str(out / "cache"))
    with harness.Mitsuba3Sphere(env, opts) as r:
        ref = r.reference()
        integrators = {"path": r._integrator("mis"),            # the record's mis: path
                       "direct": r.mi.load_dict({"type": "direct", "emitter_samples": 1,
                                                 "bsdf_samples": 1})}
        for sampler in args.samplers:
            for spp in args.spp:
                row = {"sampler": sampler, "spp": spp, "spp_used": r.spp_used(sampler, spp)}
                for name, integ in integrators.items():
                    r._integrators["mis"] = integ
                    m = r.measure("mis", sampler, spp, seed=args.seed, reference=ref)
                    row[name] = {"rmse": m.rmse, "low": m.low, "high": m.high}
                r._integrators["mis"] = integrators["path"]
                row["ratio"] = row["path"]["rmse"] / row["direct"]["rmse"]
                row["disjoint"] = (row["path"]["low"] > row["direct"]["high"]
                                   or row["direct"]["low"] > row["path"]["high"])
                rows.append(row)
                print(f"{sampler:12s} {spp:5d}->{row['spp_used']:<5d} direct "
                      f"{row['direct']['rmse']:.4g} [{row['direct']['low']:.4g}, "
                      f"{row['direct']['high']:.4g}]  path {row['path']['rmse']:.4g} "
                      f"[{row['path']['low']:.4g}, {row['path']['high']:.4g}]  path/direct "
                      f"{row['ratio']:.3f}{'  (intervals disjoint)' if row['disjoint'] else ''}",
                      flush=True)
                atomic_write_json(out / "mitsuba_path_check.json",
                                  {"meta": {"cpu": _cpu(), "map": args.map,
                                            "resolution": args.resolution,
                                            "max_height": args.max_height},
                                   "rows": rows})
    print(f"CPU: {_cpu()}; wall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()

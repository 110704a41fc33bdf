"""Acceptance run of the renderer predictions (issue: renderer-grade predictions).

For each map (linear radiance) — the files given, plus two synthesized sun + GP maps with
a sun of known radiance and radius — run the renderer validation of ``envfit validate
--renderer`` (envfit.validate._renderer.run_renderer_validation, full settings unless
--quick): every strategy (brdf, map, mis, split) × point set (random, sobol, sf) × N × lobe
(diffuse, glossy n = 30), predicted vs measured RMSE with its bootstrap 95 % interval. Prints
per rule the median ratio predicted/measured and the fraction of cells that agree (within
20 % or inside the interval), and whether every rule meets the acceptance (median in
0.9–1.1 and ≥ 80 % agree); writes one JSON per map.

    python bench/renderer_acceptance.py ../shared/envmaps/city.exr ../shared/envmaps/forest.exr \\
        --out /tmp/acc

Also prints the CPU (lscpu model name) and the wall time per map.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path

from envfit.data_gen import sun_gp_map
from envfit.maps import EnvMap, load_envmap
from envfit.validate._renderer import (  # internal: the renderer validation has no public entry but the CLI
    renderer_config, run_renderer_validation)

#: the synthesized maps: (name, sun_gp_map keywords)
SYNTH = [
    ("sun-gp-1.5", dict(seed=1, s0=1.5, sun_theta=0.6, sun_phi=1.0, sun_radius=0.02,
                        sun_radiance=(27000.0, 26000.0, 24000.0), channels=3, offset=4.0)),
    ("sun-gp-1.3", dict(seed=2, s0=1.3, sun_theta=1.2, sun_phi=4.0, sun_radius=0.05,
                        sun_radiance=(2000.0, 1800.0, 1500.0), channels=3, offset=6.0)),
]


def _cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        return next(line.split(":", 1)[1].strip() for line in out.splitlines()
                    if line.startswith("Model name"))
    except (OSError, StopIteration):
        return "unknown"


def _maps(paths, height: int):
    for p in paths:
        yield Path(p).stem, load_envmap(p)
    for name, kw in SYNTH:
        arr, sun = sun_gp_map(height, **kw)
        yield name, EnvMap(arr, up="z", name=name)


def _report(name: str, res) -> bool:
    ok = True
    print(f"\n{name}: sources {[round(s['share'], 3) for s in res.sources]}")
    print(f"  {'lobe':8s} {'rule':14s} {'cells':>5s} {'median':>7s} {'agree':>6s} {'worst':>7s}")
    for r in res.rules:
        good = (r.median_ratio is not None and 0.9 <= r.median_ratio <= 1.1
                and r.fraction_agree >= 0.8)
        ok &= good
        print(f"  {r.lobe:8s} {r.strategy + '/' + r.pointset:14s} {r.cells:5d} "
              f"{r.median_ratio:7.3f} {r.fraction_agree:6.0%} {r.worst_ratio:7.3f}"
              + ("" if good else "   <- misses"))
    for lobe in res.lobes:
        print(f"  {lobe.lobe}: median {lobe.median_ratio:.3f}, {lobe.fraction_agree:.0%} agree, "
              f"worst {lobe.worst_ratio:.3f} ({lobe.worst_rule}, N = {lobe.worst_n})")
    return ok


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="*")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--synth-height", type=int, default=256)
    ap.add_argument("--no-synth", action="store_true")
    args = ap.parse_args()
    if args.no_synth:
        SYNTH.clear()
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"CPU: {_cpu()}")
    all_ok = True
    for name, env in _maps(args.maps, args.synth_height):
        t0 = time.perf_counter()
        res = run_renderer_validation(env, renderer_config(quick=args.quick), scale="linear",
                                      out=args.out / name, quiet=True)
        wall = time.perf_counter() - t0
        (args.out / f"{name}.json").write_text(json.dumps(res.to_json(), indent=1))
        all_ok &= _report(f"{name} ({env.width}x{env.height}, {wall:.0f} s)", res)
    print("\nacceptance:", "every rule meets it" if all_ok else "some rules miss (marked)")
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())

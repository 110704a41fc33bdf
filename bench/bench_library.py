"""Benchmark: Table 2 over a library of maps (one factorisation per (s, N)) vs one map.

Run:  /tmp/venv/bin/python bench/bench_library.py [--n 20000] [--maps 20] [--height 512]
      [--s 1.5] [--workers 1] [--json out.json] [--quick] [MAP_OR_DIR ...]

The kernel matrix depends on the sample directions and s only, so a library of M maps
should cost one factorisation (N^3/3 flops; ~40 s and 3.2 GB at N = 20000) plus M
evaluations (~1 s each at 1024 x 512), not M factorisations. This script measures it
with the product's own entry point, :func:`envfit.batch.run_table2_library`:

* **one**: the first map alone (one factorisation, one evaluation);
* **many**: all M maps (one factorisation, M right-hand sides, M evaluations streamed map
  by map, each map loaded from disk when its task runs).

Each phase runs in its own child process, so its wall time and peak RSS are its own; the
1-minute load average is recorded before and after each (the machine may be shared). The
maps are synthesised Gaussian-process maps of H rows (s0 = 1.5, different seeds), written
as EXR files into a temporary folder, unless files or folders are given.

Reported: wall seconds of each phase, the ratio many/one (target: well under 2 for
M = 20 at N = 20000), what M independent single-map runs would cost (M x one), peak RSS,
and the factorisation counts (must be 1 and 1). ``--quick``: N = 2000, 5 maps of 128 rows.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path



def load() -> float:
    return round(os.getloadavg()[0], 2)


def phase(args: argparse.Namespace) -> None:
    """Child process: run one library sweep and print a JSON line with its figures."""
    from envfit.batch import LibraryOptions, run_table2_library
    maps = json.loads(args.phase_maps)
    t0 = time.perf_counter()
    lib = run_table2_library(maps, [args.s], [args.n], scale="display",
                             options=LibraryOptions(workers=args.workers))
    wall = time.perf_counter() - t0
    cells = [r.cells[0] for r in lib.maps]
    print(json.dumps({
        "maps": len(maps), "wall_s": wall, "factorizations": lib.factorizations,
        "seconds_factorization": cells[0].seconds_fit,
        "seconds_evaluate_per_map": sum(c.seconds_evaluate for c in cells) / len(cells),
        "rmse": [c.rmse for c in cells], "executor": lib.executor,
        "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))


def synthesize(folder: Path, count: int, height: int) -> list[str]:
    import numpy as np

    from envfit.data_gen import gaussian_process_map
    from envfit.maps import EnvMap, save_envmap
    paths = []
    for k in range(count):
        f = gaussian_process_map(1.5, height, seed=k, channels=3)
        env = EnvMap((f - f.min() + 0.1).astype(np.float32), name=f"gp{k:03d}")
        paths.append(str(save_envmap(folder / f"gp{k:03d}.exr", env)))
    return paths


def run_phase(args, maps: list[str]) -> dict:
    cmd = [sys.executable, __file__, "--phase-maps", json.dumps(maps), "--n", str(args.n),
           "--s", str(args.s), "--workers", str(args.workers)]
    before = load()
    res = subprocess.run(cmd, check=True, capture_output=True, text=True)
    out = json.loads(res.stdout.strip().splitlines()[-1])
    out["load_before"], out["load_after"] = before, load()
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("maps", nargs="*", help="map files or folders (default: synthesised GP maps)")
    p.add_argument("--n", type=int, default=20000)
    p.add_argument("--s", type=float, default=1.5)
    p.add_argument("--maps", dest="count", type=int, default=20)
    p.add_argument("--height", type=int, default=512)
    p.add_argument("--workers", type=int, default=1,
                   help="local workers (default 1: inline, every core for each task)")
    p.add_argument("--quick", action="store_true", help="N = 2000, 5 maps of 128 rows")
    p.add_argument("--json", type=Path, default=None)
    p.add_argument("--phase-maps", default=None, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.phase_maps is not None:
        phase(args)
        return 0
    if args.quick:
        args.n, args.count, args.height = 2000, 5, 128
    from envfit.maps._lazy_maps import resolve_map_sources  # internal: the library run's own file resolver
    with tempfile.TemporaryDirectory(prefix="bench_library_") as tmp:
        if args.maps:
            maps = [s.path for s in resolve_map_sources(args.maps)]
        else:
            t = time.perf_counter()
            maps = synthesize(Path(tmp), args.count, args.height)
            print(f"synthesised {len(maps)} GP maps ({2 * args.height}x{args.height}) in "
                  f"{time.perf_counter() - t:.1f} s", flush=True)
        print(f"N = {args.n}, s = {args.s}, {len(maps)} maps; {os.cpu_count()} CPUs, "
              f"load average {load()}", flush=True)
        one = run_phase(args, maps[:1])
        print(f"one map : {one['wall_s']:7.1f} s (factorisation {one['seconds_factorization']:.1f} s, "
              f"evaluation {one['seconds_evaluate_per_map']:.2f} s), peak RSS "
              f"{one['peak_rss_bytes'] / 1e9:.2f} GB, load {one['load_before']} -> {one['load_after']}",
              flush=True)
        many = run_phase(args, maps)
        print(f"{len(maps)} maps: {many['wall_s']:7.1f} s (factorisation {many['seconds_factorization']:.1f} s, "
              f"evaluation {many['seconds_evaluate_per_map']:.2f} s per map), peak RSS "
              f"{many['peak_rss_bytes'] / 1e9:.2f} GB, load {many['load_before']} -> {many['load_after']}",
              flush=True)
    ratio = many["wall_s"] / one["wall_s"]
    print(f"ratio {len(maps)} maps / 1 map = {ratio:.2f} (independent runs: {len(maps)}x = "
          f"{len(maps) * one['wall_s']:.0f} s); factorisations: {one['factorizations']} and "
          f"{many['factorizations']}; map 0's RMSE alone vs in the library: relative difference "
          f"{abs(one['rmse'][0] / many['rmse'][0] - 1):.1e}")
    report = {"n": args.n, "s": args.s, "maps": len(maps), "height": args.height,
              "one": one, "many": many, "ratio": ratio, "cpus": os.cpu_count()}
    if args.json:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

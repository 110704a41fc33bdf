"""Acceptance of ``envfit advise --check`` on real maps with a sun (linear scale): for each
map, lobe and relative target, every row's measured RMSE over its target (paper rows: the
BRDF-morphed rules and SH/HSH, measured on ``--axes`` random axes; renderer rows: BRDF, map,
MIS and split, measured adaptively to a ±10 % bootstrap interval), and whether the
recommended renderer rule is the cheapest row whose measurement meets the target.

    python bench/advise_renderer_check.py MAP [MAP ...] [--brdf diffuse,glossy]
        [--targets 0.01,0.05] [--axes 1000] [--json FILE]

Prints one table per (map, lobe, target) and a summary line; ``--json`` writes every row.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import tempfile
import time

from envfit import advise, load_envmap

TOLERANCE = 1.25


def _cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        model = next(line.split(":", 1)[1].strip() for line in out.splitlines()
                     if line.startswith("Model name"))
        avx = "AVX-512" if "avx512f" in out else ("AVX2" if "avx2" in out else "no AVX2")
        return f"{model}, {avx}, {os.cpu_count()} cores"
    except (OSError, subprocess.CalledProcessError, StopIteration):
        return platform.processor() or "unknown CPU"


def _rows(a) -> list[dict]:
    """Every checked row: paper rows and renderer rows, with cost and measured/target."""
    out = []
    for r in a.rows:
        if r.measured_rmse is not None:
            out.append({"kind": "paper", "rule": r.label, "n": r.n if r.n else r.L,
                        "cost": r.cost, "predicted": r.predicted,
                        "measured": r.measured_rmse, "over_target": r.measured_over_target})
    if a.renderer is not None:
        for r in a.renderer.rows:
            if r.measured_rmse is not None:
                out.append({"kind": "renderer", "rule": r.label, "n": r.n, "cost": r.cost,
                            "predicted": r.predicted_rmse, "measured": r.measured_rmse,
                            "low": r.measured_low, "high": r.measured_high,
                            "over_target": r.measured_over_target})
    return out


def _cheapest_met(rows: list[dict], target: float) -> dict | None:
    met = [r for r in rows if r["kind"] == "renderer" and r["measured"] <= target]
    return min(met, key=lambda r: r["cost"]) if met else None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--brdf", default="diffuse,glossy")
    ap.add_argument("--targets", default="0.01,0.05")
    ap.add_argument("--axes", type=int, default=1000)
    ap.add_argument("--json", default=None)
    ap.add_argument("--cache-dir", default=None, help="default: a fresh temporary folder")
    args = ap.parse_args(argv)
    cache = args.cache_dir or tempfile.mkdtemp(prefix="advise_renderer_check_")
    print(f"CPU: {_cpu()}; load {os.getloadavg()[0]:.1f}; cache {cache}")
    results, worst, recs_ok, combos = [], 0.0, 0, 0
    for path in args.maps:
        env = load_envmap(path)
        for brdf in args.brdf.split(","):
            for t in (float(x) for x in args.targets.split(",")):
                t0 = time.perf_counter()
                a = advise(env, brdf, target_relative=t, check=True, axes=args.axes,
                           cache_dir=cache, quiet=True, renderer=True)
                rows = _rows(a)
                best = a.renderer.best() if a.renderer is not None else None
                cheap = _cheapest_met(rows, a.target_rmse)
                same = best is not None and cheap is not None and best.label == cheap["rule"]
                combos += 1
                recs_ok += same
                print(f"\n{os.path.basename(path)} {brdf} target {t:g} of the mean "
                      f"(RMSE {a.target_rmse:.4g}); {time.perf_counter() - t0:.0f} s")
                for r in sorted(rows, key=lambda r: (r["kind"], r["cost"] or 0)):
                    flag = "ok" if r["over_target"] <= TOLERANCE else "OVER"
                    print(f"  {r['kind']:<8s} {r['rule']:<18s} N/L {str(r['n']):>6s} "
                          f"cost {str(r['cost']):>6s} pred {r['predicted']:.4g} "
                          f"meas {r['measured']:.4g} meas/target {r['over_target']:.3f} {flag}")
                    worst = max(worst, r["over_target"])
                print(f"  recommended: {best.label if best else None}; cheapest renderer row "
                      f"measured to meet the target: {cheap['rule'] if cheap else None} "
                      f"({'same' if same else 'DIFFERENT'})")
                results.append({"map": path, "brdf": brdf, "target_relative": t,
                                "target_rmse": a.target_rmse, "rows": rows,
                                "recommended": best.label if best else None,
                                "cheapest_met": cheap["rule"] if cheap else None})
    print(f"\nworst measured/target {worst:.3f} (limit {TOLERANCE}); recommendation = cheapest "
          f"measured-to-meet renderer row in {recs_ok}/{combos}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"cpu": _cpu(), "results": results}, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

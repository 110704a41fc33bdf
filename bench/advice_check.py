"""Is envfit's advice in a renderer's terms right when rendered? (issue 24, "advice" acceptance)

For each map × sampler × target (a fraction of the map's mean radiance): ask
:func:`envfit.advisor.advise_preset` (the same call as ``envfit advise MAP --renderer mitsuba3
--sampler S --target-relative T``) for the spp of the renderer's default strategy (MIS,
Mitsuba's ``path`` at its defaults), render the sphere set-up of
:mod:`envfit.renderers` with Mitsuba 3 at that spp and at half of it — the largest spp
the sampler runs at or below spp / 2 (its own rounding: ``ldsampler`` runs 4^k, so "half" of
256 is 64; ``independent`` runs any spp, so half is spp // 2) — and report the measured RMSE over uniform normals with its
bootstrap 95 % interval against the target:

* **holds**: the recommended spp measures ≤ 1.25 × the target;
* **not wasteful**: half that spp measures above the target.

Writes ``OUT/advice_check.json`` and ``.csv`` after every render and skips the rows already
there (resumable); prints the table and the CPU.

    python bench/advice_check.py /work/shared/envmaps/city.exr /work/shared/envmaps/forest.exr \\
        --samplers independent ldsampler --targets 0.01 0.05 --out /tmp/ac
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from envfit.advisor import RendererAdviseOptions, advise_renderer_map
from envfit.base._atomic import atomic_write_csv, atomic_write_json  # internal: the atomic writers of the product's outputs
from envfit.base._progress import progress_bar  # internal: the product's progress bar

sys.path.insert(0, str(Path(__file__).parent))
from render_check import _cpu, load_map  # noqa: E402  (bench helpers: CPU name, maps)

COLUMNS = ["map", "sampler", "target_relative", "target_rmse", "role", "spp", "spp_used",
           "predicted_rmse", "measured_rmse", "low", "high", "measured_over_target",
           "verdict", "mean_offset", "seconds"]


def advice(env, sampler: str, target: float, args) -> dict:
    """The advice (recommended spp, half of it as the sampler runs it, their predictions)."""
    t = time.perf_counter()
    opts = RendererAdviseOptions("mitsuba3", sampler=sampler, strategies=["mis"],
                               level=args.level, normals=args.normals)
    adv = advise_renderer_map(env, opts.asking(target_relative=target, cache_dir=args.cache))
    a = adv.default
    half = half_spp(opts, a.spp) if a.reached else None
    half_pred = None
    if half is not None:            # the model's prediction there (cached cells, one pass)
        adv2 = advise_renderer_map(env, RendererAdviseOptions("mitsuba3", sampler=sampler,
                                                      strategies=["mis"], spp=[half],
                                                      level=args.level, normals=args.normals).asking(
            target_relative=target, cache_dir=args.cache))
        half_pred = adv2.cells[("mis", half)]
    return {"spp": a.spp, "predicted": a.predicted_rmse, "half": half,
            "half_predicted": half_pred, "target_rmse": adv.target_rmse,
            "seconds": time.perf_counter() - t, "reached": a.reached,
            "searched_max": a.searched_max}


def half_spp(opts, spp: int) -> int | None:
    """The largest spp the sampler runs at or below spp / 2 (None below 2)."""
    spec = opts.record.sampler(opts.sampler)
    n = spp // 2
    while n >= 1 and spec.spp(n) > spp // 2:
        n -= 1
    return spec.spp(n) if n >= 1 else None


def _verdict(role: str, measured: float, target: float) -> str:
    if role == "recommended":
        return "holds" if measured <= 1.25 * target else "FAILS (> 1.25 x target)"
    return "not wasteful" if measured > target else "WASTEFUL (half meets the target)"


def _write(out: Path, rows: list, meta: dict) -> None:
    atomic_write_json(out / "advice_check.json", {"meta": meta, "rows": rows})
    atomic_write_csv(out / "advice_check.csv", COLUMNS,
                     [[r.get(c, "") for c in COLUMNS] for r in rows])


def run_map(spec: str, args, rows: list, meta: dict, out: Path) -> None:
    from envfit.renderers import Mitsuba3Options, Mitsuba3Sphere
    name, env = load_map(spec, args.synth_height)
    todo = [(s, t) for s in args.samplers for t in args.targets
            if not any(r["map"] == name and r["sampler"] == s and r["target_relative"] == t
                       and r["role"] == "half" for r in rows)]
    if not todo:
        return
    session = Mitsuba3Sphere(env, Mitsuba3Options(
        resolution=args.resolution, reference_spp=args.reference_spp, cache_dir=args.cache,
        reference_sampler=args.reference_sampler))
    bar = progress_bar(2 * len(todo) + 1, desc=f"advice {name}", unit="render")
    try:
        ref = session.reference()
        bar.update(1)
        rng = np.random.default_rng([args.seed, len(rows)])
        for sampler, target in todo:
            a = advice(env, sampler, target, args)
            meta.setdefault("advise_seconds", {})[f"{name}/{sampler}/{target}"] = a["seconds"]
            if not a["reached"]:
                print(f"{name} {sampler} {target}: not reached up to {a['searched_max']} spp")
                continue
            for role, spp, pred in (("recommended", a["spp"], a["predicted"]),
                                    ("half", a["half"], a["half_predicted"])):
                if spp is None or any(r["map"] == name and r["sampler"] == sampler
                                      and r["target_relative"] == target and r["role"] == role
                                      for r in rows):
                    continue
                m = session.measure("mis", sampler, spp, seed=rng, reference=ref)
                rows.append({"map": name, "sampler": sampler, "target_relative": target,
                             "target_rmse": a["target_rmse"], "role": role, "spp": spp,
                             "spp_used": m.spp_used, "predicted_rmse": pred,
                             "measured_rmse": m.rmse, "low": m.low, "high": m.high,
                             "measured_over_target": m.rmse / a["target_rmse"],
                             "verdict": _verdict(role, m.rmse, a["target_rmse"]),
                             "mean_offset": m.mean_offset, "seconds": m.seconds})
                _write(out, rows, meta)
                bar.update(1)
    finally:
        bar.close()
        session.close()


def print_table(rows: list) -> None:
    print(f"{'map':10s} {'sampler':12s} {'target':>7s} {'role':12s} {'spp':>5s} "
          f"{'predicted':>10s} {'measured':>10s} {'95% interval':>22s} {'meas/target':>11s}  verdict")
    for r in rows:
        print(f"{r['map']:10s} {r['sampler']:12s} {r['target_relative']:7.2%} {r['role']:12s} "
              f"{r['spp_used']:5d} {r['predicted_rmse']:10.4g} {r['measured_rmse']:10.4g} "
              f"[{r['low']:9.4g}, {r['high']:9.4g}] {r['measured_over_target']:11.3f}  "
              f"{r['verdict']}")
    rec = [r for r in rows if r["role"] == "recommended"]
    low = [r for r in rows if r["role"] == "half"]
    print(f"\nrecommended spp holds (measured <= 1.25 x target): "
          f"{sum(r['verdict'] == 'holds' for r in rec)}/{len(rec)}; half that spp "
          f"misses the target: {sum(r['verdict'] == 'not wasteful' for r in low)}/{len(low)}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", help="map files, or sun-gp-1.5 / sun-gp-1.3")
    ap.add_argument("--samplers", nargs="+", default=["independent", "ldsampler"])
    ap.add_argument("--targets", nargs="+", type=float, default=[0.01, 0.05])
    ap.add_argument("--level", type=int, default=None,
                    help="advise's --renderer-level (default: the sampler's default; 11 "
                         "resolves ldsampler to 1024 spp)")
    ap.add_argument("--normals", type=int, default=48, help="advise's --renderer-normals")
    ap.add_argument("--resolution", type=int, default=64, help="pixels per view side")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference-sampler", default="ldsampler",
                    help="the references' sampler (ldsampler: far less noise at the same spp)")
    ap.add_argument("--synth-height", type=int, default=256)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=None, help="advisor and reference cache (OUT/cache)")
    ap.add_argument("--out", default="advice_check_out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.cache = args.cache or str(out / "cache")
    path = out / "advice_check.json"
    rows, meta = [], {}
    if path.exists():
        saved = json.loads(path.read_text())
        rows, meta = saved["rows"], saved["meta"]
    meta.update(cpu=_cpu(), resolution=args.resolution, reference_spp=args.reference_spp,
                reference_sampler=args.reference_sampler, argv=sys.argv[1:])
    t = time.perf_counter()
    for spec in args.maps:
        run_map(spec, args, rows, meta, out)
    print_table(rows)
    print(f"\nCPU: {meta['cpu']}; wall {time.perf_counter() - t:.0f} s this run")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

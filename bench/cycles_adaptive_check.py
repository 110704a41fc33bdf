"""Rendering check of the adaptive-sampling model (issue 41): Cycles renders envfit's white
diffuse sphere (six orthographic views, envfit.renderers) with adaptive sampling on, and the
measured RMSE over uniform normals (bootstrap 95 % interval) and the samples the sphere's
pixels took (Cycles' Debug Sample Count pass, averaged as the RMSE is) are set against
:class:`envfit.predict.renderer._adaptive.AdaptiveModel`.

For each map × noise threshold: measured RMSE [low, high], predicted, ratio, inside
([0.8 × low, 1.25 × high]); measured and predicted mean spp and their ratio (the issue's
rule: within 20 %); with ``--target-relative``, the threshold the model advises for that
target (relative to the sphere's mean radiance), rendered: it meets the target, or not.
Writes ``OUT/cycles_adaptive.json`` after every cell (resumable: done cells are skipped);
``--repredict`` predicts the saved rows again with the current model, without rendering.

    python bench/cycles_adaptive_check.py /tmp/maps/forest64.exr /tmp/maps/city64.exr \\
        sun-gp-1.5 --synth-height 64 --thresholds 0.1 0.03 0.01 --resolution 32 \\
        --reference-spp 2048 --out /tmp/ac

Needs bpy (``pip install bpy==5.0.1``: ``envfit[cycles]``); maps as bench/render_check.py
takes them (paths, or the synthesized ``sun-gp-1.5`` / ``sun-gp-1.3``).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from render_check import _cpu, load_map  # noqa: E402  # the bench's own map loading and CPU line

from envfit.base._atomic import atomic_write_json  # noqa: E402  # internal: the atomic writer
from envfit.maps import EnvMap  # noqa: E402
from envfit.renderers import get_renderer  # noqa: E402
from envfit.renderers._sphere import sphere_error  # noqa: E402  # internal: the measurement


def weighted_spp(counts: np.ndarray, geometry) -> float:
    """The samples the sphere's kept pixels took, averaged with the measurement's weights
    (uniform over normals)."""
    keep, w = geometry.keep, geometry.weight
    return float(np.sum(counts[:, keep] * w[keep]) / (len(counts) * np.sum(w[keep])))


def _model(env: EnvMap, args):
    from envfit.predict.renderer import AdaptiveModel, AdaptiveOptions
    seen = EnvMap(env.data, up="y", name=env.name)        # as the Cycles world looks it up
    return AdaptiveModel(seen, get_renderer("cycles"), samples=args.samples, sampler=args.pattern,
                         sphere_pixels=None if args.no_footprint else args.resolution,
                         options=AdaptiveOptions(normals=args.normals,
                                                 realizations=args.realizations,
                                                 seed=args.seed), quiet=False)


def _predicted(row: dict, p) -> None:
    """The prediction's fields of a row (its measurement kept)."""
    spp = row["measured_spp"]
    row.update(predicted=p.predicted_rmse, ratio=p.predicted_rmse / row["measured_rmse"],
               inside=bool(0.8 * row["low"] <= p.predicted_rmse <= 1.25 * row["high"]),
               predicted_spp=p.mean_spp, spp_ratio=p.mean_spp / spp,
               spp_within_20=bool(abs(p.mean_spp / spp - 1) <= 0.2),
               predicted_spp_95=p.spp_percentiles[95], model_se=p.model_se)


def repredict_map(spec: str, args, rows: list) -> None:
    """The saved rows of one map predicted again by this code, without rendering."""
    name, env = load_map(spec, args.synth_height)
    mine = [r for r in rows if r["map"] == name and "measured_rmse" in r]
    if mine:
        model = _model(env, args)
        for r in mine:
            _predicted(r, model.predict(r["tau"]))


def run_map(spec: str, args, rows: list, meta: dict, out: Path) -> None:
    from envfit.renderers.cycles._render import CyclesOptions, CyclesSphere  # internal: the harness
    name, env = load_map(spec, args.synth_height)
    done = {(r["map"], r["threshold"]) for r in rows}
    todo = [t for t in args.thresholds if (name, t) not in done]
    want_target = args.target_relative and (name, f"target {args.target_relative}") not in done
    if not todo and not want_target:
        return
    t0 = time.perf_counter()
    model = _model(env, args)
    model.predict(args.thresholds[0])
    meta.setdefault("model_seconds", {})[name] = time.perf_counter() - t0
    rng = np.random.default_rng([args.seed, len(rows)])
    with CyclesSphere(env, CyclesOptions(resolution=args.resolution,
                                         reference_spp=args.reference_spp,
                                         cache_dir=args.cache)) as s:
        ref = s.reference()
        meta.setdefault("reference_seconds", {})[name] = ref.seconds
        mean_radiance = float(np.mean(0.5 * (ref.a + ref.b)[:, s.geometry.keep]))

        def cell(label, threshold):
            t = time.perf_counter()
            imgs, counts, secs = s.render_adaptive(args.pattern, threshold, args.samples,
                                                   int(rng.integers(1 << 31)))
            err = sphere_error(imgs, ref.a, ref.b, s.geometry, seed=rng)
            row = {"map": name, "threshold": label, "tau": threshold,
                   "measured_rmse": err.rmse, "low": err.low, "high": err.high,
                   "measured_spp": weighted_spp(counts, s.geometry),
                   "measured_max_spp": float(counts[:, s.geometry.keep].max()),
                   "render_seconds": float(time.perf_counter() - t),
                   "view_seconds": [float(x) for x in secs],
                   "mean_radiance": mean_radiance}
            _predicted(row, model.predict(threshold))
            rows.append(row)
            atomic_write_json(out / "cycles_adaptive.json", {"meta": meta, "rows": rows})
            return row

        for tau in todo:
            cell(tau, tau)
        if want_target:
            target = args.target_relative * mean_radiance
            tau, p = model.threshold_for(target)
            if tau is None:
                rows.append({"map": name, "threshold": f"target {args.target_relative}",
                             "advised": None, "target_rmse": target})
            else:
                row = cell(f"target {args.target_relative}", tau)
                row.update(advised=tau, target_rmse=target,
                           meets=bool(row["measured_rmse"] <= target),
                           meets_interval=bool(row["low"] <= target))
            atomic_write_json(out / "cycles_adaptive.json", {"meta": meta, "rows": rows})


def report(rows: list) -> None:
    print(f"{'map':12s} {'τ':>8s} {'measured [95%]':>30s} {'pred':>9s} {'ratio':>6s} in "
          f"{'spp meas':>9s} {'pred':>8s} {'ratio':>6s}")
    for r in rows:
        if "measured_rmse" not in r:
            print(f"{r['map']:12s} {r['threshold']}: no threshold meets {r['target_rmse']:.4g}")
            continue
        print(f"{r['map']:12s} {str(r['threshold']):>8s} {r['measured_rmse']:9.4g} "
              f"[{r['low']:9.4g}, {r['high']:9.4g}] {r['predicted']:9.4g} {r['ratio']:6.3f} "
              f"{'yn'[not r['inside']]}  {r['measured_spp']:9.1f} {r['predicted_spp']:8.1f} "
              f"{r['spp_ratio']:6.3f}"
              + (f"  advised τ {r['advised']:.3g} for {r['target_rmse']:.4g}: "
                 f"{'meets' if r['meets'] else 'MISSES'}" if "advised" in r else ""))
    cells = [r for r in rows if "inside" in r]
    if cells:
        print(f"inside: {sum(r['inside'] for r in cells)}/{len(cells)}; mean spp within 20 %: "
              f"{sum(r['spp_within_20'] for r in cells)}/{len(cells)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--thresholds", type=float, nargs="+", default=[0.1, 0.03, 0.01])
    ap.add_argument("--target-relative", type=float, default=None)
    ap.add_argument("--samples", type=int, default=4096)
    ap.add_argument("--pattern", default="tabulated_sobol")
    ap.add_argument("--resolution", type=int, default=32)
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--normals", type=int, default=128)
    ap.add_argument("--realizations", type=int, default=64)
    ap.add_argument("--synth-height", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=None, help="reference cache folder")
    ap.add_argument("--out", default="adaptive_check")
    ap.add_argument("--no-footprint", action="store_true",
                    help="predict every pixel as a point (default: its footprint on the "
                         "--resolution sphere)")
    ap.add_argument("--repredict", action="store_true",
                    help="predict the saved rows again with this code, without rendering")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "cycles_adaptive.json"
    doc = json.loads(path.read_text()) if path.exists() else {"meta": {}, "rows": []}
    meta, rows = doc["meta"], doc["rows"]
    meta.update(cpu=_cpu(), args=vars(args))
    for spec in args.maps:
        if args.repredict:
            repredict_map(spec, args, rows)
            atomic_write_json(path, {"meta": meta, "rows": rows})
        else:
            run_map(spec, args, rows, meta, out)
    report(rows)


if __name__ == "__main__":
    main()

"""Rendering check of envfit's renderer predictions (issue 24): measure a real renderer's noise
on a white diffuse sphere seen from six orthographic views (envfit.renderers) and set
it against envfit's prediction.

For each map (files given by path, and ``sun-gp-1.5`` / ``sun-gp-1.3``: the synthesized sun +
GP maps of bench/renderer_acceptance.py) × sampler × strategy × spp: the measured RMSE over
uniform normals with its bootstrap 95 % interval, the predicted RMSE (:func:`predict_cell`,
the ONE place where the prediction is chosen) and their ratio. Writes
``OUT/render_check_<renderer>.json`` and ``.csv`` after every cell and skips the cells
already there (resumable); prints a table, per (sampler, strategy) the median ratio and the
share of cells with the prediction inside [0.8 × low, 1.25 × high], and the CPU.

    python bench/render_check.py --renderer mitsuba3 /work/shared/envmaps/city.exr \\
        /work/shared/envmaps/forest.exr --samplers independent ldsampler \\
        --strategies map brdf mis --spp 16 64 256 --out /tmp/rc
    python bench/render_check.py --renderer cycles /work/shared/envmaps/city.exr \\
        --samplers tabulated_sobol --strategies mis brdf --out /tmp/rc

Mitsuba 3 strategies: map, brdf, mis, mis-comp (MIS with the envmap's mis_compensation);
samplers: independent, stratified, multijitter, ldsampler, orthogonal. Cycles: mis, brdf;
patterns tabulated_sobol, blue_noise. One renderer per run (bpy and Mitsuba are not loaded
in one process).

``--footprint 2`` predicts each pixel's footprint too (2 × 2 normals over each pixel of the
``--resolution`` sphere, ``RendererModelOptions.sphere_pixels``; 4× the model's work); the
default, 1, predicts point normals: on a white diffuse sphere the footprint moved city's Cycles
predictions by −0.6 % to +2 % (docs/validation.md). ``--repredict`` predicts the saved rows of
the maps again with this run's options, without rendering (the old prediction kept as
``predicted_before``).
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from envfit.base._atomic import atomic_write_csv, atomic_write_json  # internal: the atomic writers of the product's outputs
from envfit.base._progress import progress_bar  # internal: the product's progress bar
from envfit.maps import EnvMap, convention, load_envmap

#: the synthesized maps: (name, sun_gp_map keywords), as bench/renderer_acceptance.py
SYNTH = {
    "sun-gp-1.5": dict(seed=1, s0=1.5, sun_theta=0.6, sun_phi=1.0, sun_radius=0.02,
                       sun_radiance=(27000.0, 26000.0, 24000.0), channels=3, offset=4.0),
    "sun-gp-1.3": dict(seed=2, s0=1.3, sun_theta=1.2, sun_phi=4.0, sun_radius=0.05,
                       sun_radiance=(2000.0, 1800.0, 1500.0), channels=3, offset=6.0),
}
#: the renderer's sampler → envfit's generic point set (today's rules)
GENERIC_POINTSET = {"independent": "random", "stratified": "jitter", "multijitter": "jitter",
                    "orthogonal": "jitter", "ldsampler": "sobol", "tabulated_sobol": "sobol",
                    "blue_noise": "sobol", "automatic": "sobol"}
COLUMNS = ["renderer", "map", "sampler", "strategy", "spp", "spp_used", "measured_rmse", "low",
           "high", "predicted", "ratio", "inside", "generic", "reference_rmse", "mean_offset",
           "seconds",
           "seconds_per_view", "pixels"]


def _cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        return next(l.split(":", 1)[1].strip() for l in out.splitlines()
                    if l.startswith("Model name"))
    except Exception:  # noqa: BLE001 - informational only
        return "unknown"


def load_map(spec: str, synth_height: int) -> tuple[str, EnvMap]:
    """A map by path or by the name of a synthesized map of :data:`SYNTH`."""
    if spec in SYNTH:
        from envfit.data_gen import sun_gp_map
        kw = SYNTH[spec]
        arr, _ = sun_gp_map(synth_height, **kw)
        if arr.min() < 0:           # lift the GP background above 0 (as envfit synth does)
            arr = arr - arr.min() + 0.1 * kw["offset"]
        return spec, EnvMap(np.asarray(arr, np.float32), up="z", name=spec)
    env = load_envmap(spec)
    return Path(spec).stem, env


def map_as_seen(renderer: str, env: EnvMap) -> EnvMap:
    """The map as the renderer renders it, in envfit's convention: Mitsuba 3 reads the file in
    its own lat-long grid (rows on the poles; :func:`envfit.maps.convention` "mitsuba3"); the
    Cycles world of envfit.renderers looks it up in envfit's own convention. The
    pixels are written as they are, whatever ``env.up`` says (the mean over uniform normals
    does not depend on the map's orientation)."""
    plain = EnvMap(env.data, up="y", name=env.name)
    return convention("mitsuba3").to_internal(plain) if renderer == "mitsuba3" else plain


class Predictor:
    """envfit's predictions of one map as a renderer sees it (the models built once)."""

    def __init__(self, renderer: str, env: EnvMap, grid: int, axes: int,
                 max_level: int = 9, footprint: tuple | None = None, film=None):
        self.renderer, self.env, self.grid, self.axes = renderer, map_as_seen(renderer, env), \
            grid, axes
        self.max_level = max_level
        self.footprint = footprint       # (R pixels across, side) or None: point normals
        self.film = film                 # the renders' pixel filter (a FilmWarp; None: box)
        self._model = None
        self.file_env = env              # the pixels as the renderer reads the file
        self.cells: list = []            # (sampler, strategy, spp) planned: one model pass
        self._presets: dict = {}

    def preset_model(self, compensation: bool):
        """The renderer preset's noise model (envfit.predict.renderer.DiffuseModel) of the map,
        plain or with Mitsuba's mis_compensation, built once."""
        if compensation not in self._presets:
            from envfit.predict.renderer import DiffuseModel, RendererModelOptions
            from envfit.renderers import BOX_FILTER, get_renderer
            env = EnvMap(self.file_env.data, up="y", name=self.file_env.name)
            options = {"mis_compensation": compensation} if self.renderer == "mitsuba3" else {}
            self._presets[compensation] = DiffuseModel(
                env, get_renderer(self.renderer), options,
                RendererModelOptions(normals=PRESET_NORMALS, max_level=self.max_level,
                                   sphere_pixels=self.footprint and self.footprint[0],
                                   footprint_side=self.footprint[1] if self.footprint else 2,
                                   pixel_filter=self.film or BOX_FILTER))
        return self._presets[compensation]

    def model(self):
        if self._model is None:
            from envfit.measure import RendererSetup
            from envfit.predict.warped import renderer_model
            setup = RendererSetup.of(self.env, sources=[])
            self._model = renderer_model(setup, "diffuse", strategies=["brdf", "map", "mis"],
                                         grid=self.grid, axes=self.axes)
        return self._model


#: the preset model's normals and default finest grid level (bench/preset_check.py measures
#: them); --max-level 10 resolves the nets to 512 spp, 11 to 1024 (each level 4x the time)
PRESET_NORMALS, PRESET_MAX_LEVEL = 32, 9


def predict_cell(predictor: Predictor, sampler: str, strategy: str, spp: int) -> float:
    """The predicted RMSE of one cell — THE place the prediction is chosen.

    The renderer preset's own estimator and its sampler's exact randomisation
    (:class:`envfit.predict.renderer.DiffuseModel`; Mitsuba 3's ``mis-comp`` with the envmap's
    mis_compensation; Cycles' world importance map, power heuristic and Owen-scrambled
    patterns), all planned cells of the map in one pass over the normals. The generic rules
    of :func:`generic_cell` are the second column."""
    comp = strategy == "mis-comp"
    model = predictor.preset_model(comp)
    plan = [("mis" if st == "mis-comp" else st, s, n) for s, st, n in predictor.cells
            if (st == "mis-comp") == comp]
    model.predict_many(plan + [("mis" if comp else strategy, sampler, spp)])
    return float(model.predict("mis" if comp else strategy, sampler, spp).rmse)


def generic_cell(predictor: Predictor, sampler: str, strategy: str, spp: int) -> float:
    """envfit's generic prediction of one cell (the second column, ``generic``).

    envfit's generic rules (:func:`envfit.predict.predict_rule`): the
    renderer's sampler as envfit's point set of :data:`GENERIC_POINTSET` (random, jitter,
    sobol), envfit's map sampler (piecewise constant per pixel) and, for MIS, the balance
    heuristic at 2N (the renderer takes one emitter + one BSDF sample per spp; envfit's rule
    splits N into N/2 + N/2). ``mis-comp`` is predicted as ``mis``."""
    from envfit.predict import predict_rule
    from envfit.sampling import RendererRule
    pointset = GENERIC_POINTSET[sampler]
    strat = "mis" if strategy.startswith("mis") else strategy
    n = 2 * spp if strat == "mis" else spp
    return float(predict_rule(predictor.model(), RendererRule(strat, pointset, n)).rmse)


def _session(renderer: str, env: EnvMap, args):
    if renderer == "mitsuba3":
        from envfit.renderers import Mitsuba3Options, Mitsuba3Sphere
        opts = dict(resolution=args.resolution, reference_spp=args.reference_spp,
                    cache_dir=args.cache, reference_sampler=args.reference_sampler)
        plain = Mitsuba3Sphere(env, Mitsuba3Options(**opts))
        comp = Mitsuba3Sphere(env, Mitsuba3Options(**opts, mis_compensation=True))
        return {"plain": plain, "comp": comp}
    from envfit.renderers import CyclesOptions, CyclesSphere
    s = CyclesSphere(env, CyclesOptions(resolution=args.resolution,
                                        reference_spp=args.reference_spp, cache_dir=args.cache,
                                        threads=args.threads,
                                        pixel_filter=(args.pixel_filter[0].upper(),
                                                      args.pixel_filter[1])))
    return {"plain": s, "comp": s}


def _row(renderer, name, sampler, strategy, spp, m, pred) -> dict:
    ratio = pred / m.rmse if m.rmse > 0 else math.inf
    return {"renderer": renderer, "map": name, "sampler": sampler, "strategy": strategy,
            "spp": spp, "spp_used": m.spp_used, "measured_rmse": m.rmse, "low": m.low,
            "high": m.high, "predicted": pred, "ratio": ratio,
            "inside": bool(0.8 * m.low <= pred <= 1.25 * m.high),
            "reference_rmse": m.reference_rmse, "mean_offset": m.mean_offset,
            "seconds": m.seconds,
            "seconds_per_view": m.seconds / 6.0, "pixels": m.pixels}


def _write(out: Path, renderer: str, rows: list, meta: dict) -> None:
    atomic_write_json(out / f"render_check_{renderer}.json", {"meta": meta, "rows": rows})
    atomic_write_csv(out / f"render_check_{renderer}.csv", COLUMNS,
                     [[r.get(c, "") for c in COLUMNS] for r in rows])


def _cells(args):
    return [(s, st, n) for s in args.samplers for st in args.strategies for n in args.spp]


def run_map(spec: str, args, rows: list, meta: dict, out: Path) -> None:
    name, env = load_map(spec, args.synth_height)
    if args.repredict:
        return repredict_map(name, env, args, rows)
    done = {(r["map"], r["sampler"], r["strategy"], r["spp"]) for r in rows}
    todo = [c for c in _cells(args) if (name, *c) not in done]
    if not todo:
        return
    pred = _predictor(env, args)
    pred.cells = todo
    sessions = _session(args.renderer, env, args)
    bar = progress_bar(len(todo) + 1, desc=f"{args.renderer} {name}", unit="cell")
    try:
        t = time.perf_counter()
        ref = sessions["plain"].reference()
        meta.setdefault("reference_seconds", {})[name] = ref.seconds
        bar.update(1)
        rng = np.random.default_rng([args.seed, len(rows)])
        for sampler, strategy, spp in todo:
            s = sessions["comp" if strategy == "mis-comp" else "plain"]
            m = s.measure("mis" if strategy == "mis-comp" else strategy, sampler, spp,
                          seed=rng, reference=ref)
            p = predict_cell(pred, sampler, strategy, m.spp_used)
            rows.append(_row(args.renderer, name, sampler, strategy, spp, m, p))
            rows[-1]["generic"] = generic_cell(pred, sampler, strategy, m.spp_used)
            _write(out, args.renderer, rows, meta)
            bar.update(1)
        meta.setdefault("map_seconds", {})[name] = time.perf_counter() - t
        _write(out, args.renderer, rows, meta)
    finally:
        bar.close()
        for s in set(sessions.values()):
            s.close()


def _filter_arg(text: str) -> tuple:
    """``KIND:WIDTH`` → (kind, width)."""
    kind, _, width = text.partition(":")
    return kind.lower(), float(width or 1.0)


def film_warp_of(args):
    """The renders' ``--pixel-filter`` as the model's film warp (None: the box)."""
    if args.renderer != "cycles" or tuple(args.pixel_filter) == ("box", 1.0):
        return None
    from envfit.renderers.cycles._film import film_warp  # internal: Cycles' filter table
    return film_warp(*args.pixel_filter)


def _predictor(env: EnvMap, args) -> Predictor:
    foot = (args.resolution, args.footprint) if args.footprint > 1 else None
    return Predictor(args.renderer, env, args.grid, args.axes, args.max_level, foot,
                     film_warp_of(args))


def repredict_map(name: str, env: EnvMap, args, rows: list) -> None:
    """Predict the saved rows of map ``name`` again with this run's model options (no
    rendering) that this run's ``--samplers``, ``--strategies`` and ``--spp`` select: each
    row keeps its measurement, gains the new ``predicted``, ``ratio`` and ``inside``, and keeps
    the old prediction as ``predicted_before``."""
    mine = [r for r in rows if r["map"] == name and r["renderer"] == args.renderer
            and r["sampler"] in args.samplers and r["strategy"] in args.strategies
            and r["spp"] in args.spp]
    if not mine:
        return
    pred = _predictor(env, args)
    pred.cells = [(r["sampler"], r["strategy"], r["spp_used"]) for r in mine]
    for r in mine:
        p = predict_cell(pred, r["sampler"], r["strategy"], r["spp_used"])
        r.update(predicted_before=r.get("predicted_before", r["predicted"]), predicted=p,
                 ratio=p / r["measured_rmse"] if r["measured_rmse"] > 0 else math.inf,
                 inside=bool(0.8 * r["low"] <= p <= 1.25 * r["high"]),
                 footprint=args.footprint)


def _offset(row: dict) -> str:
    """The render's mean minus the reference's, relative (blank in rows of older runs); '!'
    marks a rare event missed (below −5 %: the measured RMSE is unreliable)."""
    if "mean_offset" not in row:
        return ""
    o = row["mean_offset"]
    return f"{100 * o:+6.1f}%" + (" !" if o < -0.05 else "")


def print_table(rows: list) -> None:
    print(f"{'map':12s} {'sampler':16s} {'strategy':9s} {'spp':>5s} {'measured':>10s} "
          f"{'95% interval':>22s} {'predicted':>10s} {'pred/meas':>9s} {'in':>3s} {'s/view':>7s} "
          f"{'offset':>7s}")
    for r in rows:
        print(f"{r['map']:12s} {r['sampler']:16s} {r['strategy']:9s} {r['spp']:5d} "
              f"{r['measured_rmse']:10.4g} [{r['low']:9.4g}, {r['high']:9.4g}] "
              f"{r['predicted']:10.4g} {r['ratio']:9.3f} {'y' if r['inside'] else 'n':>3s} "
              f"{r['seconds_per_view']:7.2f} {_offset(r)}")
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["sampler"], r["strategy"]), []).append(r)
    print("\nper (sampler, strategy): median predicted/measured, cells inside "
          "[0.8 low, 1.25 high]")
    for (s, st), rs in groups.items():
        med = float(np.median([r["ratio"] for r in rs]))
        print(f"  {s:16s} {st:9s} median {med:6.3f}   inside {sum(r['inside'] for r in rs)}"
              f"/{len(rs)}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", help="map files, or sun-gp-1.5 / sun-gp-1.3")
    ap.add_argument("--renderer", choices=("mitsuba3", "cycles"), default="mitsuba3")
    ap.add_argument("--samplers", nargs="+", default=None)
    ap.add_argument("--strategies", nargs="+", default=None)
    ap.add_argument("--spp", nargs="+", type=int, default=[16, 64, 256, 1024])
    ap.add_argument("--resolution", type=int, default=64, help="pixels per view side")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference-sampler", default="independent",
                    help="Mitsuba 3: the references' sampler (ldsampler: far less noise)")
    ap.add_argument("--grid", type=int, default=512, help="envfit's spectrum grid")
    ap.add_argument("--axes", type=int, default=64, help="envfit's spectrum axes")
    ap.add_argument("--max-level", type=int, default=PRESET_MAX_LEVEL,
                    help="the preset model's finest grid level (nets resolved to 2^(L-1) spp)")
    ap.add_argument("--synth-height", type=int, default=256)
    ap.add_argument("--threads", type=int, default=None, help="Cycles CPU threads")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=None, help="reference cache folder (default OUT/cache)")
    ap.add_argument("--footprint", type=int, default=1,
                    help="the model's pixel footprint: side x side normals over each pixel of "
                         "the --resolution sphere (default 1: each pixel at its centre, no "
                         "footprint term)")
    ap.add_argument("--pixel-filter", default="box:1", type=_filter_arg,
                    help="Cycles' pixel filter KIND:WIDTH (box, gaussian, blackman_harris; "
                         "Blender's default blackman_harris:1.5), rendered and predicted")
    ap.add_argument("--repredict", action="store_true",
                    help="predict the saved rows of the maps again (no rendering)")
    ap.add_argument("--out", default="render_check_out")
    args = ap.parse_args(argv)
    if args.samplers is None:
        args.samplers = (["independent", "stratified", "multijitter", "ldsampler"]
                         if args.renderer == "mitsuba3" else ["tabulated_sobol", "blue_noise"])
    if args.strategies is None:
        args.strategies = (["map", "brdf", "mis", "mis-comp"] if args.renderer == "mitsuba3"
                           else ["mis", "brdf"])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.cache = args.cache or str(out / "cache")
    path = out / f"render_check_{args.renderer}.json"
    rows, meta = [], {}
    if path.exists():
        import json
        saved = json.loads(path.read_text())
        rows, meta = saved["rows"], saved["meta"]
    meta.update(cpu=_cpu(), renderer=args.renderer, resolution=args.resolution,
                reference_spp=args.reference_spp, argv=sys.argv[1:],
                reference_sampler=args.reference_sampler if args.renderer == "mitsuba3"
                else "tabulated_sobol")
    from envfit.renderers import get_renderer
    rec = get_renderer(args.renderer)           # what each strategy renders with (mis: path)
    settings = {s: rec.strategy(s.split("-")[0]) for s in args.strategies}
    meta["integrators"] = {s: {"type": st.integrator, **st.settings}
                           for s, st in settings.items()}
    meta["renderer_version"] = rec.harness_module().version()      # e.g. Blender 5.3.0
    meta["pixel_filter"] = list(args.pixel_filter)
    t = time.perf_counter()
    for spec in args.maps:
        run_map(spec, args, rows, meta, out)
    if args.repredict:
        meta["repredicted_footprint"] = args.footprint
        _write(out, args.renderer, rows, meta)
    print_table(rows)
    print(f"\nCPU: {meta['cpu']}; wall {time.perf_counter() - t:.0f} s this run; "
          f"references: {meta.get('reference_seconds', {})}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

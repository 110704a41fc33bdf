"""Rendering check of envfit's microfacet predictions (issue 25): Mitsuba 3 renders the sphere
of :mod:`envfit.renderers` (six orthographic views) with a white ``roughconductor``
(GGX or Beckmann, Fresnel = 1), or Cycles (``--renderer cycles``) with a white Glossy BSDF
(:func:`envfit.renderers.glossy_bsdf`, GGX or Beckmann, roughness √α), and measures the RMSE over its kept pixels (the same weights
as the diffuse measurement) against a high-spp reference; envfit predicts the same quantity
with :class:`envfit.predict.renderer.MicrofacetModel` over frames drawn from those pixels
(:func:`envfit.predict.renderer.pixel_frames`: each pixel's normal and its view axis; a pool
of every kept pixel (or ``--pool`` of them), ``--frames`` of them importance-sampled by the
two techniques' variances so that the pixels whose lobe catches a sun are not missed).
Per view-angle band (θ_o in 0–30°, 30–60°, 60–80°) and for the whole set: with ``--layout
disk`` (default) every pixel of each view's disk, weight 1 (the views an orthographic camera
has of a sphere, six directions of the map); ``cube`` keeps each normal in its nearest view
(θ_o ≤ 55°).

Writes ``OUT/microfacet_check.json`` / ``.csv`` after every cell (resumable); prints the table,
the share of cells inside [0.8 × low, 1.25 × high] and the CPU.

    python bench/microfacet_check.py /work/shared/envmaps/city.exr --alphas 0.1 0.3 \\
        --distributions ggx beckmann --samplers independent ldsampler --spp 16 64 256 --out /tmp/mf
    python bench/microfacet_check.py /work/shared/envmaps/forest.exr --renderer cycles \\
        --distributions ggx --alphas 0.3 --spp 16 64 256 --out /tmp/mf_cycles
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from envfit.base._atomic import atomic_write_csv, atomic_write_json  # internal: the atomic writers of the product's outputs
from envfit.maps import EnvMap
from envfit.renderers import (VIEWS, CyclesOptions, CyclesSphere, Mitsuba3Options,
                                      Mitsuba3Sphere, glossy_bsdf, roughconductor_bsdf,
                                      sphere_geometry)
from envfit.predict.renderer import (MicrofacetModel, RendererModelOptions, pixel_footprints,
                                     pixel_frames)
from envfit.renderers import get_renderer
from envfit.validate import measure_cell

sys.path.insert(0, str(Path(__file__).parent))
from render_check import _cpu, _filter_arg, film_warp_of, load_map  # noqa: E402  (bench helpers)

COLUMNS = ["map", "distribution", "alpha", "sampler", "strategy", "spp", "spp_used",
           "measured_rmse", "low", "high", "predicted", "ratio", "inside", "mean_offset",
           "seconds"]


def _model(env, dist, alpha, args):
    g = sphere_geometry(args.resolution, args.layout)
    n, v, _ = pixel_frames(g, VIEWS, args.pool or len(VIEWS) * g.kept,
                           seed=args.seed)
    film = _film(args)
    foot = (pixel_footprints(n, v, args.resolution, args.footprint, film)
            if args.footprint > 1 else None)
    renderer = get_renderer(args.renderer)
    return MicrofacetModel(EnvMap(env.data, up="y", name=env.name), renderer,
                           renderer.bsdf(dist, alpha), (n, v),
                           options=RendererModelOptions(max_level=args.max_level,
                                                        pixel_filter=film),
                           select=args.frames, footprints=foot)


def _film(args):
    """The renders' pixel filter as the model's film warp (the box where none is asked)."""
    from envfit.renderers import BOX_FILTER
    return film_warp_of(args) or BOX_FILTER


def _session(args, dist: str, alpha: float):
    """The renderer's sphere for one BSDF: Mitsuba 3's ``roughconductor`` (references by
    ``ldsampler``) or Cycles' Glossy BSDF (references by Tabulated Sobol, MIS)."""
    if args.renderer == "cycles":
        opts = CyclesOptions(resolution=args.resolution, reference_spp=args.reference_spp,
                             cache_dir=args.cache, bsdf=glossy_bsdf(dist, alpha),
                             pixel_filter=(args.pixel_filter[0].upper(), args.pixel_filter[1]))
        return lambda env: CyclesSphere(env, opts)
    opts = Mitsuba3Options(resolution=args.resolution, reference_spp=args.reference_spp,
                           cache_dir=args.cache, reference_sampler="ldsampler",
                           bsdf=roughconductor_bsdf(dist, alpha))
    return lambda env: Mitsuba3Sphere(env, opts)


def repredict(args, rows: list) -> None:
    """Predict the saved rows of the maps, distributions and alphas asked again with this run's
    model options (no rendering); each row keeps its measurement and its old prediction as
    ``predicted_before``."""
    for spec in args.maps:
        name, env = load_map(spec, args.synth_height)
        for dist in args.distributions:
            for alpha in args.alphas:
                mine = [r for r in rows if (r["map"], r["distribution"], r["alpha"]) ==
                        (name, dist, alpha) and r.get("renderer", "mitsuba3") == args.renderer]
                if not mine:
                    continue
                model = _model(env, dist, alpha, args)
                model.predict_many([(r["strategy"], r["sampler"], r["spp_used"]) for r in mine])
                for r in mine:
                    p = float(model.predict(r["strategy"], r["sampler"], r["spp_used"]).rmse)
                    r.update(predicted_before=r.get("predicted_before", r["predicted"]),
                             predicted=p, ratio=p / r["measured_rmse"],
                             inside=bool(0.8 * r["low"] <= p <= 1.25 * r["high"]))
                    bands = model.predict_bands(r["strategy"], r["sampler"], r["spp_used"])
                    for b, v in r["bands"].items():
                        v.update(predicted=bands[b],
                                 inside=bool(0.8 * v["low"] <= bands[b] <= 1.25 * v["high"]))


def run(args, rows: list, meta: dict, out: Path) -> None:
    if args.repredict:
        repredict(args, rows)
        _write(out, rows, meta)
        return
    for spec in args.maps:
        name, env = load_map(spec, args.synth_height)
        for dist in args.distributions:
            for alpha in args.alphas:
                cells = [(s, st, n) for s in args.samplers for st in args.strategies
                         for n in args.spp
                         if not any((r["map"], r["distribution"], r["alpha"], r["sampler"],
                                     r["strategy"], r["spp"]) == (name, dist, alpha, s, st, n)
                                    for r in rows)]
                if not cells:
                    continue
                session = _session(args, dist, alpha)
                model = _model(env, dist, alpha, args)
                t = time.perf_counter()
                model.predict_many([(st, s, n) for s, st, n in cells])
                meta.setdefault("model_seconds", {})[f"{name}/{dist}/{alpha}"] = \
                    time.perf_counter() - t
                rng = np.random.default_rng([args.seed, len(rows)])
                geometry = sphere_geometry(args.resolution, args.layout)
                with session(env) as sph:
                    ref = sph.reference()
                    for s, st, n in cells:
                        rows.append(_cell(sph, ref, model, (name, dist, alpha, s, st, n), rng,
                                          geometry))
                        rows[-1]["renderer"] = args.renderer
                        _write(out, rows, meta)
                        print(_line(rows[-1]), flush=True)


def _cell(sph, ref, model, cell, rng, g) -> dict:
    """One rendered cell: the whole set of kept pixels of geometry ``g`` and each view-angle
    band (:func:`envfit.validate._rendered.measure_cell`, the product's step)."""
    name, dist, alpha, s, st, n = cell
    return {"map": name, "distribution": dist, "alpha": alpha,
            **measure_cell(sph, ref, model, (s, st, n), rng, g)}


def _write(out: Path, rows: list, meta: dict) -> None:
    atomic_write_json(out / "microfacet_check.json", {"meta": meta, "rows": rows})
    atomic_write_csv(out / "microfacet_check.csv", COLUMNS,
                     [[r.get(c, "") for c in COLUMNS] for r in rows])


def print_summary(rows: list) -> None:
    """Cells inside [0.8 low, 1.25 high] and the median ratio: whole set, per band, per map."""
    inside = sum(r["inside"] for r in rows)
    print(f"\nwhole set: inside {inside}/{len(rows)}; median predicted/measured "
          f"{np.median([r['ratio'] for r in rows]):.3f}")
    bands = sorted({b for r in rows for b in r.get("bands", {})})
    for b in bands:
        cells = [r["bands"][b] for r in rows if b in r.get("bands", {})]
        ratios = [c["predicted"] / c["measured_rmse"] for c in cells if c["measured_rmse"] > 0]
        zero = len(cells) - len(ratios)    # the reference's noise corrected away: measured 0
        print(f"band {b} deg: inside {sum(c['inside'] for c in cells)}/{len(cells)}; median "
              f"predicted/measured {np.median(ratios) if ratios else float('nan'):.3f}"
              + (f" ({zero} cell(s) measured 0)" if zero else ""))
    for name in sorted({r["map"] for r in rows}):
        rs = [r for r in rows if r["map"] == name]
        print(f"map {name}: inside {sum(r['inside'] for r in rs)}/{len(rs)}")


def _line(r: dict) -> str:
    return (f"{r['map']:8s} {r['distribution']:8s} {r['alpha']:5.2f} {r['sampler']:12s} "
            f"{r['strategy']:5s} {r['spp_used']:5d} {r['measured_rmse']:10.4g} "
            f"[{r['low']:9.4g}, {r['high']:9.4g}] {r['predicted']:10.4g} {r['ratio']:6.3f} "
            f"{'y' if r['inside'] else 'n'}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", help="map files, or sun-gp-1.5 / sun-gp-1.3")
    ap.add_argument("--renderer", choices=("mitsuba3", "cycles"), default="mitsuba3")
    ap.add_argument("--distributions", nargs="+", default=["ggx", "beckmann"],
                    help="ggx, beckmann; multiggx: Cycles' Multiscatter GGX (its nodes' default)")
    ap.add_argument("--alphas", nargs="+", type=float, default=[0.1, 0.3, 0.6])
    ap.add_argument("--samplers", nargs="+", default=None,
                    help="default: independent ldsampler (Mitsuba 3), tabulated_sobol "
                         "blue_noise (Cycles)")
    ap.add_argument("--strategies", nargs="+", default=None,
                    help="default: map brdf mis (Mitsuba 3), brdf mis (Cycles: emitter "
                         "sampling alone is a debug-build mode)")
    ap.add_argument("--spp", nargs="+", type=int, default=[16, 64, 256])
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--layout", choices=("disk", "cube"), default="disk",
                    help="pixels measured: disk (every pixel of each view: theta_o 0-90 deg, "
                         "an orthographic camera's view of a sphere) or cube (each normal in "
                         "its nearest view: theta_o <= 55 deg, uniform normals)")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--frames", type=int, default=256, help="frames of the model")
    ap.add_argument("--pool", type=int, default=0,
                    help="pixels the frames are importance-sampled from (default 0: every "
                         "kept pixel; 2048 missed the few pixels whose sharp lobe meets a "
                         "sun: sun-gp-1.5 GGX 0.05 went from 16/18 to 18/18 inside)")
    ap.add_argument("--max-level", type=int, default=9)
    ap.add_argument("--footprint", type=int, default=2,
                    help="the model's pixel footprint: side x side normals over each pixel "
                         "(1: each pixel at its centre, no footprint term)")
    ap.add_argument("--synth-height", type=int, default=256)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=None)
    ap.add_argument("--pixel-filter", default="box:1", type=_filter_arg,
                    help="Cycles' pixel filter KIND:WIDTH (box, gaussian, blackman_harris; "
                         "Blender's default blackman_harris:1.5), rendered and predicted")
    ap.add_argument("--repredict", action="store_true",
                    help="predict the saved rows again with this run's options (no rendering)")
    ap.add_argument("--out", default="microfacet_check_out")
    args = ap.parse_args(argv)
    cycles = args.renderer == "cycles"
    if args.samplers is None:
        args.samplers = ["tabulated_sobol", "blue_noise"] if cycles else ["independent",
                                                                          "ldsampler"]
    if args.strategies is None:
        args.strategies = ["brdf", "mis"] if cycles else ["map", "brdf", "mis"]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.cache = args.cache or str(out / "cache")
    rows, meta = [], {}
    if (out / "microfacet_check.json").exists():
        saved = json.loads((out / "microfacet_check.json").read_text())
        rows, meta = saved["rows"], saved["meta"]
    meta.update(cpu=_cpu(), argv=sys.argv[1:], resolution=args.resolution, layout=args.layout,
                reference_spp=args.reference_spp, frames=args.frames, footprint=args.footprint,
                pixel_filter=list(args.pixel_filter))
    t = time.perf_counter()
    run(args, rows, meta, out)
    print_summary(rows)
    print(f"CPU {meta['cpu']}; wall {time.perf_counter() - t:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

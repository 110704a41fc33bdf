"""The frame model (``envfit frame``, issue 42) against Mitsuba 3 renders of whole frames.

Six scenes built here (different cameras, spheres, boxes, a torus mesh that shadows itself,
a ground plane, a checkerboard texture, rough conductors, principled materials, the box
and Gaussian filters, ``direct`` and ``path`` at depth 2,
rotated maps) under each map given (``sun-gp`` synthesizes a sun map), rendered
K times per spp with the ``independent`` sampler. Per cell (scene, map, spp):

* the image RMSE: predicted against the renders' (each pixel's MSE is its variance over the
  K renders, the estimator being unbiased), inside [0.8 × low, 1.25 × high] of its 95 %
  interval (χ² with Satterthwaite's degrees of freedom over the pixels);

per (scene, map), with the pixels' measured MSE × spp pooled over the spp (the
``independent`` sampler's MSE is exactly MSE₁/N):

* Spearman's rank correlation of predicted and measured pixel RMSE (≥ 0.8);
* ten bins by predicted value: each bin's measured RMS over its predicted RMS (within 25 %);
* the prediction's time against one reference render at ``--reference-spp``;

and with ``--target-relative R``, the spp the model advises for that image RMSE, rendered
``--renders`` times at it and at the sampler's next smaller count (half; ``ldsampler``: a
quarter): the measured image RMSE over the target (≤ 1 within the model's error at the
advised spp, above 1 below it).

``--sampler ldsampler`` renders every scene with Mitsuba's ``ldsampler`` and the box filter
(the one its frame model reads); its error is not MSE₁/N, so the pixels' Spearman is the
smallest over the spp and the ten bins take every (pixel, spp) pair.

Usage::

    python bench/frame_check.py ../shared/envmaps/forest.exr ../shared/envmaps/city.exr sun-gp \
        --spp 16 64 256 --renders 16 --out frame_check
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

from envfit.frame import predict_frame
from envfit.maps import save_envmap, synthesize_envmap

CAMERA = {
    "persp": '<sensor type="perspective"><float name="fov" value="{fov}"/>'
             '<transform name="to_world"><lookat origin="{origin}" target="{target}" '
             'up="0, 1, 0"/></transform>{film}</sensor>',
    "ortho": '<sensor type="orthographic"><transform name="to_world">'
             '<lookat origin="{origin}" target="{target}" up="0, 1, 0"/>'
             '<scale x="{scale}" y="{scale}"/></transform>{film}</sensor>',
}
FILM = ('<sampler type="{sampler}"><integer name="sample_count" value="4"/></sampler>'
        '<film type="hdrfilm"><integer name="width" value="{w}"/>'
        '<integer name="height" value="{h}"/><rfilter type="{rfilter}"/></film>')
GROUND = ('<shape type="rectangle"><transform name="to_world"><scale value="6"/>'
          '<rotate x="1" angle="-90"/></transform>{bsdf}</shape>')


def _diffuse(rgb) -> str:
    return f'<bsdf type="diffuse"><rgb name="reflectance" value="{rgb}"/></bsdf>'


def _conductor(dist: str, alpha: float, extra: str = "") -> str:
    return (f'<bsdf type="roughconductor"><string name="distribution" value="{dist}"/>'
            f'<float name="alpha" value="{alpha}"/>{extra}</bsdf>')


GOLD = '<string name="material" value="Au"/>'
CHECKER = ('<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
           '<rgb name="color0" value="0.15"/><rgb name="color1" value="0.7"/>'
           '<transform name="to_uv"><scale x="6" y="6"/></transform></texture></bsdf>')


def _principled(**params) -> str:
    return ('<bsdf type="principled">' + "".join(
        f'<rgb name="{k}" value="{v}"/>' if k == "base_color" else
        f'<float name="{k}" value="{v}"/>' for k, v in params.items()) + "</bsdf>")


def _torus(path: Path, major=0.6, minor=0.25, n=48, m=24) -> Path:
    """A torus as an OBJ (non-convex: it shadows itself)."""
    u, v = np.meshgrid(np.arange(n) * 2 * np.pi / n, np.arange(m) * 2 * np.pi / m,
                       indexing="ij")
    x = (major + minor * np.cos(v)) * np.cos(u)
    z = (major + minor * np.cos(v)) * np.sin(u)
    y = minor * np.sin(v)
    lines = [f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in
             zip(x.ravel(), y.ravel(), z.ravel())]
    for i in range(n):
        for j in range(m):
            a, b = i * m + j, ((i + 1) % n) * m + j
            c, d = ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
            lines += [f"f {a + 1} {d + 1} {c + 1}", f"f {a + 1} {c + 1} {b + 1}"]
    path.write_text("\n".join(lines) + "\n")
    return path


def scenes(folder: Path, size=(64, 48), sampler: str = "independent") -> dict:
    """name → (integrator, camera, shapes, map to_world) of the scenes (a sampler other than
    ``independent``: every film with the box filter, the one its frame model reads)."""
    w, h = size
    torus = _torus(folder / "torus.obj")
    net = sampler != "independent"
    film = {"box": FILM.format(w=w, h=h, rfilter="box", sampler=sampler),
            "gaussian": FILM.format(w=w, h=h, rfilter="box" if net else "gaussian",
                                    sampler=sampler)}
    return {
        "spheres_box": ('<integrator type="direct"/>',
                        CAMERA["persp"].format(fov=40, origin="0, 1.5, 5", target="0, 0.4, 0",
                                               film=film["box"]),
                        f'<shape type="sphere"><point name="center" x="0" y="0.5" z="0"/>'
                        f'<float name="radius" value="0.5"/>{_diffuse("0.8, 0.5, 0.3")}</shape>'
                        f'<shape type="cube"><transform name="to_world"><scale value="0.3"/>'
                        f'<translate x="1" y="0.3" z="0.3"/></transform>'
                        f'{_diffuse("0.6")}</shape>' + GROUND.format(bsdf=_diffuse("0.5")),
                        ""),
        "checker_gauss": ('<integrator type="path"><integer name="max_depth" value="2"/>'
                          '</integrator>',
                          CAMERA["persp"].format(fov=50, origin="2.5, 3, 3.5",
                                                 target="0, 0.3, 0", film=film["gaussian"]),
                          f'<shape type="sphere"><point name="center" x="-0.5" y="0.4" z="0"/>'
                          f'<float name="radius" value="0.4"/>{_diffuse("0.2, 0.6, 0.3")}'
                          f'</shape><shape type="sphere"><point name="center" x="0.6" y="0.25"'
                          f' z="0.4"/><float name="radius" value="0.25"/>{_diffuse("0.9")}'
                          f'</shape>' + GROUND.format(bsdf=CHECKER),
                          '<transform name="to_world"><rotate y="1" angle="70"/></transform>'),
        "torus_ortho": ('<integrator type="direct"/>',
                        CAMERA["ortho"].format(origin="0, 2.5, 3", target="0, 0.2, 0",
                                               scale=1.3, film=film["box"]),
                        f'<shape type="obj"><string name="filename" value="{torus}"/>'
                        f'<transform name="to_world"><rotate x="1" angle="30"/>'
                        f'<translate y="0.45"/></transform>{_diffuse("0.7, 0.7, 0.4")}</shape>'
                        + GROUND.format(bsdf=_diffuse("0.4")), ""),
        "wall_wide": ('<integrator type="direct"/>',
                      CAMERA["persp"].format(fov=65, origin="0, 1, 4", target="0, 0.8, 0",
                                             film=film["gaussian"]),
                      '<shape type="rectangle"><transform name="to_world">'
                      '<scale x="3" y="1.5"/><translate y="1.5" z="-1.5"/></transform>'
                      f'{_diffuse("0.7, 0.6, 0.5")}</shape>'
                      '<shape type="cube"><transform name="to_world"><scale x="0.2" y="0.9" '
                      'z="0.2"/><translate x="-0.6" y="0.9"/></transform>'
                      f'{_diffuse("0.3, 0.3, 0.8")}</shape>'
                      '<shape type="sphere"><point name="center" x="0.7" y="0.35" z="0.5"/>'
                      f'<float name="radius" value="0.35"/>{_diffuse("0.8")}</shape>'
                      + GROUND.format(bsdf=_diffuse("0.5")),
                      '<transform name="to_world"><rotate y="1" angle="-40"/></transform>'),
        "gloss": ('<integrator type="direct"/>',
                  CAMERA["persp"].format(fov=45, origin="0, 1.4, 4.5", target="0, 0.45, 0",
                                         film=film["box"]),
                  f'<shape type="sphere"><point name="center" x="-0.65" y="0.5" z="0"/>'
                  f'<float name="radius" value="0.5"/>{_conductor("ggx", 0.1)}</shape>'
                  f'<shape type="sphere"><point name="center" x="0.6" y="0.45" z="0.2"/>'
                  f'<float name="radius" value="0.45"/>'
                  f'{_conductor("beckmann", 0.3, GOLD)}</shape>'
                  f'<shape type="cube"><transform name="to_world"><scale value="0.25"/>'
                  f'<rotate y="1" angle="30"/><translate x="0.1" y="0.25" z="1"/></transform>'
                  f'{_conductor("ggx", 0.4)}</shape>'
                  + GROUND.format(bsdf=_diffuse("0.5")), ""),
        "principled": ('<integrator type="path"><integer name="max_depth" value="2"/>'
                       '</integrator>',
                       CAMERA["persp"].format(fov=45, origin="0.5, 1.5, 4.5",
                                              target="0, 0.45, 0", film=film["box"]),
                       f'<shape type="sphere"><point name="center" x="-0.65" y="0.5" z="0"/>'
                       f'<float name="radius" value="0.5"/>{_principled()}</shape>'
                       f'<shape type="sphere"><point name="center" x="0.6" y="0.45" z="0.2"/>'
                       f'<float name="radius" value="0.45"/>'
                       f'{_principled(base_color=0.8, roughness=0.3, metallic=0.6, sheen=0.5)}'
                       f'</shape>'
                       f'<shape type="cube"><transform name="to_world"><scale value="0.25"/>'
                       f'<rotate y="1" angle="30"/><translate x="0.1" y="0.25" z="1"/>'
                       f'</transform>{_principled(roughness=0.25, specular=0.8)}</shape>'
                       + GROUND.format(bsdf=_principled(base_color=0.5, roughness=0.7)),
                       '<transform name="to_world"><rotate y="1" angle="120"/></transform>'),
    }


def write_scene(path: Path, parts, envmap: Path) -> Path:
    integ, cam, shapes, rot = parts
    path.write_text(f'<scene version="3.0.0">{integ}{cam}<emitter type="envmap">'
                    f'<string name="filename" value="{envmap}"/>{rot}</emitter>{shapes}'
                    f'</scene>\n')
    return path


def _mitsuba():
    """Mitsuba (``scalar_rgb``) through the renderer's harness."""
    from envfit.renderers import get_renderer
    return get_renderer("mitsuba3").harness_module().import_mitsuba()


def _interval(meas: np.ndarray, k: int) -> tuple[float, float]:
    from scipy.stats import chi2
    m = float(meas.mean())
    dof = k * meas.sum() ** 2 / max((meas ** 2).sum(), 1e-300)
    return m * dof / chi2.ppf(0.975, dof), m * dof / chi2.ppf(0.025, dof)


def _measured(mi, sc, n: int, renders: int, seed: int) -> tuple[float, float, float]:
    """The image RMSE over ``renders`` renders at ``n`` spp and its 95 % interval."""
    imgs = np.stack([np.array(mi.render(sc, seed=seed + s, spp=n))[..., :3]
                     for s in range(renders)])
    meas = imgs.var(axis=0, ddof=1).mean(axis=2)
    lo, hi = _interval(meas, renders - 1)
    return math.sqrt(meas.mean()), math.sqrt(lo), math.sqrt(hi)


def lower_spp(p) -> int:
    """The spp a target check renders below the answer: the sampler's next smaller one where
    it runs only some (``ldsampler``: a quarter), else half (a sampler that runs any spp:
    the next one, answer − 1, is not told apart by any number of renders)."""
    return max(1, p.answer // 2) if p.below is None or p.below == p.answer - 1 else p.below


def target_line(sname: str, mname: str, t: dict) -> str:
    """One target check's line (:func:`target_check`)."""
    if t["answer"] is None:
        return f"{sname:14s} {mname:8s} target {t['target']:.4g}: no answer up to {t['below']} spp"
    a, h = t["at_answer"], t["at_half"]
    return (f"{sname:14s} {mname:8s} target {t['target']:.4g}: {t['answer']} spp measures "
            f"{a['over_target']:.3f} x the target [{a['low'] / t['target']:.3f}, "
            f"{a['high'] / t['target']:.3f}], {h['spp']} spp {h['over_target']:.3f} x "
            f"[{h['low'] / t['target']:.3f}, {h['high'] / t['target']:.3f}]")


def target_check(mi, path: Path, relative: float, renders: int, level: int) -> dict:
    """The advised spp for ``relative`` × the image's mean, rendered at it and at half."""
    p = predict_frame(path, target_relative=relative, level=level)
    sc = mi.load_file(str(path))
    out = {"target": p.target, "answer": p.answer, "below": p.below}
    if p.answer is None:                          # none up to what the model resolves
        return out
    for key, n in (("at_answer", p.answer), ("at_half", lower_spp(p))):
        m, lo, hi = _measured(mi, sc, n, renders, 77 * n)
        out[key] = {"spp": n, "measured": m, "low": lo, "high": hi, "over_target": m / p.target}
    return out


def check(path: Path, spps, renders: int, reference_spp: int, level: int,
          timed: dict) -> dict:
    from scipy.stats import spearmanr

    mi = _mitsuba()
    mi.set_log_level(mi.LogLevel.Error)      # a map's negative texels warn per sample
    t = time.perf_counter()
    p = predict_frame(path, spp=tuple(spps), level=level)
    t_pred = time.perf_counter() - t
    sc = mi.load_file(str(path))
    cells, pooled, pairs, rho = [], [], [], []
    for n, row in zip(spps, p.rows):
        imgs = np.stack([np.array(mi.render(sc, seed=1000 * n + s, spp=n))[..., :3]
                         for s in range(renders)])
        meas = imgs.var(axis=0, ddof=1).mean(axis=2)
        lo, hi = _interval(meas, renders - 1)
        pred = row.rmse ** 2
        cells.append({"spp": n, "predicted": row.rmse, "measured": math.sqrt(meas.mean()),
                      "low": math.sqrt(lo), "high": math.sqrt(hi),
                      "ratio": row.rmse / math.sqrt(meas.mean()),
                      "inside": bool(0.64 * lo <= pred <= 1.5625 * hi)})
        pooled.append(meas * n)
        if p.mse_by_spp:                       # a net sampler: not MSE1/N, per spp
            pm = p.pixel_rmse(n).ravel() ** 2
            pairs.append((pm, meas.ravel()))
            rho.append(float(spearmanr(pm, meas.ravel())[0]))
    if p.mse_by_spp:
        pred1, meas1 = (np.concatenate(x) for x in zip(*pairs))
        spear = min(rho)
    else:
        meas1 = np.mean(pooled, axis=0).ravel()
        pred1 = p.mse1.mean(axis=2).ravel()
        spear = float(spearmanr(pred1, meas1)[0])
    order = np.argsort(pred1)
    bins = [float(np.sqrt(meas1[b].mean() / max(pred1[b].mean(), 1e-300)))
            for b in np.array_split(order, 10)]
    key = path.stem.rsplit("_", 1)[0]                   # one reference time per scene
    if key not in timed:
        t = time.perf_counter()
        mi.render(sc, seed=7, spp=reference_spp)
        timed[key] = time.perf_counter() - t
    t_ref = timed[key]
    return {"cells": cells, "spearman": spear,
            "bins_measured_over_predicted": bins,
            "bins_inside": int(sum(0.8 <= b <= 1.25 for b in bins)),
            "edges": next((x for x in p.notes if "silhouette" in x), ""),
            "seconds_predict": t_pred, "seconds_reference": t_ref,
            "reference_spp": reference_spp, "cost_ratio": t_pred / t_ref}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", help="map files, or sun-gp (synthesized, 512 high)")
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 64, 256])
    ap.add_argument("--renders", type=int, default=16)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--level", type=int, default=4)
    ap.add_argument("--scenes", nargs="*", default=None)
    ap.add_argument("--size", type=int, nargs=2, default=[64, 48], metavar=("W", "H"))
    ap.add_argument("--target-relative", type=float, default=None,
                    help="also render the advised spp for this relative image RMSE and half")
    ap.add_argument("--sampler", default="independent",
                    help="the scenes' sampler (ldsampler: every scene with the box filter)")
    ap.add_argument("--out", type=Path, default=Path("frame_check"))
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    maps = []
    for m in a.maps:
        if m == "sun-gp":
            env = synthesize_envmap("sun-gp", height=512, seed=2)
            maps.append(("sun-gp", save_envmap(a.out / "sun-gp.exr", env.envmap)))
        else:
            maps.append((Path(m).stem, Path(m).resolve()))
    sc = scenes(a.out, tuple(a.size), a.sampler)
    rows, timed = [], {}
    for sname, parts in sc.items():
        if a.scenes and sname not in a.scenes:
            continue
        for mname, mpath in maps:
            tag = "" if a.sampler == "independent" else f"_{a.sampler}"
            path = write_scene(a.out / f"{sname}{tag}_{mname}.xml", parts, mpath)
            r = check(path, a.spp, a.renders, a.reference_spp, a.level, timed)
            r.update(scene=sname, map=mname)
            if a.target_relative:
                t = target_check(_mitsuba(), path, a.target_relative, a.renders, a.level)
                r["target_check"] = t
                print(target_line(sname, mname, t), flush=True)
            rows.append(r)
            print(row_line(r, a.reference_spp), flush=True)
    return finish(rows, a, a.out / "frame_check.json")


def row_line(r: dict, reference_spp: int) -> str:
    """One (scene, map)'s line: the cells' ratios, Spearman, the bins and the times."""
    cells = ", ".join(f"{c['spp']}: {c['ratio']:.3f}{'' if c['inside'] else ' OUT'}"
                      for c in r["cells"])
    return (f"{r['scene']:14s} {r['map']:8s} pred/meas {cells}; Spearman {r['spearman']:.3f}; "
            f"bins {r['bins_inside']}/10 inside "
            f"[{min(r['bins_measured_over_predicted']):.2f}, "
            f"{max(r['bins_measured_over_predicted']):.2f}]; predict "
            f"{r['seconds_predict']:.1f} s, reference {reference_spp} spp "
            f"{r['seconds_reference']:.1f} s ({r['cost_ratio']:.2f})")


def finish(rows: list, args, path: Path) -> int:
    """Print the totals of ``rows`` and write them with the CPU and ``args`` to ``path``."""
    from render_check import _cpu                       # the CPU's name, as render_check
    inside = sum(c["inside"] for r in rows for c in r["cells"])
    total = sum(len(r["cells"]) for r in rows)
    print(f"{inside} of {total} cells inside; Spearman >= 0.8 in "
          f"{sum(r['spearman'] >= 0.8 for r in rows)} of {len(rows)}; all bins inside in "
          f"{sum(r['bins_inside'] == 10 for r in rows)} of {len(rows)}")
    meta = {"cpu": _cpu(), "machine": platform.machine(),
            "args": vars(args) | {"out": str(args.out)}}
    path.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

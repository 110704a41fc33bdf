"""The frame model (``envfit frame``, issue 42) against Blender Cycles renders of whole frames.

Scenes built here with bpy (a perspective camera, a smooth UV sphere, a cube, a ground plane,
a torus mesh that shadows itself; diffuse materials of several colours, Glossy and
Principled metal spheres (``gloss``), Blender's default Principled BSDF (``principled``:
metallic 0, two closures) under each map given
(``sun-gp`` synthesizes a sun map), saved as ``.blend`` files and read back by
``envfit frame`` (``envfit.renderers.cycles._frame_scene``). Every scene keeps Cycles'
defaults where they are what a user keeps: the pattern *Automatic* (blue noise for a final
render) or ``--pattern``, the Blackman–Harris 1.5 px filter (importance-sampled), the light
tree; it sets what the frame model's scope needs: direct lighting (Max Bounces 0: the kernel's
1, the BSDF ray's next hit ends the path — ``_frame_scene``'s docstring), adaptive sampling
off, no denoising.

Each spp is rendered ``--renders`` times with different seeds; each pixel's MSE is measured
against the mean of two references at ``--reference-spp`` (their own noise, from their
difference, subtracted). Per cell (scene, map, spp): the predicted image RMSE inside
[0.8 × low, 1.25 × high] of the measured one's 95 % interval (χ² over the pixels with
Satterthwaite's degrees of freedom, as ``frame_check.py``). Per (scene, map): Spearman's rank
correlation of predicted and measured pixel RMSE (the smallest over the spp), and ten bins by
predicted value over every (pixel, spp) pair, each bin's measured RMS over its predicted RMS;
the prediction's time against one reference render. With ``--target-relative R``, the spp the
model advises for an image RMSE of R × the image's mean, rendered at it and at half of it
(Cycles runs any spp; the next one down is not told apart by renders): the first should
measure at most the target, the second above it.

Usage::

    python bench/frame_check_cycles.py ../shared/envmaps/forest.exr sun-gp \
        --spp 16 64 256 --renders 16 --out frame_check_cycles
    python bench/frame_check_cycles.py ../shared/envmaps/forest.exr sun-gp \
        --scenes spheres_box principled --target-relative 0.05 --renders 8
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from envfit.frame import predict_frame
from envfit.maps import save_envmap, synthesize_envmap
from frame_check import (_interval, finish, lower_spp,  # the same measures and report
                         row_line, target_line)
from envfit.renderers.cycles._render import (  # internal: the harness's bpy import, world and EXR reader
    _quiet_blender, _read_exr, _use_nodes, _world, import_bpy)

#: Blender's pattern names
PATTERNS = {"blue_noise": "AUTOMATIC", "tabulated_sobol": "TABULATED_SOBOL",
            "sobol_burley": "SOBOL_BURLEY"}


def _node_material(bpy, name: str, node_type: str, inputs: dict) -> object:
    """A material whose surface is one BSDF node of ``node_type`` with constant ``inputs``."""
    mat = bpy.data.materials.new(name)
    _use_nodes(mat)
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out, node = nt.nodes.new("ShaderNodeOutputMaterial"), nt.nodes.new(node_type)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    return mat


def _material(bpy, name: str, rgb) -> object:
    """A Diffuse BSDF of colour ``rgb`` (roughness 0: Lambert)."""
    return _node_material(bpy, name, "ShaderNodeBsdfDiffuse",
                          {"Color": (*rgb, 1.0), "Roughness": 0.0})


def _glossy(bpy, name: str, rgb, roughness: float, principled: bool = False) -> object:
    """A Glossy BSDF (its default distribution, Multiscatter GGX) or a Principled BSDF at
    Metallic 1 (base colour ``rgb``), constant inputs."""
    if principled:
        return _node_material(bpy, name, "ShaderNodeBsdfPrincipled",
                              {"Base Color": (*rgb, 1.0), "Roughness": roughness,
                               "Metallic": 1.0})
    return _node_material(bpy, name, "ShaderNodeBsdfGlossy",
                          {"Color": (*rgb, 1.0), "Roughness": roughness})


def _principled(bpy, name: str, roughness: float = 0.5) -> object:
    """Blender's Principled BSDF at its defaults (Base Color 0.8, Metallic 0, IOR 1.5,
    Multiscatter GGX), Roughness ``roughness`` (0.5 its default)."""
    return _node_material(bpy, name, "ShaderNodeBsdfPrincipled", {"Roughness": roughness})


def _object(bpy, scene, name: str, mesh, mat, location=(0, 0, 0), scale=1.0, smooth=False):
    if smooth:
        for p in mesh.polygons:
            p.use_smooth = True
    ob = bpy.data.objects.new(name, mesh)
    ob.location, ob.scale = location, (scale, scale, scale)
    ob.data.materials.append(mat)
    scene.collection.objects.link(ob)
    return ob


def _mesh(bpy, name: str, kind: str):
    """A mesh from bmesh primitives: ``sphere`` (UV, 64 × 32), ``cube``, ``plane``, ``torus``."""
    import bmesh
    bm = bmesh.new()
    if kind == "sphere":
        bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=1.0)
    elif kind == "cube":
        bmesh.ops.create_cube(bm, size=2.0)
    elif kind == "plane":
        bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=1.0)
    else:
        n, m, big, small = 48, 24, 0.6, 0.25
        verts = [bm.verts.new(((big + small * math.cos(v)) * math.cos(u),
                               (big + small * math.cos(v)) * math.sin(u), small * math.sin(v)))
                 for u in np.arange(n) * 2 * np.pi / n for v in np.arange(m) * 2 * np.pi / m]
        for i in range(n):
            for j in range(m):
                a, b = i * m + j, ((i + 1) % n) * m + j
                c, d = ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
                bm.faces.new((verts[a], verts[b], verts[c], verts[d]))
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    return me


def build(path: Path, scene_name: str, envmap: Path, size=(64, 48),
          pattern: str = "blue_noise") -> Path:
    """Write the scene ``scene_name`` under ``envmap`` as a ``.blend`` at ``path``."""
    bpy = import_bpy()
    with _quiet_blender():
        bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    r, c = scene.render, scene.cycles
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = size[0], size[1], 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    c.device, c.samples, c.sampling_pattern = "CPU", 16, PATTERNS[pattern]
    c.use_adaptive_sampling, c.use_denoising = False, False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = 0
    c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    _world(bpy, scene, str(envmap))
    cam = bpy.data.cameras.new("camera")
    cam.lens, cam.sensor_fit = 35.0, "AUTO"
    co = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(co)
    scene.camera = co
    co.location, co.rotation_euler = (0.3, -3.0, 1.2), (math.radians(76), 0.0, 0.0)
    ground = _material(bpy, "ground", (0.5, 0.5, 0.5))
    _object(bpy, scene, "ground", _mesh(bpy, "plane", "plane"), ground, scale=6.0)
    if scene_name == "spheres_box":
        _object(bpy, scene, "sphere", _mesh(bpy, "sphere", "sphere"),
                _material(bpy, "orange", (0.8, 0.5, 0.3)), (0.0, 0.0, 0.5), 0.5, smooth=True)
        _object(bpy, scene, "cube", _mesh(bpy, "cube", "cube"),
                _material(bpy, "grey", (0.6, 0.6, 0.6)), (1.0, -0.3, 0.3), 0.3)
    elif scene_name == "torus":
        ob = _object(bpy, scene, "torus", _mesh(bpy, "torus", "torus"),
                     _material(bpy, "blue", (0.3, 0.4, 0.8)), (0.0, 0.0, 0.6), 1.0, smooth=True)
        ob.rotation_euler = (math.radians(60), 0.0, math.radians(20))
        _object(bpy, scene, "sphere", _mesh(bpy, "sphere", "sphere"),
                _material(bpy, "white", (0.9, 0.9, 0.9)), (-1.2, 0.8, 0.4), 0.4, smooth=True)
    elif scene_name == "gloss":
        _object(bpy, scene, "glossy", _mesh(bpy, "sphere", "sphere"),
                _glossy(bpy, "ggx", (0.9, 0.9, 0.9), 0.3), (-0.6, 0.0, 0.5), 0.5, smooth=True)
        _object(bpy, scene, "gold", _mesh(bpy, "sphere", "sphere"),
                _glossy(bpy, "gold", (1.0, 0.77, 0.34), 0.5, principled=True),
                (0.6, 0.2, 0.4), 0.4, smooth=True)
        _object(bpy, scene, "cube", _mesh(bpy, "cube", "cube"),
                _material(bpy, "grey", (0.6, 0.6, 0.6)), (0.3, -0.8, 0.2), 0.2)
    elif scene_name == "principled":
        _object(bpy, scene, "sphere", _mesh(bpy, "sphere", "sphere"),
                _principled(bpy, "default"), (-0.4, 0.0, 0.5), 0.5, smooth=True)
        _object(bpy, scene, "cube", _mesh(bpy, "cube", "cube"),
                _principled(bpy, "glossier", 0.2), (0.7, -0.3, 0.3), 0.3)
    else:
        raise SystemExit(f"unknown scene {scene_name!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    with _quiet_blender():
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def render(path: Path, spp: int, seed: int, out: Path) -> np.ndarray:
    """One Cycles render of the ``.blend`` at ``spp`` with ``seed``, (H, W, 3)."""
    bpy = import_bpy()
    with _quiet_blender():
        bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    scene.cycles.samples, scene.cycles.seed = int(spp), int(seed)
    scene.render.threads_mode = "AUTO"
    scene.render.filepath = str(out)
    with _quiet_blender():
        bpy.ops.render.render(write_still=True)
    return _read_exr(out)[..., :3]


def _measured(path: Path, n: int, renders: int, refs: tuple, work: Path) -> np.ndarray:
    """Each pixel's MSE at ``n`` spp over ``renders`` renders against the references' mean
    ``refs`` = (mean, its own MSE per pixel), that own noise taken out."""
    ref, ref_mse = refs
    imgs = np.stack([render(path, n, 1000 * n + s, work / "r.exr") for s in range(renders)])
    return ((imgs - ref[None]) ** 2).mean(axis=(0, 3)) - ref_mse


def target_check(path: Path, relative: float, renders: int, level: int, refs: tuple,
                 work: Path) -> dict:
    """The advised spp for ``relative`` × the image's mean, rendered at it and at half (Cycles
    runs any spp: :func:`frame_check.lower_spp`)."""
    p = predict_frame(path, target_relative=relative, level=level)
    out = {"target": p.target, "answer": p.answer, "below": p.below}
    if p.answer is None:
        return out
    for key, n in (("at_answer", p.answer), ("at_half", lower_spp(p))):
        meas = _measured(path, n, renders, refs, work)
        lo, hi = _interval(np.maximum(meas, 0.0), renders)
        m = math.sqrt(max(float(meas.mean()), 0.0))
        out[key] = {"spp": n, "measured": m, "low": math.sqrt(lo), "high": math.sqrt(hi),
                    "over_target": m / p.target}
    return out


def check(path: Path, spps, renders: int, reference_spp: int, level: int, work: Path,
          relative: float | None = None) -> dict:
    from scipy.stats import spearmanr
    t = time.perf_counter()
    p = predict_frame(path, spp=tuple(spps), level=level)
    t_pred = time.perf_counter() - t
    t = time.perf_counter()
    refs = [render(path, reference_spp, 90001 + k, work / f"ref{k}.exr") for k in range(2)]
    t_ref = (time.perf_counter() - t) / 2
    ref = 0.5 * (refs[0] + refs[1])
    ref_mse = ((refs[0] - refs[1]) ** 2).mean(axis=2) / 4.0       # the mean's own noise
    cells, pairs, rho = [], [], []
    for n, row in zip(spps, p.rows):
        meas = _measured(path, n, renders, (ref, ref_mse), work)
        lo, hi = _interval(np.maximum(meas, 0.0), renders)
        pred = row.rmse ** 2
        m = float(max(meas.mean(), 1e-300))
        cells.append({"spp": n, "predicted": row.rmse, "measured": math.sqrt(m),
                      "low": math.sqrt(lo), "high": math.sqrt(hi),
                      "ratio": row.rmse / math.sqrt(m),
                      "reference_share": float(ref_mse.mean() / m),
                      "inside": bool(0.64 * lo <= pred <= 1.5625 * hi)})
        pm = p.pixel_rmse(n).ravel() ** 2
        pairs.append((pm, meas.ravel()))
        rho.append(float(spearmanr(pm, meas.ravel())[0]))
    pred1, meas1 = (np.concatenate(x) for x in zip(*pairs))
    order = np.argsort(pred1)
    bins = [float(np.sqrt(max(meas1[b].mean(), 0.0) / max(pred1[b].mean(), 1e-300)))
            for b in np.array_split(order, 10)]
    out = {"cells": cells, "spearman": min(rho), "spearman_per_spp": rho,
           "bins_measured_over_predicted": bins,
           "bins_inside": int(sum(0.8 <= b <= 1.25 for b in bins)),
           "notes": list(p.notes), "seconds_predict": t_pred, "seconds_reference": t_ref,
           "reference_spp": reference_spp, "cost_ratio": t_pred / t_ref}
    if relative:
        out["target_check"] = target_check(path, relative, renders, level, (ref, ref_mse),
                                           work)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", help="map files, or sun-gp (synthesized, 512 high)")
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 64, 256])
    ap.add_argument("--renders", type=int, default=16)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--level", type=int, default=4)
    ap.add_argument("--scenes", nargs="+", default=["spheres_box", "torus"])
    ap.add_argument("--pattern", default="blue_noise", choices=sorted(PATTERNS))
    ap.add_argument("--size", type=int, nargs=2, default=[64, 48], metavar=("W", "H"))
    ap.add_argument("--target-relative", type=float, default=None,
                    help="also render the advised spp for this relative image RMSE and half")
    ap.add_argument("--out", type=Path, default=Path("frame_check_cycles"))
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    maps = []
    for m in a.maps:
        if m == "sun-gp":
            env = synthesize_envmap("sun-gp", height=512, seed=2)
            maps.append(("sun-gp", save_envmap(a.out / "sun-gp.exr", env.envmap)))
        else:
            maps.append((Path(m).stem, Path(m).resolve()))
    rows = []
    for sname in a.scenes:
        for mname, mpath in maps:
            path = build(a.out / f"{sname}_{a.pattern}_{mname}.blend", sname, mpath,
                         tuple(a.size), a.pattern)
            r = check(path, a.spp, a.renders, a.reference_spp, a.level, a.out,
                      a.target_relative)
            r.update(scene=sname, map=mname, pattern=a.pattern)
            if "target_check" in r:
                print(target_line(sname, mname, r["target_check"]), flush=True)
            rows.append(r)
            print(row_line(r, a.reference_spp), flush=True)
    return finish(rows, a, a.out / "frame_check_cycles.json")

if __name__ == "__main__":
    raise SystemExit(main())

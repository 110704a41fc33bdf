"""Rendering check of envfit's pbrt-v4 predictions: render the white diffuse sphere of
bench/render_check.py (six orthographic views of a unit sphere, envfit.renderers) with the
``pbrt`` binary of pbrt-v4 and set its measured noise against envfit's ``pbrt4`` prediction.

    python bench/pbrt4_check.py /tmp/s34/maps/forest64.exr /tmp/s34/maps/city64.exr \\
        --samplers zsobol independent stratified paddedsobol --strategies mis brdf \\
        --spp 16 64 256 --renders 16 --reference-spp 4096 --resolution 32 \\
        --out /tmp/s34/pbrt_check

(run it with ``NUMBA_NUM_THREADS=1`` to keep envfit's model on one core; pbrt runs with
``--nthreads 1`` under ``nice``, one render at a time).

Per map (a lat-long file, given by path):

* the map **as envfit reads it** (``load_envmap``: negatives clamped to 0, as
  ``envfit advise MAP --renderer pbrt4`` reads it) is written to ``OUT/maps/NAME.exr`` and
  converted with ``imgtool makeequiarea`` exactly as the snippet's first line says
  (``--map-file raw`` converts a copy of the file as given instead: pbrt then filters the
  signed pixels and clamps afterwards, envfit still predicts from the clamped map);
  envfit's own conversion (``make_equal_area``, what its model reads) is compared with
  imgtool's (``equal_area`` in the JSON: per-pixel relative differences and the power ratio,
  of the file as read and as given);
* each scene is the record's snippet (``get_renderer("pbrt4").snippet(strategy, sampler, spp,
  filename=..., up=..., sphere_pixels=R)``: ``path`` for ``mis``, ``simplepath`` with
  ``samplelights`` false for ``brdf``, ``maxdepth`` 1, the orthographic camera on [-1, 1]²,
  the box filter of radius 0.5, the ``diffuse`` material of reflectance 1, the light's
  ``ConcatTransform`` of the map's ``up``) with two changes only: the ``LookAt`` of each of
  the six views (``SPHERE_VIEWS``) and ``"bool savefp16" [ false ]`` on the ``rgb`` film.
  pbrt's ``LookAt`` makes image right = up × (look − eye), the mirror of envfit's views
  (right = up × axis): every image is flipped left-right after reading, and the layout is
  checked (``orientation`` in the JSON) twice: pbrt's own world shading normals (the
  ``gbuffer`` film) against ``view_normals``, and each map's converged reference against
  the exact shading (1/π)∫L max(0, n·ω)dω of the pixel normals over imgtool's equal-area
  image;
* every cell (sampler × strategy × spp) renders ``--renders`` sets of six views with random
  ``--seed`` values (``nice -n 10 pbrt --nthreads 1 --quiet --seed S --spp N --outfile F``),
  the reference is two sets at ``--reference-spp`` (``--reference-sampler``, MIS) with their
  own seeds, cached in ``OUT/cache``; the measured RMSE is sphere_error's (the reference's
  own variance subtracted, RMS over channels, weighted over the kept pixels) with the
  squared errors averaged over the renders, and its percentile bootstrap 95 % interval over
  pixels; the predicted RMSE is bench/render_check.py's :func:`predict_cell` (the preset's
  DiffuseModel) with the pixel footprint of the R-pixel sphere (``--footprint 2``, as
  ``advise --sphere-pixels R``), and, as ``predicted_point``, with point normals (``advise``'s
  default); "inside": the prediction in [0.8 × low, 1.25 × high];
* pbrt is spectral (4 wavelengths per camera sample, drawn from the sampler's 1-D
  dimension before the film's): ``--wavelengths fixed`` renders cells (and their reference)
  with ``--disable-wavelength-jitter`` (the same 4 wavelengths for every sample: no
  wavelength noise, but white renders as about (1.22, 1.01, 0.60)), and divides renders and
  reference per channel by that white response (``white_response_fixed`` in the JSON):
  the noise of the estimator alone; ``jitter`` (default) as pbrt renders by default. Once per map size, a constant map of 1.0 is rendered at the
  spp of ``--spp`` for each sampler and strategy (``--spectral-renders`` sets): the sphere's
  pixels are all exactly 1 (reflectance 1), so their RMSE against 1 is the noise that is
  not in envfit's model where the estimator is exact (``brdf``: cosine sampling of a
  constant map), beside envfit's prediction for that map (``spectral`` in the JSON and
  ``OUT/pbrt4_check_spectral.csv``).

Writes ``OUT/pbrt4_check.json`` and ``.csv`` after every cell and skips the cells already
there (resumable); prints the table, per (sampler, strategy) the median ratio and the share
inside, the spectral table, the conversion comparison, the CPU (lscpu) and the wall times.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import render_check  # noqa: E402
from render_check import Predictor, predict_cell, load_map  # noqa: E402
from render_check import _cpu, _offset  # noqa: E402  # internal: render_check's CPU name and offset column

from envfit.base._atomic import atomic_write_csv, atomic_write_json  # noqa: E402  # internal: the atomic writers of the product's outputs
from envfit.maps import EnvMap, load_envmap, local_to_world, save_envmap  # noqa: E402
from envfit.predict.renderer import DiffuseModel, RendererModelOptions  # noqa: E402
from envfit.renderers import (BOOTSTRAP_RESAMPLES, BOX_FILTER, VIEWS,  # noqa: E402
                              Pbrt4ImageInfiniteLight, cached_reference,
                              equal_area_square_to_sphere, get_renderer, make_equal_area,
                              sphere_geometry, view_normals, view_seeds)
from envfit.renderers._base import SPHERE_VIEWS  # noqa: E402  # internal: the snippet's six views (LookAt of each)
from envfit.renderers._sphere import _bootstrap  # noqa: E402  # internal: sphere_error's pixel bootstrap, over R renders here

PBRT = "/tmp/pbrt4/build/pbrt"
IMGTOOL = "/tmp/pbrt4/build/imgtool"
COLUMNS = ["map", "sampler", "strategy", "wavelengths", "spp", "spp_used", "renders",
           "measured_rmse", "low", "high", "predicted", "ratio", "inside", "model_se",
           "predicted_point", "ratio_point", "inside_point", "model_se_point",
           "predicted_point_imgtool", "predicted_before", "reference_rmse", "mean_offset",
           "render_rmse_sd", "seconds", "seconds_per_view", "pixels"]
SPECTRAL_COLUMNS = ["shape", "sampler", "strategy", "wavelengths", "spp", "renders",
                    "sphere_rmse", "sphere_sd", "sphere_grey_rmse", "sphere_max_dev",
                    "sphere_mean",
                    "background_rmse", "background_mean", "predicted", "seconds"]


# ----------------------------------------------------------------------------- files, pbrt

def read_exr(path) -> np.ndarray:
    """An EXR's R, G, B channels (H, W, 3) float64, row 0 at the top (OpenImageIO)."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise RuntimeError(f"cannot open {path}: {oiio.geterror()}")
    try:
        names = list(inp.spec().channelnames)
        a = np.asarray(inp.read_image("float"), dtype=np.float64)
    finally:
        inp.close()
    return a[:, :, [names.index(c) for c in "RGB"]]


def read_channels(path, channels) -> np.ndarray:
    """The named channels (H, W, len(channels)) of an EXR."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    try:
        names = list(inp.spec().channelnames)
        a = np.asarray(inp.read_image("float"), dtype=np.float64)
    finally:
        inp.close()
    return a[:, :, [names.index(c) for c in channels]]


def lookat(k: int) -> str:
    """``LookAt`` of view k of :data:`SPHERE_VIEWS` (eye 3v, the origin, up u), written as the
    snippet writes its view."""
    v, u = SPHERE_VIEWS[k]
    return "LookAt " + "  ".join(" ".join(f"{c:g}" for c in w)
                                 for w in ([3 * c for c in v], (0, 0, 0), u))


def scenes(record, strategy: str, sampler: str, spp: int, map_file: Path, up: str,
           resolution: int, film: str = "rgb") -> tuple[list[str], Path, str]:
    """The six views' scene texts of the record's snippet (module docstring), the equal-area
    file it reads and the conversion line it starts with."""
    text = record.snippet(strategy, sampler, spp, filename=str(map_file), up=up,
                          sphere_pixels=resolution)
    lines = text.splitlines()
    convert = lines[0]
    eq = re.search(r'LightSource "infinite" "string filename" \[ "(.*?)" \]', text).group(1)
    look = [i for i, ln in enumerate(lines) if ln.startswith("LookAt ")]
    films = [i for i, ln in enumerate(lines) if ln.startswith('Film "rgb"')]
    if len(look) != 1 or len(films) != 1 or lines[look[0]] != lookat(4):
        raise RuntimeError("the pbrt4 snippet changed: one 'LookAt' of view +z and one "
                           "'Film \"rgb\"' line expected\n" + text)
    out = []
    for k in range(len(SPHERE_VIEWS)):
        ls = list(lines)
        ls[look[0]] = lookat(k)
        if film == "rgb":
            ls[films[0]] += ' "bool savefp16" [ false ]'
        else:                           # the gbuffer film: world normals per pixel
            ls[films[0]] = ls[films[0]].replace(
                'Film "rgb"', 'Film "gbuffer" "string coordinatesystem" "world" '
                              '"bool savefp16" [ false ]')
        out.append("\n".join(ls) + "\n")
    return out, Path(eq), convert


class Pbrt:
    """The pbrt binary run one render at a time (``--nthreads 1``, ``nice``)."""

    def __init__(self, args):
        self.pbrt, self.imgtool, self.nice = args.pbrt, args.imgtool, args.nice
        self.dir = Path(tempfile.mkdtemp(prefix="pbrt4-check-"))
        self.renders = 0

    def close(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def _run(self, cmd):
        p = subprocess.run(["nice", "-n", str(self.nice), *cmd], capture_output=True,
                           text=True)
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}"
                               f"{p.stdout}")
        return p

    def makeequiarea(self, latlong: Path, out: Path) -> float:
        t = time.perf_counter()
        self._run([self.imgtool, "makeequiarea", str(latlong), "--outfile", str(out)])
        return time.perf_counter() - t

    def render_view(self, scene: str, spp: int, seed: int, fixed: bool = False,
                    channels=None) -> tuple[np.ndarray, float]:
        """One view (R, R, C), flipped left-right into envfit's layout, and its seconds."""
        sp, out = self.dir / "view.pbrt", self.dir / "view.exr"
        sp.write_text(scene)
        cmd = [self.pbrt, "--nthreads", "1", "--quiet", "--seed", str(seed), "--spp", str(spp),
               "--outfile", str(out)]
        if fixed:
            cmd.append("--disable-wavelength-jitter")
        t = time.perf_counter()
        self._run(cmd + [str(sp)])
        secs = time.perf_counter() - t
        img = read_exr(out) if channels is None else read_channels(out, channels)
        out.unlink()
        self.renders += 1
        return img[:, ::-1], secs

    def render_set(self, texts, spp: int, seeds, fixed: bool = False):
        """The six views (6, R, R, 3) with seeds[k] each, and the total seconds."""
        imgs, total = [], 0.0
        for text, s in zip(texts, seeds):
            img, secs = self.render_view(text, spp, s, fixed)
            imgs.append(img)
            total += secs
        return np.stack(imgs), total


# ----------------------------------------------------------------------------- measures

def measure(imgs, a, b, geometry, rng, resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """sphere_error over R renders (R, 6, N, N, C): per kept pixel the squared error against
    (a + b)/2 averaged over renders and channels, minus (a − b)²/4; the weighted mean, its
    square root, the percentile bootstrap over pixels; the mean offset; the spread of the
    renders' own RMSEs."""
    keep = geometry.keep
    ref = 0.5 * (a + b)
    sq = ((imgs - ref[None]) ** 2).mean(axis=-1)[:, :, keep]          # (R, 6, K)
    v = (0.25 * (a - b) ** 2).mean(axis=-1)[:, keep].ravel()
    w = np.broadcast_to(geometry.weight[keep], (len(VIEWS), int(keep.sum()))).ravel()
    if not np.all(np.isfinite(sq)) or not np.all(np.isfinite(v)):
        raise RuntimeError("a render holds NaN or Inf on the sphere")
    d = sq.mean(axis=0).ravel() - v
    root = lambda m: float(np.sqrt(max(m, 0.0)))
    mse = float(np.sum(w * d) / np.sum(w))
    lo, hi = _bootstrap(d, w, rng, int(resamples))
    per = [root(float(np.sum(w * (s.ravel() - v)) / np.sum(w))) for s in sq]
    diff = (imgs.mean(axis=0) - ref).mean(axis=-1)[:, keep].ravel()
    level = float(np.sum(w * ref.mean(axis=-1)[:, keep].ravel()))
    return {"measured_rmse": root(mse), "low": root(lo), "high": root(hi),
            "reference_rmse": root(float(np.sum(w * v) / np.sum(w))),
            "mean_offset": float(np.sum(w * diff) / level) if level > 0 else 0.0,
            "render_rmse_sd": float(np.std(per, ddof=1)) if len(per) > 1 else 0.0,
            "pixels": int(d.size)}


def background_mask(resolution: int) -> np.ndarray:
    """Pixels whose whole square lies off the sphere's disk."""
    c = (np.arange(resolution) + 0.5) / resolution * 2.0 - 1.0
    X, Y = np.meshgrid(c, -c)
    h = 1.0 / resolution
    dx, dy = np.maximum(np.abs(X) - h, 0.0), np.maximum(np.abs(Y) - h, 0.0)
    return dx ** 2 + dy ** 2 > 1.0


def exact_shading(eq: np.ndarray, up: str, normals: np.ndarray, sub: int = 2) -> np.ndarray:
    r"""(1/π)∫ L(ω) max(0, n·ω) dω (K, 3) at world normals (K, 3) over the equal-area image
    ``eq`` (N, N, 3) as the light sees it: ``sub`` × ``sub`` equal-area cells per pixel, each
    of solid angle 4π/(sub N)², radiance = its pixel (nearest lookup), light frame → world by
    ``local_to_world(up)`` (the snippet's ConcatTransform)."""
    n = eq.shape[0]
    g = n * sub
    c = (np.arange(g) + 0.5) / g
    uu, vv = np.meshgrid(c, c)                      # u: column, v: row
    d = equal_area_square_to_sphere(np.column_stack([uu.ravel(), vv.ravel()]))
    d = d @ local_to_world(up).T
    L = eq[(vv.ravel() * n).astype(int), (uu.ravel() * n).astype(int)]
    dw = 4.0 * np.pi / (g * g) / np.pi
    out = np.empty((len(normals), 3))
    for s in range(0, len(normals), 256):
        cos = np.maximum(normals[s:s + 256] @ d.T, 0.0)
        out[s:s + 256] = cos @ L * dw
    return out


def compare_equal_area(ours: np.ndarray, theirs: np.ndarray) -> dict:
    """Per-pixel relative differences of envfit's equal-area image against imgtool's (pixels
    above 1e-3 × imgtool's mean), the largest absolute difference over the mean, the ratio of
    the means (the power) and the pixels imgtool made 0 that envfit did not."""
    d = np.abs(ours - theirs)
    m = float(theirs.mean())
    sig = theirs > 1e-3 * m
    rel = d[sig] / theirs[sig]
    return {"max_rel": float(rel.max()), "p99_rel": float(np.percentile(rel, 99)),
            "median_rel": float(np.median(rel)), "max_abs_over_mean": float(d.max() / m),
            "mean_ratio": float(ours.mean() / m),
            "zero_in_imgtool_not_envfit": int(((~sig) & (ours > 1e-3 * m)).sum())}


# ----------------------------------------------------------------------------- the run

class Run:
    """The JSON document (meta, rows, spectral, equal_area, orientation) and its writers."""

    def __init__(self, out: Path):
        self.out = out
        self.path = out / "pbrt4_check.json"
        self.doc = {"meta": {}, "rows": [], "spectral": [], "equal_area": {},
                    "orientation": {}, "predictions": {}}
        if self.path.exists():
            self.doc.update(json.loads(self.path.read_text()))

    @property
    def rows(self) -> list:
        return self.doc["rows"]

    def write(self):
        atomic_write_json(self.path, self.doc)
        atomic_write_csv(self.out / "pbrt4_check.csv", COLUMNS,
                         [[r.get(c, "") for c in COLUMNS] for r in self.rows])
        atomic_write_csv(self.out / "pbrt4_check_spectral.csv", SPECTRAL_COLUMNS,
                         [[r.get(c, "") for c in SPECTRAL_COLUMNS]
                          for r in self.doc["spectral"]])


def cell_rng(args, *key) -> np.random.Generator:
    """The seeds of one cell: the same on every run (resumable in any order)."""
    return np.random.default_rng([args.seed, zlib.crc32(repr(key).encode())])


def reference(pbrt: Pbrt, record, name: str, eq: np.ndarray, map_file: Path, up: str, args,
              fixed: bool):
    """The two reference sets (MIS, ``--reference-sampler``, ``--reference-spp``) of the
    equal-area image ``eq`` pbrt reads, cached."""
    digest = zlib.crc32(np.ascontiguousarray(eq, dtype=np.float32).tobytes())
    key = {"renderer": "pbrt4", "binary": str(args.pbrt), "map": name, "equal_area": digest,
           "spp": args.reference_spp, "resolution": args.resolution,
           "sampler": args.reference_sampler, "strategy": "mis", "seed": args.reference_seed,
           "wavelengths": "fixed" if fixed else "jitter", "flip": "lr"}
    texts, _, _ = scenes(record, "mis", args.reference_sampler, args.reference_spp, map_file,
                         up, args.resolution)

    def render():
        rng = np.random.default_rng([args.reference_seed, digest])
        seeds = view_seeds(rng, 2 * len(VIEWS))
        a, ta = pbrt.render_set(texts, args.reference_spp, seeds[:6], fixed)
        b, tb = pbrt.render_set(texts, args.reference_spp, seeds[6:], fixed)
        return a, b, ta + tb

    return cached_reference(key, render, str(args.out / "cache"))


def prepare_map(spec: str, args, run: Run, pbrt: Pbrt, record):
    """The map as envfit reads it, its file for pbrt, imgtool's conversion and the
    comparison with envfit's (``run.doc["equal_area"]``)."""
    name, env = load_map(spec, 256)
    maps = args.out / "maps"
    maps.mkdir(parents=True, exist_ok=True)
    if args.map_file == "raw":
        name = f"{name}-raw"
        map_file = maps / f"{name}{Path(spec).suffix}"
        shutil.copyfile(spec, map_file)
    else:
        map_file = maps / f"{name}.exr"
        save_envmap(map_file, env)
    texts, eq_file, convert = scenes(record, "mis", None, 16, map_file, env.up,
                                     args.resolution)
    secs = pbrt.makeequiarea(map_file, eq_file)
    eq = read_exr(eq_file)
    if name not in run.doc["equal_area"]:
        raw = load_envmap(spec, allow_negative=True)
        raw_px = np.asarray(raw.data)
        envfit_eq = make_equal_area(env)            # what envfit's model reads
        cmp = {"snippet_line": convert, "imgtool_seconds": secs,
               "negative_values": int((raw_px < 0).sum()),
               "negative_sum_over_positive_sum": float(raw_px[raw_px < 0].sum()
                                                       / raw_px[raw_px > 0].sum()),
               "rendered_file": args.map_file,
               "envfit_vs_imgtool_rendered": compare_equal_area(envfit_eq, eq)}
        other = pbrt.dir / "other-equiarea.exr"
        if args.map_file == "raw":
            asread = pbrt.dir / "asread.exr"
            save_envmap(asread, env)
            pbrt.makeequiarea(asread, other)
            cmp["envfit_vs_imgtool_asread"] = compare_equal_area(envfit_eq, read_exr(other))
        else:
            pbrt.makeequiarea(Path(spec), other)
            cmp["envfit_vs_imgtool_file_as_given"] = compare_equal_area(envfit_eq,
                                                                        read_exr(other))
        cmp["envfit_raw_vs_imgtool_file_as_given"] = compare_equal_area(
            make_equal_area(raw), read_exr(other) if args.map_file != "raw" else eq)
        run.doc["equal_area"][name] = cmp
        run.write()
    return name, env, map_file, eq


def orientation_normals(pbrt: Pbrt, record, map_file: Path, up: str, args) -> dict:
    """pbrt's world shading normals (gbuffer film, 16 spp) against envfit's view_normals on
    the kept pixels, in the adopted layout (flipped left-right) and unflipped."""
    g = sphere_geometry(args.resolution)
    texts, _, _ = scenes(record, "mis", "independent", 16, map_file, up, args.resolution,
                         film="gbuffer")
    got = np.stack([pbrt.render_view(t, 16, 1, channels=("Ns.X", "Ns.Y", "Ns.Z"))[0]
                    for t in texts])
    want = np.stack([view_normals(v, g) for v in VIEWS])
    out = {}
    for tag, arr in (("flipped (adopted)", got), ("unflipped", got[:, :, ::-1])):
        n = arr[:, g.keep]
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        ang = np.degrees(np.arccos(np.clip(np.sum(n * want[:, g.keep], axis=-1), -1, 1)))
        out[tag] = {"max_deg": float(ang.max()), "median_deg": float(np.median(ang))}
    return out


def orientation_shading(ref, eq: np.ndarray, up: str, args) -> dict:
    """The converged reference (a + b)/2 against the exact shading of the pixel-centre
    normals, flipped (adopted) and unflipped: relative RMS difference and mean ratio."""
    g = sphere_geometry(args.resolution)
    normals = np.stack([view_normals(v, g) for v in VIEWS])[:, g.keep].reshape(-1, 3)
    exact = exact_shading(eq, up, normals)
    r = 0.5 * (ref.a + ref.b)
    out = {}
    for tag, arr in (("flipped (adopted)", r), ("unflipped", r[:, :, ::-1])):
        got = arr[:, g.keep].reshape(-1, 3)
        out[tag] = {"rel_rms_diff": float(np.sqrt(np.mean((got - exact) ** 2))
                                          / np.sqrt(np.mean(exact ** 2))),
                    "mean_ratio": float(got.mean() / exact.mean())}
    return out


class ImagePredictor(Predictor):
    """render_check's Predictor whose model reads a given equal-area image (imgtool's: the
    one pbrt renders) instead of envfit's conversion of the lat-long map."""

    def __init__(self, eq: np.ndarray, up: str, *a, **k):
        super().__init__(*a, **k)
        self.technique = Pbrt4ImageInfiniteLight(equal_area=eq)
        self.technique.native_to_world = local_to_world(up)      # the snippet's transform

    def preset_model(self, compensation: bool):
        if compensation not in self._presets:
            self._presets[compensation] = DiffuseModel(
                None, get_renderer("pbrt4"), {},
                RendererModelOptions(normals=render_check.PRESET_NORMALS,
                                     max_level=self.max_level,
                                     sphere_pixels=self.footprint and self.footprint[0],
                                     footprint_side=self.footprint[1] if self.footprint else 2,
                                     pixel_filter=BOX_FILTER),
                technique=self.technique)
        return self._presets[compensation]


class Predictions:
    """envfit's predictions of a map's cells (:func:`predict_cell`, ``--normals`` normals):
    with the footprint of the R-pixel sphere (``predicted``), with point normals
    (``predicted_point``) and, with point normals, from imgtool's equal-area image instead of
    envfit's conversion (``predicted_point_imgtool``); the models' relative standard errors
    (``model_se``: from their normals and sampled randomisations). Built on first use."""

    def __init__(self, env: EnvMap, eq: np.ndarray | None, args, cells, cache=None,
                 name: str = ""):
        self.cache = {} if cache is None else cache     # the JSON's "predictions"
        self.tag = (f"{name}|normals {args.normals}|footprint {args.footprint}|level "
                    f"{args.max_level}")
        foot = (args.resolution, args.footprint) if args.footprint > 1 else None
        self.models = {"predicted": Predictor("pbrt4", env, 512, 64, args.max_level, foot),
                       "predicted_point": Predictor("pbrt4", env, 512, 64, args.max_level)}
        if eq is not None:
            self.models["predicted_point_imgtool"] = ImagePredictor(
                eq, env.up, "pbrt4", env, 512, 64, args.max_level)
        for m in self.models.values():
            m.cells = list(cells)

    def fields(self, sampler: str, strategy: str, spp: int, measured: dict | None) -> dict:
        key = f"{self.tag}|{sampler}|{strategy}|{spp}"
        if key not in self.cache:
            out = {}
            for name, m in self.models.items():
                out[name] = predict_cell(m, sampler, strategy, spp)
                se = m.preset_model(False).predict(strategy, sampler, spp).model_se
                if name != "predicted_point_imgtool":
                    out[name.replace("predicted", "model_se")] = (None if se is None
                                                                  else float(se))
            self.cache[key] = out
        out = dict(self.cache[key])
        if measured is not None:
            rm, lo, hi = measured["measured_rmse"], measured["low"], measured["high"]
            for suffix in ("", "_point"):
                p = out["predicted" + suffix]
                out["ratio" + suffix] = p / rm if rm > 0 else math.inf
                out["inside" + suffix] = bool(0.8 * lo <= p <= 1.25 * hi)
        return out


def repredict_map(spec: str, args, run: Run, pbrt: Pbrt, record) -> None:
    """Predict the saved rows of a map again with this run's ``--normals``, ``--footprint``
    and ``--max-level`` (no rendering); the first prediction is kept as
    ``predicted_before``."""
    name, env = load_map(spec, 256)
    if args.map_file == "raw":
        name = f"{name}-raw"
    mine = [r for r in run.rows if r["map"] == name]
    if not mine:
        return
    eq = read_exr(args.out / "maps" / f"{name}-equiarea.exr")
    pred = Predictions(env, eq, args, {(r["sampler"], r["strategy"], r["spp_used"])
                                       for r in mine}, run.doc["predictions"], name)
    for r in mine:
        r.setdefault("predicted_before", r["predicted"])
        r.update(pred.fields(r["sampler"], r["strategy"], r["spp_used"], r))
    run.doc["meta"]["model"] = {"normals": args.normals, "footprint": args.footprint,
                                "max_level": args.max_level}
    run.write()


def run_map(spec: str, args, run: Run, pbrt: Pbrt, record) -> None:
    name, env, map_file, eq = prepare_map(spec, args, run, pbrt, record)
    t0 = time.perf_counter()
    if "normals" not in run.doc["orientation"]:
        run.doc["orientation"]["normals"] = orientation_normals(pbrt, record, map_file,
                                                                env.up, args)
        run.write()
    done = {(r["map"], r["sampler"], r["strategy"], r["wavelengths"], r["spp"])
            for r in run.rows}
    todo = [(w, s, st, n) for w in args.wavelengths for s in args.samplers
            for st in args.strategies for n in args.spp
            if (name, s, st, w, n) not in done]
    spectral(args, run, pbrt, record, env, map_file)
    if not todo and name in run.doc["orientation"]:
        return
    pred = Predictions(env, eq, args, [(s, st, record.sampler(s).spp(n))
                                       for _, s, st, n in todo], run.doc["predictions"], name)
    run.doc["meta"]["model"] = {"normals": args.normals, "footprint": args.footprint,
                                "max_level": args.max_level}
    refs, scale = {}, {False: np.ones(3)}
    if "fixed" in args.wavelengths:
        scale[True] = white_response(args, run, pbrt, record, env)
    for fixed in sorted({w == "fixed" for w in args.wavelengths}):
        t = time.perf_counter()
        refs[fixed] = reference(pbrt, record, name, eq, map_file, env.up,
                                args, fixed)
        lab = "fixed" if fixed else "jitter"
        run.doc["meta"].setdefault("reference_seconds", {})[f"{name}/{lab}"] = refs[fixed].seconds
        print(f"{name}: reference ({lab}) {'cached' if refs[fixed].cached else 'rendered'} "
              f"{refs[fixed].seconds:.0f} s render time, {time.perf_counter() - t:.0f} s now",
              flush=True)
    if name not in run.doc["orientation"]:
        run.doc["orientation"][name] = orientation_shading(refs[False] if False in refs
                                                           else refs[True], eq, env.up, args)
        run.write()
    for w, sampler, strategy, spp in todo:
        fixed = w == "fixed"
        texts, _, _ = scenes(record, strategy, sampler, spp, map_file, env.up, args.resolution)
        rng = cell_rng(args, name, sampler, strategy, w, spp)
        seeds = view_seeds(rng, args.renders * len(VIEWS))
        t = time.perf_counter()
        sets = []
        secs = 0.0
        for r in range(args.renders):
            imgs, s = pbrt.render_set(texts, spp, seeds[6 * r:6 * r + 6], fixed)
            sets.append(imgs)
            secs += s
        k = scale[fixed]                    # fixed wavelengths: white back to (1, 1, 1)
        m = measure(np.stack(sets) / k, refs[fixed].a / k, refs[fixed].b / k,
                    pbrt_geometry(args), rng)
        used = record.sampler(sampler).spp(spp)
        row = {"map": name, "sampler": sampler, "strategy": strategy, "wavelengths": w,
               "spp": spp, "spp_used": used, "renders": args.renders, **m,
               **pred.fields(sampler, strategy, used, m),
               "seconds": secs, "seconds_per_view": secs / (6 * args.renders),
               "wall_seconds": time.perf_counter() - t}
        p = row["predicted"]
        run.rows.append(row)
        run.write()
        print(f"{name} {sampler} {strategy} {w} {spp}: measured {m['measured_rmse']:.4g} "
              f"[{m['low']:.4g}, {m['high']:.4g}] predicted {p:.4g} ratio {row['ratio']:.3f} "
              f"({secs:.0f} s render)", flush=True)
    run.doc["meta"].setdefault("map_seconds", {})[name] = (
        run.doc["meta"].get("map_seconds", {}).get(name, 0.0) + time.perf_counter() - t0)
    run.write()


_GEOMETRY: dict = {}


def pbrt_geometry(args):
    if args.resolution not in _GEOMETRY:
        _GEOMETRY[args.resolution] = sphere_geometry(args.resolution)
    return _GEOMETRY[args.resolution]


def constant_map(args, pbrt: Pbrt, record, env: EnvMap) -> tuple[EnvMap, Path]:
    """The constant map of 1.0 of ``env``'s size, its file and its equal-area file."""
    shape = f"{env.height}x{env.width}"
    const = EnvMap(np.ones((env.height, env.width, 3), np.float32), up=env.up, name="const1")
    cfile = args.out / "maps" / f"const1-{shape}.exr"
    if not cfile.exists():
        save_envmap(cfile, const)
    _, eq_file, _ = scenes(record, "mis", None, 16, cfile, env.up, args.resolution)
    if not eq_file.exists():
        pbrt.makeequiarea(cfile, eq_file)
    return const, cfile


def white_response(args, run: Run, pbrt: Pbrt, record, env: EnvMap) -> np.ndarray:
    """The RGB pbrt renders for white (a constant map of 1.0, reflectance 1, BSDF sampling:
    exact per sample) with ``--disable-wavelength-jitter``: the colour the 4 fixed
    wavelengths give white; fixed-wavelength renders are divided by it per channel."""
    meta = run.doc["meta"]
    if "white_response_fixed" not in meta:
        _, cfile = constant_map(args, pbrt, record, env)
        texts, _, _ = scenes(record, "brdf", "independent", 1, cfile, env.up, args.resolution)
        img, _ = pbrt.render_view(texts[4], 1, 1, fixed=True)
        sph = img[pbrt_geometry(args).keep]
        meta["white_response_fixed"] = sph.mean(axis=0).tolist()
        meta["white_response_fixed_spread"] = float(np.abs(sph - sph.mean(axis=0)).max())
        run.write()
    return np.asarray(meta["white_response_fixed"])


def spectral(args, run: Run, pbrt: Pbrt, record, env: EnvMap, map_file: Path) -> None:
    """The constant map of 1.0 of the map's size (once per size): per sampler, strategy,
    wavelengths mode and spp, the RMSE of the sphere's pixels against 1 (weighted over the
    kept pixels, RMS over channels), of their channel mean (grey), the largest deviation,
    the background's RMSE, and envfit's prediction for that map."""
    shape = f"{env.height}x{env.width}"
    done = {(r["shape"], r["sampler"], r["strategy"], r["wavelengths"], r["spp"])
            for r in run.doc["spectral"]}
    todo = [(w, s, st, n) for w in ("jitter", "fixed") for s in args.samplers
            for st in args.strategies for n in args.spp if (shape, s, st, w, n) not in done]
    if not todo or args.spectral_renders < 1:
        return
    const, cfile = constant_map(args, pbrt, record, env)
    pred = Predictions(const, None, args, [(s, st, record.sampler(s).spp(n))
                                           for _, s, st, n in todo], run.doc["predictions"],
                       f"const1-{shape}")
    g = pbrt_geometry(args)
    bg = background_mask(args.resolution)
    w = np.broadcast_to(g.weight[g.keep], (args.spectral_renders, len(VIEWS),
                                           int(g.keep.sum())))
    for wl, sampler, strategy, spp in todo:
        texts, _, _ = scenes(record, strategy, sampler, spp, cfile, env.up, args.resolution)
        rng = cell_rng(args, "const1", shape, sampler, strategy, wl, spp)
        seeds = view_seeds(rng, args.spectral_renders * len(VIEWS))
        sets, secs = [], 0.0
        for r in range(args.spectral_renders):
            imgs, s = pbrt.render_set(texts, spp, seeds[6 * r:6 * r + 6], wl == "fixed")
            sets.append(imgs)
            secs += s
        a = np.stack(sets)                                   # (R, 6, N, N, 3)
        sph = a[:, :, g.keep]                                # (R, 6, K, 3)
        e2 = ((sph - 1.0) ** 2).mean(axis=-1)
        grey = (sph.mean(axis=-1) - 1.0) ** 2
        mean_c = np.sum(w[..., None] * sph, axis=(0, 1, 2)) / np.sum(w)
        sd = float(np.sqrt(np.sum(w * ((sph - mean_c) ** 2).mean(axis=-1)) / np.sum(w)))
        back = a[:, :, bg]
        p = pred.fields(sampler, strategy, record.sampler(sampler).spp(spp), None)["predicted"]
        run.doc["spectral"].append({
            "shape": shape, "sampler": sampler, "strategy": strategy, "wavelengths": wl,
            "spp": spp, "renders": args.spectral_renders,
            "sphere_rmse": float(np.sqrt(np.sum(w * e2) / np.sum(w))),
            "sphere_grey_rmse": float(np.sqrt(np.sum(w * grey) / np.sum(w))),
            "sphere_max_dev": float(np.abs(sph - 1.0).max()),
            "sphere_mean": float(np.sum(w[..., None] * sph) / np.sum(w) / 3.0),
            "sphere_mean_rgb": mean_c.tolist(), "sphere_sd": sd,
            "background_rmse": float(np.sqrt(np.mean((back - 1.0) ** 2))),
            "background_mean": float(back.mean()), "predicted": p, "seconds": secs})
        run.write()
        print(f"const1 {shape} {sampler} {strategy} {wl} {spp}: sphere RMSE vs 1 "
              f"{run.doc['spectral'][-1]['sphere_rmse']:.4g}, predicted {p:.4g}", flush=True)


# ----------------------------------------------------------------------------- printing

def _label(r: dict) -> str:
    return r["strategy"] + ("/fixλ" if r.get("wavelengths") == "fixed" else "")


def print_table(doc: dict) -> None:
    rows = doc["rows"]
    print(f"{'map':12s} {'sampler':12s} {'strategy':10s} {'spp':>5s} {'measured':>10s} "
          f"{'95% interval':>22s} {'predicted':>10s} {'pred/meas':>9s} {'in':>3s} "
          f"{'±se':>5s} {'point/meas':>10s} {'in':>3s} {'imgtool':>7s} {'s/view':>7s} "
          f"{'offset':>7s}")
    for r in rows:
        se = r.get("model_se")
        img = r.get("predicted_point_imgtool")
        img = "" if img is None else f"{img / r['measured_rmse']:7.3f}"
        print(f"{r['map']:12s} {r['sampler']:12s} {_label(r):10s} {r['spp']:5d} "
              f"{r['measured_rmse']:10.4g} [{r['low']:9.4g}, {r['high']:9.4g}] "
              f"{r['predicted']:10.4g} {r['ratio']:9.3f} {'y' if r['inside'] else 'n':>3s} "
              f"{'' if se is None else f'{100 * se:4.1f}%':>5s} "
              f"{r['ratio_point']:10.3f} {'y' if r['inside_point'] else 'n':>3s} "
              f"{img:>7s} "
              f"{r['seconds_per_view']:7.3f} {_offset(r)}")
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["sampler"], _label(r)), []).append(r)
    print("\nper (sampler, strategy): median predicted/measured, cells inside "
          "[0.8 low, 1.25 high] (footprint model; point normals)")
    for (s, st), rs in groups.items():
        print(f"  {s:12s} {st:10s} median {np.median([r['ratio'] for r in rs]):6.3f}   "
              f"inside {sum(r['inside'] for r in rs)}/{len(rs)}   point: median "
              f"{np.median([r['ratio_point'] for r in rs]):6.3f} inside "
              f"{sum(r['inside_point'] for r in rs)}/{len(rs)}")
    if doc["spectral"]:
        print("\nconstant map of 1.0 (sphere pixels exactly 1): RMSE against 1")
        print(f"  {'shape':8s} {'sampler':12s} {'strategy':8s} {'λ':7s} {'spp':>5s} "
              f"{'sphere':>9s} {'sd':>9s} {'grey':>9s} {'max dev':>9s} {'backgr.':>9s} "
              f"{'envfit':>9s}")
        for r in doc["spectral"]:
            print(f"  {r['shape']:8s} {r['sampler']:12s} {r['strategy']:8s} "
                  f"{r['wavelengths']:7s} {r['spp']:5d} {r['sphere_rmse']:9.3g} {r['sphere_sd']:9.3g} "
                  f"{r['sphere_grey_rmse']:9.3g} {r['sphere_max_dev']:9.3g} "
                  f"{r['background_rmse']:9.3g} {r['predicted']:9.3g}")
    for name, c in doc["equal_area"].items():
        print(f"\nequal-area conversion, {name} ({c['negative_values']} negative values, "
              f"their sum {100 * c['negative_sum_over_positive_sum']:+.2f} % of the positive)")
        for k, v in c.items():
            if isinstance(v, dict):
                print(f"  {k:40s} max rel {v['max_rel']:.3g}  p99 {v['p99_rel']:.3g}  median "
                      f"{v['median_rel']:.3g}  max|d|/mean {v['max_abs_over_mean']:.3g}  "
                      f"mean ratio {v['mean_ratio']:.5f}")
    if doc["orientation"]:
        print("\norientation:", json.dumps(doc["orientation"], indent=1))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("map_files", nargs="*", metavar="MAP", help="lat-long map files")
    ap.add_argument("--maps", nargs="+", default=[], help="lat-long map files (as MAP)")
    ap.add_argument("--samplers", nargs="+",
                    default=["zsobol", "independent", "stratified", "paddedsobol"])
    ap.add_argument("--strategies", nargs="+", default=["mis", "brdf"],
                    choices=("mis", "brdf", "map"))
    ap.add_argument("--spp", nargs="+", type=int, default=[16, 64, 256])
    ap.add_argument("--renders", type=int, default=16, help="render sets (6 views) per cell")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference-sampler", default="zsobol")
    ap.add_argument("--reference-seed", type=int, default=20240)
    ap.add_argument("--resolution", type=int, default=32, help="pixels per view side")
    ap.add_argument("--wavelengths", nargs="+", default=["jitter"],
                    choices=("jitter", "fixed"),
                    help="fixed: --disable-wavelength-jitter (cells and their reference)")
    ap.add_argument("--spectral-renders", type=int, default=2,
                    help="render sets per constant-map cell (0: none)")
    ap.add_argument("--map-file", choices=("asread", "raw"), default="asread",
                    help="convert the map as envfit reads it (negatives clamped) or the file "
                         "as given")
    ap.add_argument("--footprint", type=int, default=2,
                    help="the model's footprint side per pixel of the --resolution sphere "
                         "(1: point normals only)")
    ap.add_argument("--max-level", type=int, default=9)
    ap.add_argument("--normals", type=int, default=256,
                    help="the model's normals (render_check's PRESET_NORMALS is 32: its "
                         "normals' error is about 9 %% of the RMSE on forest64's brdf)")
    ap.add_argument("--repredict", action="store_true",
                    help="predict the saved rows of the maps again (no rendering)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pbrt", default=PBRT, help="the pbrt binary")
    ap.add_argument("--imgtool", default=IMGTOOL, help="pbrt-v4's imgtool binary")
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--out", default="pbrt4_check_out")
    args = ap.parse_args(argv)
    args.maps = [*args.map_files, *args.maps]
    if not args.maps:
        ap.error("give at least one map (MAP or --maps)")
    args.out = Path(args.out)
    args.out.mkdir(parents=True, exist_ok=True)
    render_check.PRESET_NORMALS = args.normals      # the Predictor's normals
    record = get_renderer("pbrt4")
    for s in args.samplers:
        record.sampler(s)
    run = Run(args.out)
    meta = run.doc["meta"]
    meta.update(cpu=_cpu(), renderer="pbrt4", record=record.renderer,
                resolution=args.resolution, reference_spp=args.reference_spp,
                reference_sampler=args.reference_sampler, argv=sys.argv[1:],
                pbrt=str(args.pbrt), footprint=args.footprint, map_file=args.map_file,
                integrators={s: {"type": record.strategy(s).integrator,
                                 **record.strategy(s).settings} for s in args.strategies},
                layout="pbrt images flipped left-right into envfit's views")
    t = time.perf_counter()
    pbrt = Pbrt(args)
    try:
        for spec in args.maps:
            (repredict_map if args.repredict else run_map)(spec, args, run, pbrt, record)
    finally:
        pbrt.close()
    wall = time.perf_counter() - t
    meta.setdefault("runs", []).append({"wall_seconds": wall, "pbrt_renders": pbrt.renders,
                                        "argv": sys.argv[1:]})
    run.write()
    print_table(run.doc)
    print(f"\nCPU: {meta['cpu']}; wall {wall:.0f} s this run ({pbrt.renders} pbrt renders); "
          f"references: {meta.get('reference_seconds', {})}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

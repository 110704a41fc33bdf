r"""``predict_frame``: the predicted noise of a user's frame, read from the renderer's own
scene file, at each spp; the spp that meets a target; the noise image.

Steps: read the scene with the renderer (:mod:`envfit.renderers._frame`), each film point's
moments (:func:`._model.point_moments`), each pixel's MSE under the film's filter
(:func:`._model.pixel_mse`), then the image's RMSE and percentiles per spp.

The image RMSE is over all pixels and the three channels against the converged image:
:math:`\sqrt{\frac{1}{3HW}\sum_{p,c}\mathrm{MSE}_{p,c}(N)}`, and a pixel's RMSE is
:math:`\sqrt{\frac13\sum_c \mathrm{MSE}_{p,c}(N)}`; with the ``independent`` sampler both
fall exactly as :math:`N^{-1/2}`. A sampler whose dimensions are one net per pixel (Mitsuba's
``ldsampler``) is predicted at each spp it runs (:mod:`._nets`), and the answer searched over
those counts up to :data:`NET_TOP`; one that runs any spp (Cycles) at the powers of two, then
at the spp between them their local rate gives and a few above it (:func:`_candidates`), the
answer the smallest spp predicted that meets the target (:func:`_checked_answer`): its error
need not fall smoothly between powers of two (blue noise's runs of one shared sequence).
"""
from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from envfit.base import ParameterError, progress_bar
from envfit.frame._model import (MODELLED_SAMPLERS, film_block, filter_reach, pixel_mse,
                                 point_moments)
from envfit.frame._nets import (LIMITS, net_level, net_sampler, pixel_mse_nets, resolved,
                               scrambles)
from envfit.frame._plan import PixelPlan, film_pixels, plan_pixels
from envfit.renderers import get_renderer

__all__ = ["FrameOptions", "FrameRow", "FramePrediction", "predict_frame", "READERS"]

#: scene file suffix → the renderer that reads it (its folder's ``_frame_scene.read_scene``)
READERS = {".xml": "mitsuba3", ".blend": "cycles"}
#: pixel percentiles reported per spp
PERCENTILES = (50, 90, 99)
#: the largest spp a net sampler's answer is searched to
NET_TOP = 4096


@dataclass(frozen=True)
class FrameOptions:
    """What :func:`predict_frame` is asked.

    Attributes
    ----------
    spp : the sample counts to predict (default: the scene's own).
    target : an image RMSE to meet (absolute, the image's units), or
    target_relative : one relative to the converged image's mean value (default 0.01).
    percentile : meet the target at this percentile of the pixels' RMSE instead of the image
        RMSE (0 < q ≤ 100).
    side : film points per pixel side (S).
    level : the techniques' tables, 4^level points each.
    max_pixels : predict every pixel up to this many, else one per cell of a grid of about
        this many cells (:mod:`._plan`).
    seed : the cells' draws.
    quiet : no progress bar.
    """

    spp: tuple = ()
    target: float | None = None
    target_relative: float | None = None
    percentile: float | None = None
    side: int = 2
    level: int = 4
    max_pixels: int = 16384
    seed: int = 0
    quiet: bool = True

    def __post_init__(self):
        for n in self.spp:
            if int(n) != n or n < 1:
                raise ParameterError(f"spp must be positive integers, got {n}")
        if self.target is not None and self.target_relative is not None:
            raise ParameterError("give target or target_relative, not both")
        for name in ("target", "target_relative"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a positive number, got {v}")
        if self.percentile is not None and not 0 < self.percentile <= 100:
            raise ParameterError(f"percentile must be in (0, 100], got {self.percentile}")
        if not 1 <= self.side <= 16:
            raise ParameterError(f"side must be 1..16, got {self.side}")
        if not 2 <= self.level <= 9:
            raise ParameterError(f"level must be 2..9, got {self.level}")
        if self.max_pixels < 1:
            raise ParameterError(f"max_pixels must be positive, got {self.max_pixels}")


@dataclass(frozen=True)
class FrameRow:
    """One spp: the image RMSE, it relative to the image's mean, the pixels' RMSE
    percentiles, and the relative standard error of the image RMSE where only some pixels
    were predicted (0 when all were)."""

    spp: int
    rmse: float
    relative: float
    percentiles: dict
    rmse_se: float = 0.0


@dataclass(frozen=True)
class FramePrediction:
    """What :func:`predict_frame` answers (see the module docstring for the definitions).

    ``preview`` is the converged image the model implies (H, W, 3), ``mse1`` the per-pixel
    MSE at one spp (H, W, 3) — on the plan's grid of cells where not every pixel was
    predicted (``exact`` false; ``pixels`` were); for a net sampler (not 1/N) ``mse1`` is N ×
    the MSE at the first spp and ``mse_by_spp`` {N: MSE (H, W, 3)} holds every spp
    predicted; ``answer`` the smallest spp meeting the target (None where none does up to
    the search's top), ``below`` the sampler's next smaller spp (where it misses);
    ``notes`` what the model assumed, as sentences."""

    scene: str
    renderer: str
    size: tuple
    sampler: str
    scene_spp: int
    integrator: str
    filter_name: str
    side: int
    level: int
    preview: np.ndarray = field(repr=False)
    mse1: np.ndarray = field(repr=False)
    rows: tuple
    target: float | None
    target_kind: str
    answer: int | None
    notes: tuple
    seconds: dict
    rays: int = 0
    exact: bool = True
    pixels: int = 0
    mean_value: float = 0.0
    """The converged image's mean over pixels and channels (each predicted pixel weighted by
    the pixels it stands for)."""
    mse_by_spp: dict = field(default_factory=dict, repr=False)
    below: int | None = None
    answer_rate: float | None = None
    """Where a net sampler's answer lies past the spp predicted: the RMSE exponent it was
    extrapolated at (None: the answer was predicted)."""

    def pixel_rmse(self, spp: int) -> np.ndarray:
        """Each pixel's predicted RMSE (H, W) at ``spp``."""
        if self.mse_by_spp:
            if int(spp) not in self.mse_by_spp:
                raise ParameterError(f"spp {spp} was not predicted for the {self.sampler} "
                                     f"sampler: one of {sorted(self.mse_by_spp)}")
            return np.sqrt(self.mse_by_spp[int(spp)].mean(axis=2))
        return np.sqrt(self.mse1.mean(axis=2) / int(spp))

    def to_dict(self) -> dict:
        """The JSON form: ``predictions`` = [{"spp", "predicted_rmse", …}, …]."""
        return {"scene": self.scene, "renderer": self.renderer,
                "size": list(self.size), "sampler": self.sampler, "scene_spp": self.scene_spp,
                "integrator": self.integrator, "filter": self.filter_name,
                "film_points_per_side": self.side, "level": self.level,
                "mean_value": self.mean_value,
                "pixels_predicted": self.pixels, "every_pixel": self.exact,
                "predictions": [{"spp": r.spp, "predicted_rmse": r.rmse,
                                 "relative_rmse": r.relative,
                                 "predicted_rmse_relative_se": r.rmse_se,
                                 "pixel_rmse_percentiles": {str(k): v for k, v in
                                                            r.percentiles.items()}}
                                for r in self.rows],
                "target": self.target, "target_kind": self.target_kind,
                "answer_spp": self.answer, "below_spp": self.below,
                "answer_extrapolated_rate": self.answer_rate,
                "notes": list(self.notes),
                "seconds": self.seconds, "shadow_rays": self.rays}


def _reader(path: Path):
    name = READERS.get(path.suffix.lower())
    if name is None:
        raise ParameterError(f"{path}: a frame is read from a scene file "
                             f"({', '.join(READERS)}); this suffix is not one")
    rec = get_renderer(name)
    module = importlib.import_module(rec.harness.rsplit(".", 1)[0] + "._frame_scene")
    return module.read_scene


def _row(plan: PixelPlan, mse: np.ndarray, n: int, mean: float) -> FrameRow:
    v = mse.mean(axis=1)                                       # each target's MSE at n
    img = float(np.sqrt(plan.mean(v)))
    se = plan.standard_error(v) / (2 * plan.mean(v)) if plan.mean(v) > 0 else 0.0
    pix = np.sqrt(v)
    return FrameRow(int(n), img, img / mean if mean > 0 else math.inf,
                    {q: _percentile(pix, q, plan.weights) for q in PERCENTILES}, float(se))


def _percentile(x: np.ndarray, q: float, weights: np.ndarray) -> float:
    """The weighted ``q``-th percentile of ``x`` by the inverted CDF: the smallest value
    whose cumulative weight reaches q % of the total (numpy 2's ``np.percentile(x, q,
    weights=…, method="inverted_cdf")``, written out for numpy 1.24+, which Blender's
    ``bpy`` wheels pin)."""
    order = np.argsort(x, kind="stable")
    cum = np.cumsum(np.asarray(weights, dtype=np.float64)[order])
    i = int(np.searchsorted(cum, q / 100.0 * cum[-1] * (1 - 1e-12), side="left"))
    return float(x[order][min(i, len(x) - 1)])


def _measure(plan: PixelPlan, mse: np.ndarray, percentile) -> float:
    """The image MSE, or the square of the pixels' RMSE at ``percentile``."""
    v = mse.mean(axis=1)
    return float(plan.mean(v)) if percentile is None else _percentile(
        np.sqrt(v), percentile, plan.weights) ** 2


def _answer(plan: PixelPlan, mse1: np.ndarray, target: float, percentile) -> int:
    """The smallest N whose image RMSE (or the pixel percentile's) is ≤ target: exact, as
    the MSE is MSE₁/N."""
    m = _measure(plan, mse1, percentile)
    return max(1, math.ceil(m / (target * target) * (1 - 1e-12)))


def _net_answer(plan: PixelPlan, mse: dict, target: float, percentile, ladder: list):
    """(the smallest spp of ``ladder`` whose measure is ≤ target, the next smaller one, the
    RMSE exponent used past the predicted counts or None): the spp of ``mse`` as predicted;
    past the largest, extrapolated from the last two at their local rate (MSE ∝ N^-a)."""
    have = sorted(mse)
    for i, n in enumerate(have):
        m1 = _measure(plan, mse[n], percentile)
        if m1 <= target * target:
            if not i:
                return n, None, None
            n0, m0 = have[i - 1], _measure(plan, mse[have[i - 1]], percentile)
            a = math.log(m0 / m1) / math.log(n / n0) if m0 > 0 and m1 > 0 else 1.0
            prev = n0                       # between two predicted counts: their local rate
            for x in (x for x in ladder if n0 < x < n):
                if m0 * (n0 / x) ** a <= target * target:
                    return x, prev, None
                prev = x
            return n, prev, None
    if len(have) < 2:
        return None, have[-1], None
    (n0, n1), (m0, m1) = have[-2:], (_measure(plan, mse[n], percentile) for n in have[-2:])
    a = math.log(m0 / m1) / math.log(n1 / n0) if m0 > 0 and m1 > 0 else 1.0
    prev = n1
    for n in (x for x in ladder if x > n1):
        if m1 * (n1 / n) ** a <= target * target:
            return n, prev, a / 2
        prev = n
    return None, prev, a / 2


def _candidates(ladder: list[int], guess: int, predicted) -> list[int]:
    """The spp of ``ladder`` a net sampler's interpolated answer ``guess`` is checked at: it
    and three more spaced geometrically up to the next predicted spp above it (excluded)."""
    top = min(n for n in predicted if n > guess)
    want = {guess * (top / guess) ** (k / 4.0) for k in range(4)}
    return sorted({max(n for n in ladder if n <= w) for w in want} - set(predicted))


def _predict_more(fs, block, plan: PixelPlan, spps: list, level: int, opts):
    """({N: MSE (K, 3)}, shadow rays) of the frame's pixels at more spp ``spps`` (a second
    run of :func:`._nets.pixel_mse_nets` on the same tables' level and seed)."""
    bar = progress_bar(len(plan.targets), desc="frame model (the answer's spp)",
                       quiet=opts.quiet, unit="pixel")
    _, more, rays, _ = pixel_mse_nets(fs, block, plan.targets, spps, level, opts.seed, bar,
                                      base=opts.level)
    bar.close()
    return more, rays


def _checked_answer(plan: PixelPlan, mse: dict, target: float, percentile):
    """(the smallest spp of ``mse`` whose measure is ≤ target, the largest below it):
    :func:`_net_answer` over the spp predicted only (none interpolated)."""
    have = sorted(mse)
    meet = next(n for n in have if _measure(plan, mse[n], percentile) <= target * target)
    return meet, max((n for n in have if n < meet), default=None)


def _predicted(ladder: list[int]) -> list[int]:
    """The counts of ``ladder`` a net sampler's frame is predicted at: all of them, or the
    powers of two where the sampler runs nearly every count (Cycles: any integer) — the
    answer between two is then interpolated at their local rate (:func:`_net_answer`)."""
    if len(ladder) <= 2 * max(1, max(ladder).bit_length()):
        return ladder
    return [n for n in ladder if n & (n - 1) == 0]


def _ladder(spec, top: int) -> list[int]:
    """The spp counts the sampler runs, up to ``top``."""
    out, n = [], 1
    while n <= top:
        r = int(spec.spp(n))
        if r <= top and r not in out:
            out.append(r)
        n = r + 1
    return out


def predict_frame(scene, options: FrameOptions | None = None, **kw) -> FramePrediction:
    """The predicted noise of the frame in the scene file ``scene`` (module docstring).

    Parameters
    ----------
    scene : path of the renderer's scene file (its suffix picks the reader: :data:`READERS`).
    options : :class:`FrameOptions`, or its fields as keywords.

    Examples
    --------
    >>> p = predict_frame("scene.xml", spp=(16, 64))          # doctest: +SKIP
    >>> [(r.spp, round(r.rmse, 4)) for r in p.rows]            # doctest: +SKIP
    [(16, 0.0616), (64, 0.0308)]
    """
    opts = options or FrameOptions(**{k: (tuple(v) if k == "spp" else v) for k, v in kw.items()})
    path = Path(scene)
    read = _reader(path)
    t0 = time.perf_counter()
    fs = read(path)
    spec = net_sampler(fs)
    if fs.sampler not in MODELLED_SAMPLERS and spec is None:
        raise ParameterError(f"the scene's sampler is {fs.sampler}: the frame model predicts "
                             f"the {', '.join(MODELLED_SAMPLERS + ('ldsampler',))} samplers "
                             f"so far")
    plan = plan_pixels(fs.size, opts.max_pixels, opts.seed)
    block = film_block(fs, film_pixels(plan.targets, filter_reach(fs), fs.size), opts.side)
    t1 = time.perf_counter()
    spps = tuple(int(n) for n in opts.spp) or (fs.spp,)
    if spec is None:
        pm = point_moments(fs, block, opts.level, quiet=opts.quiet)
        value, mse1 = pixel_mse(fs, block, pm, plan.targets)
        rays, edges, by_spp = pm.rays, pm.edges, {}
        mse = {n: mse1 / n for n in spps}
    else:
        spps = tuple(dict.fromkeys(int(spec.spp(n)) for n in spps))
        level = net_level(opts.level, spps)
        ladder = _ladder(spec, NET_TOP)
        todo = sorted(set(spps) | {n for n in _predicted(ladder) if n <= resolved(level)})
        bar = progress_bar(len(plan.targets), desc="frame model", quiet=opts.quiet,
                           unit="pixel")
        value, mse, rays, edges = pixel_mse_nets(fs, block, plan.targets, todo, level,
                                                 opts.seed, bar, base=opts.level)
        bar.close()
        mse1 = mse[spps[0]] * spps[0]
        by_spp = mse
    t2 = time.perf_counter()
    mean = float(plan.mean(value).mean())
    rows = tuple(_row(plan, mse[n], n, mean) for n in spps)
    if opts.target is not None:
        target, kind = float(opts.target), "absolute"
    else:
        rel = 0.01 if opts.target_relative is None else float(opts.target_relative)
        target, kind = rel * mean, f"relative {rel:g}"
    rate = None
    if spec is None:
        answer = _answer(plan, mse1, target, opts.percentile) if target > 0 else None
        below = None if answer is None else answer - 1
    else:
        answer, below, rate = _net_answer(plan, by_spp, target, opts.percentile, ladder)
    checked = (spec is not None and answer is not None and rate is None
               and answer not in by_spp)
    extra = _candidates(ladder, answer, by_spp) if checked else []
    if extra:                         # interpolated: predicted at its own spp and above
        more, more_rays = _predict_more(fs, block, plan, extra, level, opts)
        by_spp, rays = {**by_spp, **more}, rays + more_rays
        answer, below = _checked_answer(plan, by_spp, target, opts.percentile)
    notes = list(fs.notes)
    r = max(2, -(-8 // opts.side)) * opts.side
    bsdfs = ", ".join(dict.fromkeys(b.name for b in fs.bsdfs)) or "none"
    notes.append(f"direct lighting from the map ({fs.integrator}); BSDFs: {bsdfs}; "
                 f"{opts.side}×{opts.side} film points per pixel, {r}×{r} in the {edges} "
                 f"pixels a silhouette crosses")
    if spec is not None:
        notes.append(f"{fs.sampler}: " + LIMITS.format(
            r=", ".join(f"{scrambles(n)} at {n} spp" for n in spps), level=level,
            top=max(by_spp), filt="box filter" if fs.film_warp is None else
            f"{fs.film_warp.name}, each sample in its own pixel"))
        if checked:
            notes.append(f"{fs.sampler} runs any spp: predicted at the powers of two, then at "
                         f"the spp their local rate gives and a few above it "
                         f"({', '.join(str(n) for n in extra)}; its error need not fall "
                         f"smoothly between powers of two): the answer is the smallest spp "
                         f"predicted that meets the target, {below} the largest predicted "
                         f"below it; the spp between them are not predicted")
        if rate is not None:
            notes.append(f"past {max(by_spp)} spp the answer is extrapolated from "
                         f"{sorted(by_spp)[-2]} and {max(by_spp)} spp at their local rate, "
                         f"RMSE ∝ spp^-{rate:.2f} (--level {opts.level + 1} predicts to "
                         f"{resolved(net_level(opts.level + 1, spps))} spp)")
    if not plan.exact:
        notes.append(f"{len(plan.targets)} of {fs.width * fs.height} pixels predicted, one "
                     f"drawn in each cell of a {plan.grid[1]}x{plan.grid[0]} grid (seed "
                     f"{opts.seed}): the image RMSE is their estimate, +- its standard error; "
                     f"the noise image has one value per cell")
    return FramePrediction(
        str(path), fs.renderer, fs.size, fs.sampler, fs.spp, fs.integrator, fs.filter_name,
        opts.side, opts.level, plan.image(value), plan.image(mse1), rows, target, kind,
        answer, tuple(notes), {"read": round(t1 - t0, 3), "model": round(t2 - t1, 3)},
        rays, plan.exact, len(plan.targets), mean,
        {n: plan.image(v) for n, v in by_spp.items()}, below, rate)

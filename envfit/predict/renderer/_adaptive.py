r"""A renderer's adaptive sampling on a white diffuse surface: for a noise threshold, the
samples each pixel spends and the error it is left with, predicted by running the renderer's
own stopping test on its own points through the renderer's estimator (the renderer's
:attr:`~envfit.renderers.Renderer.adaptive` rule, read from its source in its folder).

**Why a simulation.** An adaptive pixel stops at the first test whose error estimate falls
below the threshold; the estimate is itself noisy (e.g. the gap between the pixel's mean and
the mean of one half of its samples — for a low-discrepancy pattern that half is a worse
point set than the whole, so the estimate is not the pixel's error) and it is tested at
many sample counts of one growing point set. Its law follows from the points the renderer
draws, so the model draws them: for each normal :math:`n_a` of the importance sample of
:class:`~envfit.predict.renderer._diffuse_model.DiffuseModel` (weights :math:`\varpi_a`) and
each of R pixels with random hashes, the renderer's points of the light and BSDF requests
(:meth:`points`) give the samples :math:`F_j = h_e(u_j) + h_b(u'_j)` of its MIS estimator
(:func:`._integrand_tables.map_values`, :func:`._integrand_tables.bsdf_values`: the
integrand itself at each point, not a table) and their sums in each block of the rule's
``step`` samples. The R pixels of a normal form a √R × √R patch (a torus), on which the
renderer's passes run as its source runs them (:meth:`AdaptiveModel._simulate`): every pixel
samples to the first test; at each test the pixels still sampling are tested at their own
sample counts with the rule's error estimate (:meth:`error`) while the others stay converged;
the neighbourhood filter marks unconverged every pixel near an unconverged one; those take the
next block — so a pixel may pause and resume, and resumes with its own next samples (a
pixel's sample number is its own count, ``src/kernel/film/light_passes.h``:
``film_write_sample``, so its samples are always the first n of its sequence). It keeps
the error of its estimate at the end,
:math:`(\bar F - I(n_a))^2`, I the converged value by the midpoint rule of the technique's own
tables at level ``level``.

.. math::  \mathrm{RMSE}^2 = \frac13\sum_c\sum_a\varpi_a\,\frac1R\sum_r
           (\bar F_{c,r} - I_c(n_a))^2,\qquad
           \overline{\mathrm{spp}} = \sum_a\varpi_a\,\frac1R\sum_r n_r,

averaged over uniform normals as the sphere measurement averages them. The same draws at a
fixed N give the pattern's own MSE (:attr:`AdaptivePrediction.fixed`), which the tests set
against the exact randomisation model (a second algorithm). Every threshold reuses the same
draws (common random numbers), so :meth:`AdaptiveModel.threshold_for` searches them at no new
cost.

**The pixel's footprint** (``sphere_pixels`` = D, the sphere D pixels across as the renders
of :mod:`envfit.renderers` show it): each sample then sees the normal at its own film position
in the pixel (the rule's film points; :func:`._footprint.pixel_footprints` at
:data:`FILM_SIDE` × :data:`FILM_SIDE` sub-positions, moved by the pixel filter's film warp —
the renderer's default filter where it importance-samples one: the sub-positions are its
quantiles), and the converged value is the mean over the filter. Without it every pixel sees
one normal.

What it leaves out: a pixel's neighbours see its normal; the sphere's rim.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError, progress
from envfit.predict.renderer._diffuse_model import DiffuseModel, RendererModelOptions
from envfit.predict.renderer._integrand_tables import (BsdfTable, MapTable, bsdf_values,
                                                       map_values, midpoints)
from envfit.predict.renderer._model_error import model_error

__all__ = ["AdaptiveOptions", "AdaptivePrediction", "AdaptiveModel", "FILM_SIDE"]

#: the sub-positions per side of a pixel at which a sample's normal is taken (its film
#: position's), and those over which the converged value is averaged
FILM_SIDE, TRUTH_SIDE = 16, 4


@dataclass(frozen=True)
class AdaptiveOptions:
    """Settings of :class:`AdaptiveModel`.

    Attributes
    ----------
    normals : K, the normals of the importance sample (:class:`DiffuseModel`'s proposal).
    pool : P, the spherical Fibonacci normals they are drawn from.
    realizations : R, the pixels with random hashes simulated per normal: a square
        √R × √R patch of neighbours.
    level : the midpoint tables (4^level points) of each normal's converged value.
    seed : of the pixels' hashes and their neighbours (``numpy.random.default_rng``).
    pixel_filter : with ``sphere_pixels``, the :class:`~envfit.renderers.FilmWarp` a
        sample's film number moves it by (its sub-positions are the filter's quantiles);
        None (default): the renderer's default filter.
    """

    normals: int = 128
    pool: int = 1024
    realizations: int = 64
    level: int = 8
    seed: int = 0
    pixel_filter: object | None = None

    def __post_init__(self):
        for name, lo, hi in (("normals", 1, 4096), ("pool", 1, 1 << 16),
                             ("realizations", 9, 4096), ("level", 4, 10),
                             ("seed", 0, 2 ** 63 - 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ParameterError(f"{name} must be an integer from {lo} to {hi}, got {v!r}")
        if self.normals > self.pool:
            raise ParameterError("normals must not exceed pool")
        if math.isqrt(self.realizations) ** 2 != self.realizations:
            raise ParameterError(f"realizations must be a square (the pixels of a square "
                                 f"patch), got {self.realizations}")


@dataclass(frozen=True)
class AdaptivePrediction:
    """One threshold's prediction.

    Attributes
    ----------
    threshold : the noise threshold as the user sets it; ``scaled_threshold`` what the test
        compares.
    samples, min_samples : the most samples and the first samples before any test.
    predicted_rmse : √(mean over channels and uniform normals of the pixels' MSE).
    mean_spp : the samples a pixel spends, averaged as the RMSE is.
    spp_percentiles : {5, 25, 50, 75, 95: samples} of the pixels.
    at_most : the share of pixels that reach ``samples`` without passing.
    fixed : {N: RMSE} of the same draws at fixed sample counts (the tests' counts that are
        powers of two, and ``samples``).
    model_se : the relative standard error of ``predicted_rmse`` (normals and pixels drawn).
    sampler, strategy, normals, realizations, seconds : as run.
    """

    threshold: float
    scaled_threshold: float
    samples: int
    min_samples: int
    predicted_rmse: float
    mean_spp: float
    spp_percentiles: dict
    at_most: float
    fixed: dict
    model_se: float | None
    sampler: str
    strategy: str
    normals: int
    realizations: int
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """The JSON form (``renderer.adaptive`` of ``envfit advise --json``)."""
        return {"threshold": self.threshold, "scaled_threshold": self.scaled_threshold,
                "samples": self.samples, "min_samples": self.min_samples,
                "predicted_rmse": self.predicted_rmse, "mean_spp": self.mean_spp,
                "spp_percentiles": {str(k): v for k, v in self.spp_percentiles.items()},
                "at_most": self.at_most, "model_se": self.model_se,
                "fixed": {str(k): v for k, v in self.fixed.items()},
                "sampler": self.sampler, "strategy": self.strategy,
                "normals": self.normals, "realizations": self.realizations}


def _weighted_quantiles(values: np.ndarray, weights: np.ndarray, qs) -> list[float]:
    order = np.argsort(values, kind="stable")
    v, w = values[order], weights[order]
    c = np.cumsum(w) / w.sum()
    return [float(v[min(np.searchsorted(c, q), len(v) - 1)]) for q in qs]


class AdaptiveModel:
    r"""The adaptive sampling of one renderer on one map (module docstring).

    Parameters
    ----------
    envmap : EnvMap
    renderer : Renderer
        A record with an :attr:`~envfit.renderers.Renderer.adaptive` rule.
    sampler : str, optional
        The sampling pattern (default: the rule's first).
    strategy : ``"mis"`` (default) or ``"brdf"``.
    samples : int
        The most samples a pixel takes (the renderer's own default when None).
    min_samples : int
        0: the renderer's automatic rule.
    sphere_pixels : int, optional
        D: the sphere's diameter in pixels — each sample sees the normal at its film position
        (module docstring); None: every pixel a point.
    options : AdaptiveOptions, optional

    Examples
    --------
    >>> import numpy as np
    >>> from envfit.maps import EnvMap
    >>> from envfit.renderers import get_renderer
    >>> m = AdaptiveModel(EnvMap(np.full((8, 16, 3), 0.5)), get_renderer("cycles"),
    ...                   strategy="brdf", samples=256,
    ...                   options=AdaptiveOptions(normals=4, pool=16, realizations=16, level=5))
    >>> p = m.predict(0.01)       # cosine sampling of a constant map: every pixel passes at once
    >>> p.mean_spp, p.predicted_rmse < 1e-6
    (80.0, True)
    """

    def __init__(self, envmap, renderer, *, sampler: str | None = None, strategy: str = "mis",
                 samples: int | None = None, min_samples: int = 0,
                 sphere_pixels: int | None = None, options: AdaptiveOptions | None = None,
                 quiet: bool = True):
        rule = getattr(renderer, "adaptive", None)
        if rule is None:
            raise ParameterError(f"{renderer.display or renderer.name} has no adaptive "
                                 f"sampling modelled")
        if strategy not in ("mis", "brdf"):
            raise ParameterError(f"adaptive sampling is modelled for the strategies mis and "
                                 f"brdf, not {strategy!r}")
        self.rule, self.renderer = rule, renderer
        self.sampler = sampler or rule.samplers[0]
        if self.sampler not in rule.samplers:
            raise ParameterError(f"{renderer.possessive} {rule.name} is modelled for "
                                 f"{' and '.join(rule.samplers)} only, not {self.sampler!r}")
        if sphere_pixels is not None and (isinstance(sphere_pixels, bool) or not isinstance(
                sphere_pixels, (int, np.integer)) or not 4 <= sphere_pixels <= 1 << 16):
            raise ParameterError(f"sphere_pixels must be an integer from 4 to {1 << 16}, got "
                                 f"{sphere_pixels!r}")
        self.strategy = strategy
        self.samples = int(rule.default_samples if samples is None else samples)
        rule.settings(rule.default_threshold, self.samples, min_samples)    # checked early
        self.min_samples = int(min_samples)
        self.options = options or AdaptiveOptions()
        self.quiet = quiet
        diffuse = DiffuseModel(envmap, renderer, options=RendererModelOptions(
            normals=self.options.normals, pool=self.options.pool))
        self._diffuse = diffuse
        self.technique, self.normals, self.weights = (diffuse.technique, diffuse.normals,
                                                      diffuse.weights)
        self.sphere_pixels = sphere_pixels
        self.side = math.isqrt(self.options.realizations)
        self._draws, self._fixed_rmse = None, None
        self.seconds = 0.0

    # ------------------------------------------------------------------ the draws
    def _fractions(self) -> tuple[float, float]:
        """The strategy's sample fractions (emitter, BSDF), as the diffuse model reads them."""
        return self._diffuse._fractions(self.strategy)

    def _samples_at(self, normal, tabs: tuple) -> np.ndarray:
        """F = h_e + h_b (P, C) at the points of ``tabs`` (map table, BSDF table)."""
        fr = self._fractions()
        rad, wb = bsdf_values(self.technique, self.renderer, tabs[1], normal, fr)
        out = rad * wb[:, None]
        if fr[0] > 0:
            h, we = map_values(tabs[0], normal, fr)
            out = out + h * we[:, None]
        return out

    def _samples_seeing(self, normals: np.ndarray, tabs: tuple) -> np.ndarray:
        """F = h_e + h_b (P, C) at the points of ``tabs``, sample p seeing ``normals[p]``:
        the map part's cosine and both MIS weights per sample, the BSDF sample turned into
        the world by each sample's own frame."""
        fr = self._fractions()
        local = tabs[1].local
        frames = np.asarray(self.renderer.tangent_frame(normals))          # (P, 3, 3) rows
        dirs = np.einsum("pi,pij->pj", local, frames)
        look = getattr(self.technique, "eval_pdf", None)
        rad, pe = look(dirs) if look is not None else (self.technique.eval_unit(dirs),
                                                        self.technique.pdf_unit(dirs))
        wb = self.renderer.mis_weights(pe, local[:, 2] / np.pi, self.strategy)[1]
        out = rad * np.asarray(wb)[:, None]
        if fr[0] > 0:
            t = tabs[0]
            cos = np.clip(np.sum(normals * t.directions, axis=1), 0.0, None)
            we = self.renderer.mis_weights(t.pdf, cos / np.pi, self.strategy)[0]
            out = out + t.base * (cos * np.where(t.pdf > 0, we, 0.0))[:, None]
        return out

    def _run(self) -> dict:
        """The draws every threshold reads: per normal and pixel, the sums of its first n
        samples (all of them, and twice the class-A ones) at every n a block of the rule's
        ``step`` samples ends, and each normal's converged value."""
        if self._draws is not None:
            return self._draws
        t0 = time.perf_counter()
        o, n, step = self.options, self.samples, self.rule.step
        rng = np.random.default_rng(o.seed)
        ue, ub, uf = self.rule.points(self.sampler, n, o.realizations, rng, film=True)
        r = o.realizations
        pts = (MapTable.at(self.technique, ue.reshape(-1, 2)),
               BsdfTable.at(self.renderer, ub.reshape(-1, 2)))
        mid = midpoints(o.level)
        grid = (MapTable.at(self.technique, mid), BsdfTable.at(self.renderer, mid))
        edges = np.append(np.arange(0, n, step), n)              # blocks [edges[j], edges[j+1])
        a_mask = self.rule.class_a(n)
        blocks = np.zeros((len(self.normals), r, len(edges) - 1, 3))
        halves = np.zeros_like(blocks)
        truth = np.zeros((len(self.normals), 3))
        feet = None
        if self.sphere_pixels is not None:
            from envfit.predict.renderer._footprint import nearest_views, pixel_footprints
            views = nearest_views(self.normals)
            from envfit.renderers import film_of
            film = film_of(self.renderer, self.options.pixel_filter)
            feet = (pixel_footprints(self.normals, views, self.sphere_pixels, FILM_SIDE, film),
                    pixel_footprints(self.normals, views, self.sphere_pixels, TRUTH_SIDE, film))
            cell = np.clip((uf.reshape(-1, 2) * FILM_SIDE).astype(np.int64), 0, FILM_SIDE - 1)
            at = cell[:, 1] * FILM_SIDE + cell[:, 0]
        for k, normal in enumerate(progress(self.normals, total=len(self.normals),
                                            desc="adaptive model", unit="normal",
                                            quiet=self.quiet)):
            if feet is None:
                f = self._samples_at(normal, pts).reshape(r, n, -1)
                truth_k = self._samples_at(normal, grid).mean(axis=0)
            else:
                f = self._samples_seeing(feet[0][k][at], pts).reshape(r, n, -1)
                truth_k = np.mean([self._samples_at(x, grid).mean(axis=0) for x in feet[1][k]],
                                  axis=0)
            c = f.shape[2]
            blocks[k, :, :, :c] = np.cumsum(f, axis=1)[:, edges[1:] - 1]
            halves[k, :, :, :c] = 2.0 * np.cumsum(f * a_mask[None, :, None],
                                                  axis=1)[:, edges[1:] - 1]
            truth[k, :c] = truth_k
        self._draws = {"edges": edges, "blocks": blocks, "halves": halves, "truth": truth}
        self.seconds += time.perf_counter() - t0
        return self._draws

    def _dilate(self, flag: np.ndarray) -> np.ndarray:
        """Converged only where the whole (2r + 1)² neighbourhood is, on each normal's
        side × side torus of pixels (the rule's filter passes)."""
        side, rad = self.side, self.rule.neighbourhood
        f = flag.reshape(flag.shape[0], side, side)
        out = f.copy()
        for dy in range(-rad, rad + 1):
            for dx in range(-rad, rad + 1):
                if dy or dx:
                    out &= np.roll(f, (dy, dx), axis=(1, 2))
        return out.reshape(flag.shape)

    def _simulate(self, s) -> tuple[np.ndarray, np.ndarray]:
        """(samples spent (K, R), squared error (K, R) averaged over channels) of every
        simulated pixel under the settings ``s``, running the renderer's passes: every pixel
        samples to the first test; at each test the pixels still sampling are tested at their
        own counts, the others stay converged; the neighbourhood filter; the unconverged
        pixels take their next block of samples."""
        d = self._run()
        edges, run, half = d["edges"], d["blocks"], d["halves"]
        ends = edges[1:]                                          # counts a block ends at
        at = np.full(run.shape[:2], int(np.searchsorted(ends, s.checks[0])))
        active = np.ones(run.shape[:2], dtype=bool)
        tests = set(int(c) for c in s.checks)
        for t in range(int(at[0, 0]), len(ends)):                 # the render's passes
            if int(ends[t]) in tests:
                total = np.take_along_axis(run, at[:, :, None, None], axis=2)[:, :, 0]
                halfs = np.take_along_axis(half, at[:, :, None, None], axis=2)[:, :, 0]
                e = self.rule.error(total, halfs, ends[at].astype(np.float64))
                active = ~self._dilate(np.where(active, e < s.scaled_threshold, True))
            if t == len(ends) - 1 or not active.any():
                break
            at = at + active
        total = np.take_along_axis(run, at[:, :, None, None], axis=2)[:, :, 0]
        spent = ends[at].astype(np.float64)
        err = total / spent[:, :, None] - d["truth"][:, None, :]
        return spent, np.mean(err * err, axis=2)

    def _fixed(self) -> dict:
        """{N: RMSE} of the draws at fixed sample counts (every pixel takes the first N)."""
        d = self._run()
        out = {}
        for j, e in enumerate(d["edges"][1:]):
            if (e & (e - 1)) == 0 or e == self.samples:
                err = d["blocks"][:, :, j] / float(e) - d["truth"][:, None, :]
                out[int(e)] = math.sqrt(max(float(self.weights @ np.mean(err * err, axis=(1, 2))),
                                            0.0))
        return out

    # ------------------------------------------------------------------ predictions
    def predict(self, threshold: float) -> AdaptivePrediction:
        """The prediction at one noise threshold (the user's value; 0: automatic)."""
        t0 = time.perf_counter()
        s = self.rule.settings(threshold, self.samples, self.min_samples)
        spent, kept = self._simulate(s)
        w = np.asarray(self.weights, dtype=np.float64)
        mse_k = kept.mean(axis=1)
        mse = float(w @ mse_k)
        r = kept.shape[1]
        draws_se = math.sqrt(float(np.sum(w * w * kept.var(axis=1, ddof=1) / r)))
        se = model_error(w, mse_k, draws_se) if len(w) > 1 else None
        pct = _weighted_quantiles(spent.ravel(), np.repeat(w / r, r),
                                  (0.05, 0.25, 0.5, 0.75, 0.95))
        if self._fixed_rmse is None:
            self._fixed_rmse = self._fixed()
        self.seconds += time.perf_counter() - t0
        return AdaptivePrediction(
            s.threshold, s.scaled_threshold, s.samples, s.min_samples,
            math.sqrt(max(mse, 0.0)), float(w @ spent.mean(axis=1)),
            dict(zip((5, 25, 50, 75, 95), pct)),
            float(w @ (spent >= self.samples).mean(axis=1)), dict(self._fixed_rmse), se,
            self.sampler, self.strategy, len(w), r, self.seconds)

    def threshold_for(self, target_rmse: float, *, lo: float = 1e-4,
                      hi: float = 1.0) -> tuple[float | None, AdaptivePrediction | None]:
        """The largest threshold (to 2 significant digits of its logarithm's grid) whose
        predicted RMSE meets ``target_rmse``, and its prediction; (None, None) when even the
        most samples do not meet it. Bisection in log τ over the same draws."""
        if not target_rmse > 0:
            raise ParameterError(f"the target RMSE must be > 0, got {target_rmse!r}")
        if self.predict(lo).predicted_rmse > target_rmse:
            return None, None
        if self.predict(hi).predicted_rmse <= target_rmse:
            return hi, self.predict(hi)
        a, b = math.log(lo), math.log(hi)
        for _ in range(30):
            m = 0.5 * (a + b)
            if self.predict(math.exp(m)).predicted_rmse <= target_rmse:
                a = m
            else:
                b = m
            if b - a < 0.01:
                break
        tau = float(f"{math.exp(a):.3g}")
        p = self.predict(tau)
        while p.predicted_rmse > target_rmse:                    # rounding up crossed it
            tau = float(f"{tau * 0.99:.3g}")
            p = self.predict(tau)
        return tau, p

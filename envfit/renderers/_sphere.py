r"""The white diffuse sphere seen from six orthographic views: a renderer-independent
measurement of a real renderer's shading error averaged over uniform normals.

Set-up (``/work/shared/notes/real-renderers.md``, issue 24): a unit sphere at the origin, an
orthographic camera on each of ±x, ±y, ±z at distance 3 looking at the origin, covering
:math:`[-1, 1]^2` in its image plane, a box pixel filter (a pixel is the plain mean of its
samples). Pixel (i, j) of an R × R view has the image-plane centre

.. math:: X_j = \frac{2(j + \tfrac12)}{R} - 1, \qquad Y_i = 1 - \frac{2(i + \tfrac12)}{R}

(row 0 at the top), the sphere's point there has the normal
:math:`n = X\,r + Y\,u + z\,v`, :math:`z = \sqrt{1 - X^2 - Y^2}`, with v the view axis, u the
view's up axis and :math:`r = u \times v` its right axis (:data:`VIEWS`). A pixel is **kept**
when its whole square lies on the disk (:math:`(|X| + h)^2 + (|Y| + h)^2 < 1`, h = 1/R the
half pixel) and the view's axis is the nearest of the six to its normal
(:math:`z \ge |X|, |Y|`): the kept pixels of the six views tile the sphere of normals like a
cube map, each normal counted once. The image-plane area :math:`dA` of a pixel covers the
normals' solid angle :math:`d\Omega = dA / (n\cdot v) = dA / z`, so with the weight
:math:`w = 1/z` the weighted mean over kept pixels of any function of the normal is the
midpoint rule of its mean over the sphere (:func:`sphere_mean`).

The error (:func:`sphere_error`): with a render ``img`` at the spp under test and two
reference renders a, b at high spp with their own seeds, the reference is
:math:`\bar r = (a + b)/2`; its own variance per pixel is estimated without bias by
:math:`\tfrac14 (a - b)^2` (:math:`\mathbb E(a-b)^2 = 2\sigma_r^2` and
:math:`\mathrm{Var}\,\bar r = \sigma_r^2/2`) and subtracted:

.. math:: \mathrm{MSE} = \frac{\sum_p w_p\,\big[\overline{(img_p - \bar r_p)^2} -
          \tfrac14\,\overline{(a_p - b_p)^2}\big]}{\sum_p w_p},

the bars the means over the colour channels (RMS over channels, as envfit's predictions);
RMSE = √max(MSE, 0). Its 95 % interval is a percentile bootstrap over the kept pixels (each
pixel an independent estimate: every renderer here randomises per pixel), resampled with a
seeded :class:`numpy.random.Generator`.

Example
-------
>>> g = sphere_geometry(64)
>>> f = lambda n: n[..., 0] ** 2                    # mean of n_x² over the sphere: 1/3
>>> round(sphere_mean(f, g), 2)
0.33
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from envfit.base import ParameterError

__all__ = ["SphereView", "VIEWS", "SphereGeometry", "sphere_geometry", "view_normals",
           "sphere_mean", "SphereError", "sphere_error", "SphereMeasurement", "STRATEGIES",
           "view_seeds", "BOOTSTRAP_RESAMPLES", "measurement", "check_strategy"]

#: the strategies of a direct-lighting estimate: emitter sampling only, BSDF sampling only,
#: both combined by the renderer's MIS
STRATEGIES = ("map", "brdf", "mis")
#: bootstrap resamples of the 95 % interval
BOOTSTRAP_RESAMPLES = 1000


@dataclass(frozen=True)
class SphereView:
    """One orthographic view: ``axis`` v (the camera sits at 3v and looks at the origin),
    ``up`` u (image up) and ``right`` r = u × v (image right), unit world vectors."""

    name: str
    axis: tuple
    up: tuple

    @property
    def right(self) -> tuple:
        return tuple(float(c) for c in np.cross(self.up, self.axis))


#: the six views, ±x, ±y, ±z (up: +z for ±x, +x for ±y, +y for ±z)
VIEWS = (SphereView("+x", (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
         SphereView("-x", (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
         SphereView("+y", (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
         SphereView("-y", (0.0, -1.0, 0.0), (1.0, 0.0, 0.0)),
         SphereView("+z", (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
         SphereView("-z", (0.0, 0.0, -1.0), (0.0, 1.0, 0.0)))


@dataclass(frozen=True)
class SphereGeometry:
    """Per-pixel image-plane geometry of an R × R view (the same for all six): centres X, Y,
    z = n·v (NaN off the sphere), the kept mask and the weights w = 1/z on kept pixels
    (0 elsewhere), all (R, R)."""

    resolution: int
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    keep: np.ndarray
    weight: np.ndarray

    @property
    def kept(self) -> int:
        """Kept pixels per view."""
        return int(self.keep.sum())


#: pixel layouts of :func:`sphere_geometry`
LAYOUTS = ("cube", "disk")


def sphere_geometry(resolution: int, layout: str = "cube") -> SphereGeometry:
    """The :class:`SphereGeometry` of R × R views (module docstring).

    ``layout="cube"`` (default): each normal kept in the view nearest it, weight 1/z — the
    mean over uniform normals (white diffuse: the view does not matter). ``"disk"``: every
    pixel whose square lies on the disk, weight 1 — what an orthographic camera sees of a
    sphere, θ_o = arccos z from 0 to 90° with density ∝ cos θ_o sin θ_o, for a BSDF whose
    error depends on the view (a rough conductor); the six views then show the map from six
    directions.

    >>> g = sphere_geometry(16)
    >>> g.kept, bool(np.all(g.weight[g.keep] >= 1.0))
    (116, True)
    >>> sphere_geometry(16, "disk").kept
    164
    """
    r = int(resolution)
    if r != resolution or r < 4:
        raise ParameterError(f"the view resolution must be an integer >= 4, got {resolution!r}")
    if layout not in LAYOUTS:
        raise ParameterError(f"layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    c = (np.arange(r) + 0.5) / r * 2.0 - 1.0
    X, Y = np.meshgrid(c, -c)
    h = 1.0 / r
    inside = (np.abs(X) + h) ** 2 + (np.abs(Y) + h) ** 2 < 1.0
    r2 = X ** 2 + Y ** 2
    z = np.where(r2 < 1.0, np.sqrt(np.clip(1.0 - r2, 0.0, None)), np.nan)
    if layout == "disk":
        return SphereGeometry(r, X, Y, z, inside, inside.astype(np.float64))
    with np.errstate(invalid="ignore"):
        keep = inside & (z >= np.abs(X)) & (z >= np.abs(Y))
    w = np.where(keep, 1.0 / np.where(keep, z, 1.0), 0.0)
    return SphereGeometry(r, X, Y, z, keep, w)


def view_normals(view: SphereView, geometry: SphereGeometry) -> np.ndarray:
    """World normals (R, R, 3) of the sphere at the pixel centres of ``view``: X r + Y u + z v
    (NaN off the sphere)."""
    r, u, v = (np.asarray(a, dtype=np.float64) for a in (view.right, view.up, view.axis))
    g = geometry
    return g.x[..., None] * r + g.y[..., None] * u + g.z[..., None] * v


def sphere_mean(f, geometry: SphereGeometry) -> float:
    """The weighted mean of f(normal) over the kept pixels of the six views: the midpoint
    rule of f's mean over the unit sphere (module docstring). ``f`` maps (..., 3) → (...)."""
    num = den = 0.0
    for view in VIEWS:
        n = view_normals(view, geometry)[geometry.keep]
        w = geometry.weight[geometry.keep]
        num += float(np.sum(w * f(n)))
        den += float(np.sum(w))
    return num / den


@dataclass(frozen=True)
class SphereError:
    """The measured RMSE over the sphere's normals (:func:`sphere_error`): ``rmse`` and its
    bootstrap 95 % interval [``low``, ``high``], the kept ``pixels`` (all views), the
    reference's own RMS error ``reference_rmse`` (of (a + b)/2: the part subtracted), the
    ``raw_rmse`` before the subtraction, and ``mean_offset``, the weighted mean of
    img − ref relative to the reference's mean: near 0 for an unbiased render, strongly
    negative where a rare event (BSDF rays hitting a small sun) was missed in this render
    — then the measured RMSE is far below its expectation and its interval does not say so
    (a bootstrap over pixels cannot see events that did not happen)."""

    rmse: float
    low: float
    high: float
    pixels: int
    reference_rmse: float
    raw_rmse: float
    mean_offset: float = 0.0


def _stack(images, geometry: SphereGeometry, what: str) -> np.ndarray:
    a = np.asarray(images, dtype=np.float64)
    r = geometry.resolution
    if a.ndim == 3:
        a = a[..., None]
    if a.ndim != 4 or a.shape[:3] != (len(VIEWS), r, r):
        raise ParameterError(f"{what} must be {len(VIEWS)} views of {r}x{r} pixels "
                             f"(6, R, R[, C]), got shape {a.shape}")
    return a


def _bootstrap(d: np.ndarray, w: np.ndarray, rng: np.random.Generator,
               resamples: int) -> tuple[float, float]:
    """2.5 and 97.5 percentiles of Σ w d / Σ w over pixel resamples (with replacement)."""
    n = d.size
    stats = np.empty(resamples)
    chunk = max(1, (1 << 22) // max(n, 1))
    wd = w * d
    for s in range(0, resamples, chunk):
        k = min(chunk, resamples - s)
        idx = rng.integers(0, n, size=(k, n), dtype=np.int32)
        stats[s:s + k] = wd[idx].sum(axis=1) / w[idx].sum(axis=1)
    lo, hi = np.percentile(stats, [2.5, 97.5])
    return float(lo), float(hi)


def sphere_error(images, reference_a, reference_b, geometry: SphereGeometry, *, seed=0,
                 resamples: int = BOOTSTRAP_RESAMPLES, mask=None) -> SphereError:
    r"""The weighted RMSE of ``images`` against the reference (a + b)/2, the reference's own
    variance :math:`\tfrac14(a-b)^2` subtracted, RMS over channels, and its percentile
    bootstrap 95 % interval over the kept pixels (module docstring).

    Parameters
    ----------
    images, reference_a, reference_b : (6, R, R[, C]) renders of the six :data:`VIEWS` (in
        that order); a and b with distinct seeds, at high spp.
    geometry : the views' :class:`SphereGeometry`.
    seed : the bootstrap's seed (an int or a :class:`numpy.random.Generator`).
    resamples : bootstrap resamples.
    mask : optional (R, R) booleans: only the kept pixels where it is True (the same in every
        view), e.g. a band of view angles θ_o = arccos z.

    >>> g = sphere_geometry(8)
    >>> ref = np.ones((6, 8, 8, 3))
    >>> e = sphere_error(ref + 0.1, ref, ref, g)
    >>> round(e.rmse, 12), round(e.low, 12), round(e.high, 12)
    (0.1, 0.1, 0.1)
    """
    img = _stack(images, geometry, "images")
    a = _stack(reference_a, geometry, "reference_a")
    b = _stack(reference_b, geometry, "reference_b")
    if not (img.shape == a.shape == b.shape):
        raise ParameterError(f"images and references differ in shape: {img.shape}, {a.shape}, "
                             f"{b.shape}")
    keep = geometry.keep
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != keep.shape or not np.any(mask & keep):
            raise ParameterError(f"mask must be {keep.shape} booleans selecting kept pixels")
        keep = keep & mask
    ref = 0.5 * (a + b)
    e2 = ((img - ref) ** 2).mean(axis=-1)[:, keep].ravel()
    v = (0.25 * (a - b) ** 2).mean(axis=-1)[:, keep].ravel()
    w = np.broadcast_to(geometry.weight[keep], (len(VIEWS), int(keep.sum()))).ravel()
    if not np.all(np.isfinite(e2)) or not np.all(np.isfinite(v)):
        raise ParameterError("a render holds NaN or Inf on the sphere")
    d = e2 - v
    mse = float(np.sum(w * d) / np.sum(w))
    diff = (img - ref).mean(axis=-1)[:, keep].ravel()
    level = float(np.sum(w * ref.mean(axis=-1)[:, keep].ravel()))
    offset = float(np.sum(w * diff) / level) if level > 0 else 0.0
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    lo, hi = _bootstrap(d, w, rng, int(resamples))
    root = lambda m: float(np.sqrt(max(m, 0.0)))
    return SphereError(rmse=root(mse), low=root(lo), high=root(hi), pixels=int(d.size),
                       reference_rmse=root(float(np.sum(w * v) / np.sum(w))),
                       raw_rmse=root(float(np.sum(w * e2) / np.sum(w))), mean_offset=offset)


def view_seeds(seed, count: int = len(VIEWS)) -> list[int]:
    """``count`` distinct random 31-bit render seeds drawn from ``seed`` (an int or a
    Generator): random, not consecutive (Cycles XORs its seed into each pixel's numbers, so
    consecutive seeds are correlated)."""
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    out: list[int] = []
    while len(out) < count:
        s = int(rng.integers(1, 2 ** 31 - 1))
        if s not in out:
            out.append(s)
    return out


@dataclass(frozen=True)
class SphereMeasurement:
    """A renderer's measured shading error over uniform normals at one configuration.

    Attributes
    ----------
    rmse, low, high : the measured RMSE and its bootstrap 95 % interval (radiance units of
        the map, RMS over channels).
    spp : samples per pixel asked for (the renderer may round it: ``spp_used``).
    renderer, sampler, strategy : e.g. "mitsuba3", "ldsampler", "mis".
    reference_spp : spp of each of the two reference renders.
    pixels : kept pixels (all six views).
    seconds : wall time of the six renders under test; ``view_seconds`` per view.
    reference_rmse : RMS error of the reference (the subtracted part).
    mean_offset : the render's weighted mean minus the reference's, relative
        (:class:`SphereError`: strongly negative = a rare event missed, RMSE unreliable).
    resolution : pixels per view side.
    options : the renderer's other settings (dict).
    """

    rmse: float
    low: float
    high: float
    spp: int
    renderer: str
    sampler: str
    strategy: str
    reference_spp: int
    pixels: int
    seconds: float
    view_seconds: tuple = ()
    reference_rmse: float = 0.0
    mean_offset: float = 0.0
    resolution: int = 0
    spp_used: int = 0
    options: dict | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["view_seconds"] = list(self.view_seconds)
        return d


def measurement(err: SphereError, *, spp: int, renderer: str, sampler: str, strategy: str,
                reference_spp: int, view_seconds, resolution: int, spp_used: int = 0,
                options: dict | None = None) -> SphereMeasurement:
    """A :class:`SphereMeasurement` from a :class:`SphereError` and the render's settings."""
    return SphereMeasurement(rmse=err.rmse, low=err.low, high=err.high, spp=int(spp),
                             renderer=renderer, sampler=sampler, strategy=strategy,
                             reference_spp=int(reference_spp), pixels=err.pixels,
                             seconds=float(sum(view_seconds)),
                             view_seconds=tuple(float(s) for s in view_seconds),
                             reference_rmse=err.reference_rmse,
                             mean_offset=err.mean_offset, resolution=int(resolution),
                             spp_used=int(spp_used or spp), options=dict(options or {}))


def check_strategy(strategy: str) -> str:
    """``strategy`` if it is one of :data:`STRATEGIES`, else :class:`ParameterError`."""
    if strategy not in STRATEGIES:
        raise ParameterError(f"strategy must be one of {', '.join(STRATEGIES)}; got {strategy!r}")
    return strategy

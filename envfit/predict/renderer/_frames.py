r"""The frames (normal, view) a microfacet prediction averages over: the pixels of the rendered
sphere (:func:`pixel_frames`) or views in a band of polar angles with uniformly rotated maps
(:func:`band_frames`); :class:`~envfit.predict.renderer.MicrofacetModel` takes either."""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.predict.renderer._footprint import _unit

__all__ = ["band_frames", "pixel_frames"]


def band_frames(count: int, theta_range=(0.0, 90.0), *, seed=0):
    r"""``count`` frames (normals (K, 3), views (K, 3)) with the view at a polar angle θ_o
    from the normal in ``theta_range`` (degrees), density ∝ cos θ_o sin θ_o there (the
    pixels of an orthographic view of a sphere), the normal uniform on the sphere and the
    view's azimuth uniform — the frames of uniformly rotated maps. Stratified in
    (cos² θ_o, azimuth, normal) by one shuffled Latin hypercube from ``seed``.

    >>> n, v = band_frames(64, (30, 60), seed=1)
    >>> t = np.degrees(np.arccos(np.sum(n * v, axis=1)))
    >>> bool(t.min() >= 30 and t.max() <= 60)
    True
    """
    lo, hi = (float(x) for x in theta_range)
    if not (0.0 <= lo < hi <= 90.0):
        raise ParameterError(f"theta_range must satisfy 0 <= low < high <= 90, got {theta_range}")
    rng = np.random.default_rng(seed)
    k = int(count)
    u = (rng.permuted(np.tile(np.arange(k), (4, 1)), axis=1).T + rng.random((k, 4))) / k
    c2 = np.cos(np.radians(hi)) ** 2 + u[:, 0] * (np.cos(np.radians(lo)) ** 2
                                                 - np.cos(np.radians(hi)) ** 2)
    ct = np.sqrt(c2)                                           # density ∝ cos θ sin θ
    st = np.sqrt(np.clip(1.0 - c2, 0.0, None))
    phi = 2.0 * np.pi * u[:, 1]
    z = 1.0 - 2.0 * u[:, 2]
    a = 2.0 * np.pi * u[:, 3]
    n = np.column_stack([np.sqrt(1 - z * z) * np.cos(a), np.sqrt(1 - z * z) * np.sin(a), z])
    t = _unit(np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])))
    b = np.cross(n, t)
    v = (st * np.cos(phi))[:, None] * t + (st * np.sin(phi))[:, None] * b + ct[:, None] * n
    return n, _unit(v)


def pixel_frames(geometry, views, count: int, *, seed=0):
    r"""``count`` frames drawn from the kept pixels of the sphere renders (``geometry`` from
    :func:`envfit.renderers.sphere_geometry`, ``views`` their :data:`VIEWS`): the
    pixel's normal and its view axis, drawn with probability ∝ the RMSE's pixel weight 1/z
    (systematic sampling, a random start from ``seed``), so the plain mean over the frames
    estimates the measurement's weighted mean. Returns (normals, views, θ_o in degrees)."""
    from envfit.renderers import view_normals
    ns, vs, ws = [], [], []
    for view in views:
        n = view_normals(view, geometry)[geometry.keep]
        ns.append(n)
        vs.append(np.broadcast_to(np.asarray(view.axis, dtype=np.float64), n.shape))
        ws.append(geometry.weight[geometry.keep])
    n, v, w = np.concatenate(ns), np.concatenate(vs), np.concatenate(ws)
    cdf = np.cumsum(w) / w.sum()
    start = np.random.default_rng(seed).random()
    idx = np.minimum(np.searchsorted(cdf, (np.arange(count) + start) / count), len(w) - 1)
    theta = np.degrees(np.arccos(np.clip(np.sum(n[idx] * v[idx], axis=1), -1.0, 1.0)))
    return n[idx], np.ascontiguousarray(v[idx]), theta

r"""Proxies of the second moments of the renderer's sampling techniques, per axis.

:func:`proxy_second_moments` gives, at each axis a, block-quadrature proxies of the squared
error of BRDF sampling (:math:`\int\rho_a Y^2\,d\omega`) and of map importance sampling
(:math:`\int\rho_a^2 Y^2/p\,d\omega`, p the :class:`~envfit.sampling._map_sampler.MapSampler`
pdf); :func:`normalised_moments` turns them into probabilities over the axes. Both the axis
sample of the warped spectra (:func:`envfit.predict.warped._warped_spectrum.proposal_axes`)
and the measurement's axis proposal (:class:`envfit.measure._axis_proposal.AxisProposal`) draw
their axes from them.

>>> from envfit.maps._envmap import EnvMap
>>> from envfit.shading._ground_truth import weight_function
>>> m = EnvMap(np.ones((8, 16, 1)))
>>> m1, m2 = proxy_second_moments(m, MapSampler(m), weight_function("diffuse", 30.0),
...                               np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]))
>>> [round(float(p.sum()), 9) for p in normalised_moments((m1, m2))]
[1.0, 1.0]
"""
from __future__ import annotations

import numpy as np

from envfit.maps import pixel_directions, pixel_solid_angles
from envfit.maps import EnvMap
from envfit.sampling._importance import brdf_pdf
from envfit.sampling._map_sampler import MapSampler

__all__ = ["PROXY_BLOCK", "proxy_second_moments", "normalised_moments"]

#: pixel block of the axis proposal's proxy quadrature
PROXY_BLOCK = 8


def proxy_second_moments(envmap: EnvMap, sampler: MapSampler, weight, axes: np.ndarray):
    r"""Proxies of the squared error of BRDF and map sampling of the luminance at ``axes``
    (K, 3): :math:`\int\rho_a Y^2\,d\omega` and :math:`\int\rho_a^2 Y^2/p\,d\omega` by a
    quadrature on blocks of :data:`PROXY_BLOCK`² pixels (the lobe at the block's centroid of
    :math:`Y^2\omega`, so that a sun smaller than a block is where it is);
    the axes in chunks, so memory stays near 2²² values whatever K and the map's size."""
    h, w = envmap.height, envmap.width
    b = max(1, min(PROXY_BLOCK, h // 4))
    hb, wb = h // b, w // b
    y = np.abs(envmap.luminance())[:hb * b, :wb * b]
    om = pixel_solid_angles(h, w)[:hb * b, :wb * b]
    pdf = sampler.pixel_pdf[:hb * b, :wb * b]
    y2o = (y * y * om).reshape(hb, b, wb, b).sum(axis=(1, 3)).ravel()
    y2op = (y * y * om / np.maximum(pdf, 1e-300)).reshape(hb, b, wb, b).sum(axis=(1, 3)).ravel()
    dirs = pixel_directions(h, w, up=envmap.up)[:hb * b, :wb * b]
    # each block's direction: its centroid of Y²ω (a sun's, in the block holding it), the
    # geometric centre where the block is black
    mass = (y * y * om)[..., None] + 1e-300
    centres = (dirs * mass).reshape(hb, b, wb, b, 3).sum(axis=(1, 3)).reshape(-1, 3)
    centres /= np.linalg.norm(centres, axis=1, keepdims=True)
    axes = np.asarray(axes, dtype=np.float64)
    m1, m2 = np.empty(axes.shape[0]), np.empty(axes.shape[0])
    step = max(1, (1 << 22) // centres.shape[0])
    for i in range(0, axes.shape[0], step):
        rho = brdf_pdf(weight, np.einsum("kc,bc->kb", axes[i:i + step], centres))  # (chunk, blocks)
        m1[i:i + step], m2[i:i + step] = rho @ y2o, (rho * rho) @ y2op
    return m1, m2


def normalised_moments(moments) -> list[np.ndarray]:
    """Each proxy of :func:`proxy_second_moments` (negatives clipped) as probabilities over
    its axes; uniform where a proxy is all zero (a black map)."""
    out = []
    for m in moments:
        m = np.maximum(np.asarray(m, dtype=np.float64), 0.0)
        tot = float(m.sum())
        out.append(m / tot if tot > 0 else np.full(m.shape, 1.0 / m.size))
    return out

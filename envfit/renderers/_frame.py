r"""A user's frame as a renderer reads it: what the frame model (:mod:`envfit.frame`) needs of
each pixel's first hits, of the geometry that can shadow them, of the environment map and of
the sampler, integrator and film.

A renderer's folder fills a :class:`FrameScene` from the renderer's own scene file with the
renderer's own code (Mitsuba 3: :mod:`envfit.renderers.mitsuba3._frame_scene`); the frame
model never reads a scene file itself.

The film points of a pixel are the midpoints of its S × S strata: point (i, j) of pixel
(x, y) lies at film position :math:`(x + (j + \tfrac12)/S,\; y + (i + \tfrac12)/S)` in pixels,
x to the right and y down, as the renderer's film counts them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FrameScene", "Occluder", "HIT_NONE", "HIT_SURFACE"]

#: :attr:`FrameScene.kind` of a film point whose camera ray escapes to the map
HIT_NONE = 0
#: :attr:`FrameScene.kind` of a film point whose camera ray hits a surface
HIT_SURFACE = 1


@dataclass(frozen=True)
class Occluder:
    """One shape as triangles for the shadow rays (world space).

    ``convex``: rays leaving the shape's own surface on its outer side never hit it again
    (a sphere, a disk, a rectangle, a cube), so its own triangles are left out of the shadow
    rays of its points; a general mesh keeps them (with the ray origins offset)."""

    name: str
    vertices: np.ndarray          # (V, 3) float
    faces: np.ndarray             # (F, 3) int
    convex: bool


@dataclass(frozen=True)
class FrameScene:
    r"""The frame's per-film-point first hits and the scene around them.

    Arrays over film points have shape (H, W, S, S, …): pixel row, pixel column, stratum row,
    stratum column.

    Attributes
    ----------
    path : the scene file.
    renderer : the renderer's registry name.
    size : (W, H) pixels.
    side : S, film points per pixel side.
    kind : (H, W, S, S) int8, :data:`HIT_NONE` or :data:`HIT_SURFACE`.
    position : (…, 3) world-space hit point (0 where none).
    normal : (…, 3) shading normal (world).
    geo_normal : (…, 3) geometric normal (world), facing the camera's side.
    tangent : (…, 3, 3) the BSDF's shading frame rows (s, t, n), world.
    albedo : (…, 3) the diffuse reflectance at the hit (textures evaluated by the renderer).
    facing : (…,) bool, the camera sees the BSDF's upper side (cos θ_o > 0).
    shape : (…,) int, the hit shape's index in ``occluders`` (−1 where none).
    background : (…, 3) the map's radiance seen by an escaping camera ray.
    corner_origins : (H + 1, W + 1, 3) the camera rays' origins at the pixel corners.
    corners : (H + 1, W + 1, 3) the camera ray directions at the pixel corners, each divided
        by its component along the camera's axis, so that a direction inside a pixel is the
        bilinear interpolation of its corners' (a pinhole's directions are linear in the film
        position; an orthographic camera's are one direction).
    occluders : the shapes as triangles (:class:`Occluder`).
    envmap_data : (h, w, 3) the map's texels as the emitter holds them.
    envmap_to_world : (3, 3) the emitter's rotation (its ``to_world``).
    envmap_scale : the emitter's radiance scale.
    sampler : the sampler's registry name (``independent``, ``ldsampler``, …).
    spp : the scene's sample count.
    integrator : its name (``direct``, ``path``).
    emitter_samples, bsdf_samples : samples of each technique per spp.
    max_depth : the path length limit (−1: none).
    filter_name : the reconstruction filter's name (``box``, ``gaussian``, …).
    filter_radius : its radius in pixels.
    filter_weights : the filter's 1-D weight at each film point's offset from each pixel
        centre, as a callable of offsets (pixels) — the renderer's own ``eval``.
    hits_at : the first hits at film positions (P, 2) in pixels, by the renderer: a dict of
        the arrays above with shape (P, …) (``kind`` … ``background``).
    notes : what the reader assumed, as sentences.
    """

    path: str
    renderer: str
    size: tuple
    side: int
    kind: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    geo_normal: np.ndarray
    tangent: np.ndarray
    albedo: np.ndarray
    facing: np.ndarray
    shape: np.ndarray
    background: np.ndarray
    corner_origins: np.ndarray
    corners: np.ndarray
    occluders: tuple
    envmap_data: np.ndarray = field(repr=False)
    envmap_to_world: np.ndarray
    envmap_scale: float
    sampler: str
    spp: int
    integrator: str
    emitter_samples: int
    bsdf_samples: int
    max_depth: int
    filter_name: str
    filter_radius: float
    filter_weights: object = field(repr=False)
    hits_at: object = field(repr=False)
    notes: tuple = ()

    @property
    def width(self) -> int:
        return int(self.size[0])

    @property
    def height(self) -> int:
        return int(self.size[1])

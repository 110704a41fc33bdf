r"""A user's frame as a renderer reads it: what the frame model (:mod:`envfit.frame`) needs of
the geometry that can shadow a hit, of the environment map, of the sampler, integrator and
film, and the renderer's own first hits and camera rays at any film position.

A renderer's folder fills a :class:`FrameScene` from the renderer's own scene file with the
renderer's own code (Mitsuba 3: :mod:`envfit.renderers.mitsuba3._frame_scene`); the frame
model never reads a scene file itself.

Film positions are in pixels, x to the right and y down, as the renderer's film counts them:
pixel (x, y) covers [x, x + 1) × [y, y + 1).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FrameScene", "FrameBsdf", "Occluder", "TwoLobes", "HIT_NONE", "HIT_SURFACE"]

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


class TwoLobes:
    """A two-lobe BSDF (``bsdf``: ``eval``, ``pdf``, ``sample(wi, u, u1)`` with the lobe
    number u1, ``sample_square``, ``lobe_probability``) with the frame model's interface:
    ``sample`` draws the lobe and the direction from one point of the square (the i.i.d.
    estimator of an ``independent`` sampler); ``sample_lobe`` draws from one lobe (0: the
    first, where the lobe number is below ``lobe_probability``), its weight the mixture's
    f·cos/pdf — for a sampler whose own points pick the lobe (:mod:`envfit.frame._nets`)."""

    def __init__(self, bsdf):
        self.bsdf, self.alpha = bsdf, bsdf.alpha

    def eval(self, wi, wo):
        return self.bsdf.eval(wi, wo)

    def pdf(self, wi, wo):
        return self.bsdf.pdf(wi, wo)

    def sample(self, wi, u):
        return self.bsdf.sample_square(wi, u)

    def sample_lobe(self, wi, u, lobe: int):
        pick = np.full(len(u), 0.0 if lobe == 0 else np.nextafter(1.0, 0.0))
        return self.bsdf.sample(wi, u, pick)

    def lobe_probability(self, cos_i):
        return self.bsdf.lobe_probability(cos_i)


@dataclass(frozen=True)
class FrameBsdf:
    r"""One shape's BSDF as the frame model evaluates it, in the shading frame (normal +z,
    ``wi`` towards the camera), built by the renderer's folder from its own plugin.

    ``kind``: ``"diffuse"`` (Lambert: the model's cosine tables; ``lobe`` None) or
    ``"glossy"``: ``lobe`` has the renderer's ``eval(wi, wo)`` (f·cos θ_o), ``pdf(wi, wo)``
    and ``sample(wi, u)`` (``wo``, ``weight`` = f·cos/pdf, ``pdf``, the microfacet normal
    ``m``) with a white Fresnel term, and ``fresnel(cos)`` (…, 3) the per-channel factor
    at cos θ = ω_i·m (None: 1). The texture factor (the diffuse or specular reflectance
    at the hit) is the hit's ``albedo``. ``level_extra``: how many grid levels finer than
    the diffuse tables this lobe is tabulated (a sharper lobe needs more points). ``lobes``:
    2 for a BSDF that picks one of two lobes per sample (its ``sample`` draws the lobe from
    u_x, the independent sampler's model)."""

    kind: str
    name: str
    lobe: object = None
    fresnel: object = None
    level_extra: int = 0
    lobes: int = 1


@dataclass(frozen=True)
class FrameScene:
    r"""The scene around the frame's pixels, and the renderer's own first hits on demand.

    Attributes
    ----------
    path : the scene file.
    renderer : the renderer's registry name.
    size : (W, H) pixels.
    occluders : the shapes as triangles (:class:`Occluder`).
    bsdfs : each shape's :class:`FrameBsdf` (the order of ``occluders``).
    draws : the sampler calls (dimension pairs after the film's, call 0) of the first emitter
        and the first BSDF 2-D sample of a spp, as the integrator makes them (None: not
        known for this integrator and sample counts).
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
    filter_weights : the filter's 1-D weight at offsets (pixels) from a pixel's centre, a
        callable of an array — the renderer's own ``eval``.
    film_warp : where the renderer *importance-samples* its filter (Cycles), the
        :class:`~envfit.renderers.FilmWarp` each sample's offset from its pixel's centre
        follows, per axis — the sample then counts in its own pixel only; None: the samples
        are uniform in their pixel and splat with ``filter_weights`` (Mitsuba, pbrt's box).
    hits_at : the first hits of the camera rays at film positions (P, 2) in pixels (x right,
        y down), by the renderer: a dict of arrays (P, …): ``kind`` (int8, :data:`HIT_NONE`
        or :data:`HIT_SURFACE`), ``position`` (world), ``normal`` (shading), ``geo_normal``
        (facing the camera's side), ``tangent`` (the BSDF's frame rows s, t, n), ``wi``
        (towards the camera, in that frame), ``albedo`` (the diffuse reflectance, or a
        glossy lobe's specular reflectance, with its textures), ``facing`` (the camera sees the BSDF's
        upper side), ``shape`` (index in ``occluders``, −1 where none), ``background`` (the
        map's radiance where the ray escapes).
    rays_at : the camera rays at film positions (P, 2): origins (P, 3) and directions
        (P, 3) divided by their component along the camera's axis, so that a direction inside
        a pixel is the bilinear interpolation of its corners' (a pinhole's directions are
        linear in the film position; an orthographic camera's are one direction).
    notes : what the reader assumed, as sentences.
    """

    path: str
    renderer: str
    size: tuple
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
    rays_at: object = field(repr=False)
    notes: tuple = ()
    bsdfs: tuple = ()
    draws: tuple | None = None
    film_warp: object = None

    @property
    def width(self) -> int:
        return int(self.size[0])

    @property
    def height(self) -> int:
        return int(self.size[1])

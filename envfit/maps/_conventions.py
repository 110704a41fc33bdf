r"""Lat-long conventions of renderers: each renderer's direction ↔ pixel formula, and the
conversion of a map in that convention into envfit's (:mod:`envfit.maps._latlong`).

Every convention is written in one canonical form, read off the renderer's source:

.. math::  d_{world} = F\,(\sin\theta\cos\phi,\ \sin\theta\sin\phi,\ \cos\theta),\qquad
           \theta = \pi\,\frac{row + a_r}{H - b_r},\qquad \phi = 2\pi\,\frac{col + a_c}{W - b_c},

with a fixed orthogonal frame ``F`` and one of two pixel grids per axis: **centred**
(``a = ½, b = 0``: pixel centres at half-integers, no row on a pole; envfit, pbrt-v3,
Blender/Cycles) or **endpoints** (``a = 0, b = 1``: first and last row *on* the poles, or
first and last column on the same meridian; OpenEXR's ``LatLongMap``, Mitsuba 3's rows).
``row``/``col`` are continuous pixel coordinates with pixel ``(i, j)`` at ``(i, j)``, row 0
the top row of the file. The renderer's own formula is in each class's docstring, with the
source file and function it was verified against.

=========  =====  ============================================================  ==========
name       up     world direction of pixel (row, col)                           grid
=========  =====  ============================================================  ==========
envfit     +y     (sinθ sinφ, cosθ, −sinθ cosφ), θ = π(r+½)/H, φ = 2π(c+½)/W     centred
openexr    +y     same orientation, θ = π r/(H−1), φ = 2π c/(W−1)               endpoints
usd        +y     = openexr (UsdLuxDomeLight adopts the OpenEXR specification)  endpoints
mitsuba3   +y     same orientation, θ = π r/(H−1), φ = 2π(c+½)/W                rows: ends
pbrt3      +z     (sinθ cosφ, sinθ sinφ, cosθ), θ = π(r+½)/H, φ = 2π(c+½)/W     centred
blender    +z     (−sinθ cosφ, sinθ sinφ, cosθ) (x mirrored), centred grid      centred
pbrt4      —      not lat-long: equal-area square (octahedral) maps; refused     —
=========  =====  ============================================================  ==========

Conversion into envfit's convention (:meth:`LatLongConvention.to_internal`): the internal
map keeps the convention's world frame (its ``up`` is the world axis of the convention's
pole, so ``+z`` for pbrt-v3 and Blender) and has envfit's centred grid. If every internal
pixel centre falls exactly on a pixel of the convention's grid (a permutation or flip of
rows and columns: pbrt-v3, Blender, envfit) the pixels are **permuted**, bit-exactly;
otherwise (OpenEXR, USD, Mitsuba 3) the renderer's bilinear interpolant of the map is
evaluated at the internal pixel centres with ``scipy.ndimage.map_coordinates`` (order 1,
periodic in longitude). Everything downstream (fits, shading, advise) is then unchanged.
The grids, the base class and the conversion are in :mod:`envfit.maps._convention_base`.

Example
-------
>>> import numpy as np
>>> c = convention("pbrt3")
>>> r, col = c.direction_to_pixel([0.0, 0.0, 1.0], 4, 8)       # +z: pbrt-v3's top edge
>>> float(r), float(col)
(-0.5, -0.5)
>>> bool(np.allclose(c.pixel_to_direction(r, col, 4, 8), [0, 0, 1]))
True
>>> sorted(CONVENTIONS)
['blender', 'envfit', 'mitsuba3', 'openexr', 'pbrt3', 'pbrt4', 'usd']
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.maps import _latlong as latlong  # noqa: F401 (EnvfitConvention's doctest)
from envfit.maps._convention_base import (CENTRED, ENDPOINTS, EXACT_TOLERANCE, Grid,
                                          LatLongConvention, NotLatLong)

__all__ = ["Grid", "CENTRED", "ENDPOINTS", "EXACT_TOLERANCE", "LatLongConvention", "NotLatLong",
           "CONVENTIONS", "convention", "convention_names", "lat_long_convention"]


# ---------------------------------------------------------------------------- conventions
class EnvfitConvention(LatLongConvention):
    r"""envfit's own convention (:mod:`envfit.maps._latlong`, ``up="y"``; what ``--up y`` reads).

    ``d = (sinθ sinφ, cosθ, −sinθ cosφ)``, ``θ = π(row+½)/H``, ``φ = 2π(col+½)/W``:
    OpenEXR's orientation on a centred pixel grid (no row on a pole).

    >>> bool(np.allclose(convention("envfit").pixel_directions(4), latlong.pixel_directions(4)))
    True
    """

    name = "envfit"
    renderer = "envfit"
    source = "envfit/maps/_latlong.py"


class OpenEXRConvention(LatLongConvention):
    r"""OpenEXR's latitude-longitude map, exactly as ``ImfEnvmap`` defines it.

    Source: OpenEXR ``src/lib/OpenEXR/ImfEnvmap.h`` (the "Latitude-Longitude Map" comment)
    and ``ImfEnvmap.cpp``, namespace ``LatLongMap``, functions ``latLong(dir)``,
    ``latLong(dataWindow, pixelPosition)``, ``pixelPosition`` and ``direction``
    (AcademySoftwareFoundation/openexr, read at commit 41253757e6bb):

    .. code-block:: text

        latitude  = −π ((y − min.y)/(max.y − min.y) − ½)
        longitude = −2π ((x − min.x)/(max.x − min.x) − ½)
        direction = (sin(lon) cos(lat), sin(lat), cos(lon) cos(lat))
        latLong(dir): lat = asin(dir.y/|dir|), lon = atan2(dir.x, dir.z)

    "Pixel (dataWindow.min.x, dataWindow.min.y) has latitude +pi/2 and longitude +pi;
    pixel (dataWindow.max.x, dataWindow.max.y) has latitude −pi/2 and longitude −pi."
    With the data window ``[0, W−1] x [0, H−1]``, ``θ = π/2 − lat = π row/(H−1)`` and
    ``φ = π − lon = 2π col/(W−1)``: the same orientation as envfit's default
    (``+y`` up, centre column towards ``+z``, φ = π/2 towards ``+x``) but on the
    **endpoint** grid: the first and last rows lie on the poles and the first and last
    columns on the same meridian (``lon = ±π``). Maps are therefore resampled, not
    permuted; the difference from envfit's grid is half a pixel at the edges.

    >>> r, c = convention("openexr").direction_to_pixel([0.0, 0.0, 1.0], 4, 8)   # lat 0, lon 0
    >>> round(float(r), 12), round(float(c), 12)                  # (y, x) = ((H−1)/2, (W−1)/2)
    (1.5, 3.5)
    """

    name = "openexr"
    renderer = "OpenEXR (ImfEnvmap LatLongMap)"
    rows = ENDPOINTS
    cols = ENDPOINTS
    azimuth = (-1.0, np.pi, -np.pi)
    azimuth_label = "longitude = atan2(x, z)"
    source = ("OpenEXR src/lib/OpenEXR/ImfEnvmap.cpp LatLongMap::latLong / pixelPosition / "
              "direction, ImfEnvmap.h")


class USDConvention(OpenEXRConvention):
    r"""USD's ``DomeLight`` with a ``latlong`` texture: the OpenEXR convention.

    Source: the UsdLux schema documentation, ``DomeLight``
    (https://openusd.org/release/user_guides/schemas/usdLux/DomeLight.html): "The dome's
    default orientation is such that its top pole is aligned with the world's +Y axis.
    This adheres to the OpenEXR specification for latitude-longitude maps", followed by the
    OpenEXR text quoted in :class:`OpenEXRConvention`. (``DomeLight_1``, USD 23.11, adds
    ``poleAxis``, whose fallback ``"scene"`` puts the pole on the stage's up axis; this
    convention is the ``+Y`` one, i.e. ``DomeLight`` or ``DomeLight_1`` on a Y-up stage.)
    The formulas are those of :class:`OpenEXRConvention`.

    >>> convention("usd").pixel_to_direction(0.0, 0.0, 4).round(12) + 0.0
    array([0., 1., 0.])
    """

    name = "usd"
    renderer = "USD (UsdLuxDomeLight)"
    source = ("openusd.org usdLux DomeLight schema docs (OpenEXR specification); "
              "formulas of OpenEXR ImfEnvmap.cpp")


class Mitsuba3Convention(LatLongConvention):
    r"""Mitsuba 3's ``envmap`` emitter.

    Source: mitsuba-renderer/mitsuba3 ``src/emitters/envmap.cpp`` (read at commit
    0179ad9f28b5), ``EnvironmentMapEmitter::direction_to_uv``, ``uv_to_direction`` and
    ``eval_spectrum``:

    .. code-block:: text

        direction_to_uv(d) = (atan2(d.x, −d.z) / 2π, acos(d.y) / π)
        uv_to_direction(u, v) = (sin φ sin θ, cos θ, −cos φ sin θ), θ = π v, φ = 2π u
        eval_spectrum: u −= ½/(res.x − 1); uv −= floor(uv); uv *= (res.x − 1, res.y − 1)

    where the texture ``m_data`` is the file plus one periodic column (``res.x = W + 1``),
    so the lookup position is ``(u W − ½, v (H − 1))``, bilinear: columns are centred
    (``φ = 2π(col+½)/W``, as envfit) but rows are on the **endpoint** grid,
    ``θ = π row/(H−1)`` (the first and last rows on the poles; the sampling warp's
    ``sin θ`` uses ``θ = π y/(H−1)`` too). Orientation: envfit's default (``+y`` up).
    Maps are resampled (rows), not permuted.

    >>> float(convention("mitsuba3").direction_to_pixel([0.0, 1.0, 0.0], 5, 10)[0])  # +y: row 0
    0.0
    """

    name = "mitsuba3"
    renderer = "Mitsuba 3 (envmap emitter)"
    rows = ENDPOINTS
    azimuth_label = "2π u = atan2(x, −z) in [0, 2π)"
    source = ("mitsuba3 src/emitters/envmap.cpp EnvironmentMapEmitter::direction_to_uv / "
              "uv_to_direction / eval_spectrum")


class Pbrt3Convention(LatLongConvention):
    r"""pbrt-v3's ``infinite`` light (``InfiniteAreaLight``), ``+z`` up.

    Source: mmp/pbrt-v3 ``src/lights/infinite.cpp`` (read at commit fdc6f73b52ea),
    ``InfiniteAreaLight::Le`` and ``Sample_Li``, and ``src/core/mipmap.h``,
    ``MIPMap::triangle`` (the bilinear lookup):

    .. code-block:: text

        Le:        st = (SphericalPhi(w)/2π, SphericalTheta(w)/π)   (light space)
        Sample_Li: θ = π v, φ = 2π u, wi = LightToWorld(sinθ cosφ, sinθ sinφ, cosθ)
        triangle:  s = st[0]·width − ½, t = st[1]·height − ½

    ``SphericalTheta = acos(w.z)``, ``SphericalPhi = atan2(w.y, w.x)`` in ``[0, 2π)``: the
    centred grid with envfit's ``--up z`` frame (identity), ``θ = π(row+½)/H``,
    ``φ = 2π(col+½)/W``. Converted exactly (the identity permutation, ``up = "z"``).

    >>> convention("pbrt3").exact_indices(2)[1][0].tolist()
    [0, 1, 2, 3]
    """

    name = "pbrt3"
    renderer = "pbrt-v3 (InfiniteAreaLight)"
    frame = np.eye(3)
    azimuth_label = "SphericalPhi = atan2(y, x) in [0, 2π)"
    source = "pbrt-v3 src/lights/infinite.cpp InfiniteAreaLight::Le / Sample_Li, src/core/mipmap.h"


class BlenderConvention(LatLongConvention):
    r"""Blender Cycles' Environment Texture node (equirectangular projection), ``+z`` up.

    Source: blender/blender ``intern/cycles/kernel/camera/projection.h``,
    ``direction_to_equirectangular_range`` and ``direction_to_equirectangular`` (range
    ``(−2π, π, −π, π)``); ``intern/cycles/kernel/svm/image.h``,
    ``svm_node_tex_environment`` (``uv = direction_to_equirectangular(normalize(co))``);
    ``intern/cycles/scene/image_oiio.cpp``, ``oiio_load_pixels`` (the file is read with a
    negative row stride: its **top row becomes v = 1**); and
    ``intern/cycles/kernel/device/cpu/image.h``, ``interp_linear``
    (``x·width − ½``: centred texels):

    .. code-block:: text

        u = (atan2(d.y, d.x) − π)/(−2π) = ½ − atan2(d.y, d.x)/2π
        v = (acos(d.z/|d|) − π)/(−π)    = 1 − acos(d.z)/π

    With file row ``r`` (top = 0) at ``v = 1 − (r+½)/H`` and column ``c`` at
    ``u = (c+½)/W``: ``θ = π(r+½)/H`` and ``atan2(y, x) = π − φ`` with envfit's
    ``φ = 2π(c+½)/W``, i.e. ``d = (−sinθ cosφ, sinθ sinφ, cosθ)``: envfit's ``--up z``
    **mirrored in x**. Both grids are centred, so the conversion is exact: internal
    column ``j`` is Blender column ``W/2 − 1 − j (mod W)``.

    >>> r, c = convention("blender").direction_to_pixel([1.0, 0.0, 0.0], 4, 8)   # u = ½, v = ½
    >>> round(float(r), 12), round(float(c), 12)
    (1.5, 3.5)
    """

    name = "blender"
    renderer = "Blender Cycles (Environment Texture)"
    frame = np.diag([-1.0, 1.0, 1.0])
    azimuth = (-1.0, np.pi, -np.pi)
    azimuth_label = "atan2(y, x)"
    source = ("Blender intern/cycles/kernel/camera/projection.h "
              "direction_to_equirectangular_range; kernel/svm/image.h svm_node_tex_environment; "
              "scene/image_oiio.cpp oiio_load_pixels (rows flipped)")



class Pbrt4Convention(NotLatLong):
    """pbrt-v4's ``infinite`` light reads **equal-area square** maps, not lat-long ones.

    Source: mmp/pbrt-v4 ``src/pbrt/lights.cpp``, ``Light::Create`` (``"infinite"`` with a
    ``filename`` builds an ``ImageInfiniteLight``, whose pixel ``(x, y)`` is the direction
    ``EqualAreaSquareToSphere(((x+½)/W, (y+½)/H))``, Clarberg's octahedral equal-area map)
    and pbrt-v4's README ("the environment map parameterization has also changed (from
    equi-rect to an equi-area mapping); you can upgrade environment maps using
    ``imgtool makeequiarea old.exr --outfile new.exr``"). A 2:1 lat-long file is not such a
    map, so envfit refuses it instead of guessing.

    >>> convention("pbrt4").to_internal(None)
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: --convention pbrt4: pbrt-v4 reads equal-area square (octahedral) environment maps, not lat-long ones; give the lat-long map that pbrt-v4's `imgtool makeequiarea` converts (read it as --convention pbrt3 for pbrt-v3, or envfit)
    """

    name = "pbrt4"
    renderer = "pbrt-v4 (ImageInfiniteLight)"
    reason = ("pbrt-v4 reads equal-area square (octahedral) environment maps, not lat-long "
              "ones; give the lat-long map that pbrt-v4's `imgtool makeequiarea` converts "
              "(read it as --convention pbrt3 for pbrt-v3, or envfit)")
    source = "pbrt-v4 src/pbrt/lights.cpp Light::Create / ImageInfiniteLight; README.md"


#: name → convention (one instance each)
CONVENTIONS: dict[str, LatLongConvention | NotLatLong] = {
    c.name: c() for c in (EnvfitConvention, OpenEXRConvention, USDConvention,
                          Mitsuba3Convention, Pbrt3Convention, BlenderConvention,
                          Pbrt4Convention)}


def convention_names() -> tuple[str, ...]:
    """The accepted names, in the order of :data:`CONVENTIONS`."""
    return tuple(CONVENTIONS)


def convention(name) -> LatLongConvention | NotLatLong:
    """The convention called ``name`` (case-insensitive); :class:`ParameterError` otherwise.

    >>> convention("Mitsuba3").name
    'mitsuba3'
    >>> convention("maya")
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: unknown --convention 'maya'; use one of envfit, openexr, usd, mitsuba3, pbrt3, blender, pbrt4
    """
    key = str(name).strip().lower() if isinstance(name, str) else None
    try:
        return CONVENTIONS[key]
    except KeyError:
        raise ParameterError(f"unknown --convention {name!r}; use one of "
                             f"{', '.join(convention_names())}") from None


def lat_long_convention(which, up: str | None = None) -> LatLongConvention | None:
    """The :class:`~envfit.maps._convention_base.LatLongConvention` ``which`` names (a
    name or a convention object), or None for None; :class:`ParameterError` for an unknown
    name, a convention that is not lat-long (``pbrt4``), or ``up`` given with it (the
    convention fixes the up axis). What :func:`~envfit.maps._io.load_envmap` and
    :func:`~envfit.maps._synth.synthesize_envmap` take.

    >>> lat_long_convention("pbrt3").up
    'z'
    """
    if which is None:
        return None
    conv = convention(which) if isinstance(which, str) else which
    if isinstance(conv, NotLatLong):
        conv.to_internal(None)              # raises its one-line reason
    if not isinstance(conv, LatLongConvention):
        raise ParameterError(f"convention must be a name of envfit.maps.CONVENTIONS or a "
                             f"convention object, got {which!r}")
    if up is not None:
        raise ParameterError(f"up={up!r} and convention={conv.name!r} exclude each other: the "
                             f"convention fixes the up axis (+{conv.up})")
    return conv

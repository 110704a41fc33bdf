r"""What ``envfit info`` says of a map (:func:`describe_envmap`) and what its preview shows:
its pixels tone-mapped in the file's lat-long layout, the angles along its axes in that
layout's terms, and its bright sources with their direction, solid angle and share of the
power (``envfit info --out``, ``envfit synth --out``).

Layout
    A renderer convention of :mod:`envfit.maps._conventions` (``--convention``), or envfit's
    own centred grid with ``--up`` (:func:`envfit_layout`). Row r, column c of the file
    (continuous, pixel centres at integers) have, in the layout's terms,

    .. math::  \theta(r) = \pi\,\frac{r + a_r}{H - b_r}, \qquad
               \phi_R(c) = \sigma\,2\pi\,\frac{c + a_c}{W - b_c} + \phi_0

    (θ from the layout's up axis; φ_R the renderer's own azimuth, sign σ and offset φ_0 of
    :attr:`~envfit.maps._conventions.LatLongConvention.azimuth`, shown wrapped into its
    range): both are affine in the pixel coordinates, so :class:`MapPreview` carries them as
    ``(slope, intercept)`` pairs in degrees.

Tone mapping
    The ``display`` scale of :mod:`envfit.maps._scales` (exposure k = 0.18 / mean luminance,
    clipped to [0, 1], sRGB OETF): the scale every display-referred output of envfit uses.

Sources
    :func:`envfit.maps._bright_sources.find_bright_sources` (connected regions above a robust
    threshold holding at least 5 % of the power, brightest first); each is listed by
    :class:`SourceEntry` with the pixel at which the layout looks its direction up.

Example
-------
>>> from envfit.maps._envmap import EnvMap
>>> x = np.full((8, 16, 3), 1.0); x[2, 4] = 400.0
>>> p = map_preview(EnvMap(x, up="z"))
>>> len(p.sources), round(p.sources[0].share, 3), p.image.shape
(1, 0.819, (8, 16, 3))
>>> round(p.sources[0].position["row"], 2), round(p.sources[0].position["col"], 2)
(2.0, 4.0)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from envfit.base import ParameterError
from envfit.maps import _latlong as latlong
from envfit.maps._conventions import LatLongConvention, convention
from envfit.maps._envmap import EnvMap
from envfit.maps._scales import MIDDLE_GREY, Scale, fit_scale
from envfit.maps._bright_sources import DEFAULT_SHARE, find_bright_sources

__all__ = ["in_convention", "envfit_layout", "SourceEntry", "list_sources", "describe_envmap",
           "MapPreview", "map_preview"]


def in_convention(conv: LatLongConvention, direction, width: int, height: int) -> dict[str, Any]:
    """A world direction in a renderer's terms: θ from its up axis, its own azimuth, and the
    continuous pixel (col, row) of a ``width x height`` file in its layout (JSON-ready).

    >>> v = in_convention(convention("pbrt3"), [0.0, 0.0, 1.0], 8, 4)
    >>> v["theta_deg"], v["col"], v["row"]
    (0.0, -0.5, -0.5)
    """
    theta, phi = conv.angles(direction)
    row, col = conv.direction_to_pixel(direction, height, width)
    return {"name": conv.name, "renderer": conv.renderer, "up": conv.up,
            "theta_deg": float(np.degrees(theta)), "phi_deg": float(np.degrees(phi)),
            "phi_is": conv.azimuth_label, "col": float(col), "row": float(row),
            "source": conv.source}


def envfit_layout(up: str = "y") -> LatLongConvention:
    r"""envfit's own grid (:mod:`envfit.maps._latlong`) with world axis ``up`` at row 0, as a
    convention object: θ = π(r+½)/H from ``up``, φ = 2π(c+½)/W the azimuth in the map's local
    frame (z = up); ``"y"`` is ``convention("envfit")``.

    >>> c = envfit_layout("x")
    >>> bool(np.allclose(c.pixel_directions(4), latlong.pixel_directions(4, up="x")))
    True
    """
    if up == "y":
        return convention("envfit")
    if up not in ("x", "z"):
        raise ParameterError(f"up must be 'x', 'y' or 'z', got {up!r}")
    attrs = {"name": f"envfit --up {up}", "renderer": "envfit",
             "frame": latlong.local_to_world(up), "source": "envfit/maps/_latlong.py",
             "azimuth_label": "phi = atan2(y, x) in the map's local frame (z = up)"}
    return type(f"EnvfitUp{up.upper()}", (LatLongConvention,), attrs)()


@dataclass(frozen=True)
class SourceEntry:
    r"""One bright source of a map, as a preview marks it and ``envfit info`` lists it.

    Attributes
    ----------
    rank : 1 for the most powerful source
    direction : world unit vector (excess-power-weighted mean of its pixel directions)
    solid_angle : equivalent solid angle in sr, :math:`\sum_M (Y - \bar Y)\Omega / (Y_{peak} - \bar Y)`
        (:class:`envfit.maps._bright_sources.BrightSource`)
    share : its luminous power :math:`\sum_M Y\Omega` over the map's :math:`\sum Y\Omega`
    excess_share : the share of its excess over the surrounding background
    pixels : pixels in its region
    position : :func:`in_convention` of ``direction`` in the layout (θ, azimuth, col, row)
    """

    rank: int
    direction: tuple[float, float, float]
    solid_angle: float
    share: float
    excess_share: float
    pixels: int
    position: dict

    @property
    def radius_deg(self) -> float:
        r"""Angular radius of a disc of :attr:`solid_angle`: :math:`\arccos(1 - \Omega/2\pi)`."""
        return float(np.degrees(np.arccos(np.clip(1.0 - self.solid_angle / (2 * np.pi), -1, 1))))

    def label(self) -> str:
        """``"1: theta 34.4, phi 57.3 deg; 0.00785 sr; 47.1 % of the power"`` (a source
        covering a pole: ``"around the +y pole"``, its azimuth being meaningless)."""
        p = self.position
        t = p["theta_deg"]
        where = (f"around the {'+' if t < 90 else '-'}{p['up']} pole"
                 if min(t, 180.0 - t) < self.radius_deg else
                 f"theta {t:.1f}, phi {p['phi_deg']:.1f} deg")
        return (f"{self.rank}: {where}; {self.solid_angle:.3g} sr; "
                f"{100 * self.share:.1f} % of the power")

    def to_dict(self) -> dict:
        """JSON-ready fields (and the angular radius)."""
        return {"rank": self.rank, "direction": list(self.direction),
                "solid_angle": self.solid_angle, "radius_deg": self.radius_deg,
                "share": self.share, "excess_share": self.excess_share, "pixels": self.pixels,
                "position": self.position}


def list_sources(envmap: EnvMap, layout: LatLongConvention | None = None, *,
                 share: float = DEFAULT_SHARE, limit: int = 8) -> tuple[SourceEntry, ...]:
    """The at most ``limit`` most powerful bright sources of ``envmap`` (each holding at
    least ``share`` of the power; :func:`~envfit.maps._bright_sources.find_bright_sources`), with
    their positions in ``layout`` (default: envfit's grid with the map's ``up``)."""
    layout = layout if layout is not None else envfit_layout(envmap.up)
    found = find_bright_sources(envmap, share=share)[:max(int(limit), 0)]
    return tuple(SourceEntry(rank=k + 1, direction=tuple(float(v) for v in s.direction),
                             solid_angle=s.solid_angle, share=s.share,
                             excess_share=s.excess_share, pixels=int(s.mask.sum()),
                             position=in_convention(layout, s.direction, envmap.width,
                                                    envmap.height))
                 for k, s in enumerate(found))


def describe_envmap(m: EnvMap, conv: LatLongConvention | None = None,
                    sources: tuple[SourceEntry, ...] | None = None) -> dict[str, Any]:
    """The statistics ``envfit info`` reports, as a JSON-ready dict: size, per-channel
    min/max/solid-angle mean, mean and largest luminance, dynamic range, the brightest pixel
    (with ``conv``: also in that renderer's terms, :func:`in_convention`) and the bright
    sources (``sources``, default :func:`list_sources` in ``conv``'s layout).

    >>> d = describe_envmap(EnvMap(np.ones((4, 8, 1))))
    >>> d["width"], d["dynamic_range"], d["sources"]
    (8, 1.0, [])
    """
    sources = list_sources(m, conv) if sources is None else sources
    data = m.data
    y = m.luminance()
    flat = int(np.argmax(y))
    row, col = divmod(flat, m.width)
    theta, phi = latlong.pixel_angles(m.height, m.width)
    direction = latlong.pixel_to_direction(row, col, m.height, m.width, up=m.up)
    om = latlong.row_solid_angles(m.height, m.width)
    pos = y[y > 0]
    ymax = float(y.max())
    dr = float(ymax / pos.min()) if pos.size else None
    return {
        "name": m.name,
        "width": m.width,
        "height": m.height,
        "channels": m.channels,
        "dtype": str(data.dtype),
        "up": m.up,
        "min": data.min(axis=(0, 1)).astype(np.float64),
        "max": data.max(axis=(0, 1)).astype(np.float64),
        "mean": m.mean(),
        "mean_luminance": float(om @ y.sum(axis=1) / (om.sum() * m.width)),
        "max_luminance": ymax,
        "dynamic_range": dr,
        "dynamic_range_stops": float(np.log2(dr)) if dr else None,
        "brightest": {
            "row": int(row), "col": int(col),
            "direction": direction,
            "theta_deg": float(np.degrees(theta[row])),
            "phi_deg": float(np.degrees(phi[col])),
            "value": data[row, col].astype(np.float64),
            "convention": (in_convention(conv, direction, m.width, m.height)
                           if conv is not None else None),
        },
        "sources": [e.to_dict() for e in sources],
        "notes": list(m.notes),
    }


@dataclass(frozen=True, eq=False)
class MapPreview:
    """Everything a preview figure draws (module docstring), as plain data.

    Attributes
    ----------
    name, width, height : the map's label and size (W×H)
    image : (H, W, 3) display-referred values in [0, 1], in the layout's pixel order
    layout, renderer, up, azimuth_label : the layout's name, its renderer, its up axis and
        how its azimuth is computed
    theta_of_row : (slope, intercept) in degrees: θ(r) = slope·r + intercept
    phi_of_col : (slope, intercept) in degrees: φ_R(c), unwrapped
    phi_low : the azimuth's range is [phi_low, phi_low + 360) degrees
    exposure : the display exposure k
    sources : :class:`SourceEntry` tuple, most powerful first
    brightest : (col, row) of the brightest pixel in the layout
    share : the smallest share of the power a listed source holds
    """

    name: str
    width: int
    height: int
    image: np.ndarray
    layout: str
    renderer: str
    up: str
    azimuth_label: str
    theta_of_row: tuple[float, float]
    phi_of_col: tuple[float, float]
    phi_low: float
    exposure: float
    sources: tuple[SourceEntry, ...]
    brightest: tuple[float, float]
    share: float


def _display_scale(envmap: EnvMap) -> Scale:
    """The display scale of the map; exposure 1 for a map without positive luminance."""
    try:
        return fit_scale("display", envmap)
    except ParameterError:
        return Scale("display", exposure=1.0, reference_mean_luminance=MIDDLE_GREY)


def _rgb(values: np.ndarray) -> np.ndarray:
    """(H, W, 3): the first three channels, or one channel as grey."""
    return values[..., :3] if values.shape[-1] >= 3 else np.repeat(values[..., :1], 3, axis=-1)


def _axis_maps(layout: LatLongConvention, height: int, width: int):
    """θ(row) and φ_R(col) as (slope, intercept) pairs in degrees, and φ_R's lower bound."""
    a_r, b_r = layout.rows.offset, layout.rows.shrink
    a_c, b_c = layout.cols.offset, layout.cols.shrink
    sign, offset, low = layout.azimuth
    theta = (180.0 / (height - b_r), 180.0 * a_r / (height - b_r))
    phi = (sign * 360.0 / (width - b_c), sign * 360.0 * a_c / (width - b_c) + np.degrees(offset))
    return theta, phi, float(np.degrees(low))


def map_preview(envmap: EnvMap, conv: LatLongConvention | None = None, *,
                share: float = DEFAULT_SHARE, limit: int = 8,
                sources: tuple[SourceEntry, ...] | None = None) -> MapPreview:
    """The preview of ``envmap`` (envfit's grid, as loaded) in the layout ``conv`` (a
    renderer convention; None: envfit's grid with the map's ``up``): the pixels moved into
    the layout (:meth:`~envfit.maps._conventions.LatLongConvention.from_internal`; envfit's
    own grid as it is), tone-mapped by the display scale; the axis maps; the sources
    (:func:`list_sources` with ``share`` and ``limit``, unless ``sources`` gives them, listed
    in the same layout) and the brightest pixel in the layout's pixel coordinates."""
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    layout = conv if conv is not None else envfit_layout(envmap.up)
    h, w = envmap.height, envmap.width
    pixels = envmap.data if conv is None else layout.from_internal(envmap)
    scale = _display_scale(envmap)
    row, col = divmod(int(np.argmax(envmap.luminance())), w)
    bright = layout.direction_to_pixel(latlong.pixel_to_direction(row, col, h, w, up=envmap.up),
                                       h, w)
    theta, phi, low = _axis_maps(layout, h, w)
    return MapPreview(name=envmap.name, width=w, height=h,
                      image=_rgb(scale.apply(np.asarray(pixels, dtype=np.float64))),
                      layout=layout.name, renderer=layout.renderer, up=layout.up,
                      azimuth_label=layout.azimuth_label, theta_of_row=theta, phi_of_col=phi,
                      phi_low=low, exposure=scale.exposure,
                      sources=(list_sources(envmap, layout, share=share, limit=limit)
                               if sources is None else tuple(sources)),
                      brightest=(float(bright[1]), float(bright[0])), share=float(share))

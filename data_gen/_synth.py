r"""The synthetic map kinds by name: :data:`SYNTH_KINDS` (a registry of :class:`SynthKind`) and
one dispatcher, :func:`synthesize` — what ``envfit synth --kind`` writes.

=========  ==================================================================  ==============
kind       the map (local frame, z up)                                         offset 'auto'
=========  ==================================================================  ==============
gp         ``offset + amplitude·f``, f a GP sample of covariance              ``−min f' +
           :math:`K_{gd}^{(s_0)}` (Eq. 8; :func:`gaussian_process_map`)         0.1 (max − min)``
sun-gp     a disc of known radiance on such a background                      4·amplitude,
           (:func:`~envfit.data_gen._sun_gp.sun_gp_map`)                       raised if < 0
constant   :class:`ConstantMap` (``value``)                                   —
sky        :class:`SkyGradientMap` (``horizon``, ``zenith``)                  —
sun        :class:`SunSkyMap` (``sun_*``, ``sky``)                             —
step       :class:`StepMap` (``low``, ``high``, ``theta_edge``)                —
marker     :func:`~envfit.data_gen._marker.marker_map` at ``directions``       —
=========  ==================================================================  ==============

The offset policies (:class:`OffsetPolicy`): with ``offset="auto"`` a GP map is made
positive after the sample, ``offset = −min f + 0.1 (max f − min f)`` (f the zero-mean
sample); a sun-on-GP map gets the background offset ``4·amplitude`` (four standard
deviations of a unit process's pixel values are rarely exceeded) and, if a pixel is still
negative, the whole map is lifted by ``−min f + 0.1·offset``. A number is used as it is.

Colours (``value``, ``horizon``, ``sun_radiance``, …) are a number or one value per channel;
a one-element sequence is that number.

Example
-------
>>> m = synthesize("sky", 4, horizon=1.0, zenith=2.0)
>>> m.data.shape, m.to_dict()["map"]
((4, 8, 1), 'SkyGradientMap(horizon=1.0, zenith=2.0)')
>>> sorted(SYNTH_KINDS["gp"].params)
['amplitude', 'channels', 'method', 'offset', 's0']
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping

import numpy as np

from envfit.data_gen import _sht as sht
from envfit.data_gen._analytic import (AnalyticMap, ConstantMap, SkyGradientMap, StepMap,
                                       SunSkyMap)
from envfit.data_gen._errors import SyntheticMapError
from envfit.data_gen._gp import gaussian_process_map
from envfit.data_gen._marker import MARKERS, marker_map
from envfit.data_gen._sun_gp import SunGPOptions, SunRecord, sun_gp_map

__all__ = ["OffsetPolicy", "SynthKind", "SynthesizedMap", "SYNTH_KINDS", "synthesize",
           "synth_kind_names"]

#: the frame the sun of a sun-gp map is given in (its record's ``sun_frame``)
SUN_FRAME = "local (z up; the written map's world frame by its up axis)"


@dataclass(frozen=True)
class OffsetPolicy:
    """How ``offset="auto"`` is resolved: ``before(amplitude)`` is the offset the generator
    adds, ``lift(min, max, offset)`` what is added to the whole map after it (0: nothing);
    the recorded offset is their sum."""

    description: str
    before: Callable[[float], float]
    lift: Callable[[float, float, float], float]

    def resolve(self, make: Callable[[float], tuple], amplitude: float, offset):
        """``make(offset)`` → ``(f, ...)`` with the offset resolved; returns
        ``(f + lift, offset + lift, ...rest)``."""
        if offset != "auto":
            return (*make(float(offset)), float(offset))
        first = self.before(amplitude)
        f, *rest = make(first)
        lift = self.lift(float(f.min()), float(f.max()), first)
        if lift:
            f, first = f + lift, first + lift
        return (f, *rest, first)


GP_OFFSET = OffsetPolicy(
    "every pixel positive: offset = -min f + 0.1 (max f - min f) after the sample",
    before=lambda amplitude: 0.0,
    lift=lambda lo, hi, offset: float(-lo + 0.1 * (hi - lo)))

SUN_GP_OFFSET = OffsetPolicy(
    "4 x amplitude, raised by -min f + 0.1 offset if a pixel would be negative",
    before=lambda amplitude: 4.0 * amplitude,
    lift=lambda lo, hi, offset: float(-lo + 0.1 * offset) if lo < 0 else 0.0)


@dataclass(frozen=True)
class SynthesizedMap:
    """A synthesized map and how it was made.

    Attributes
    ----------
    data : (H, 2H, C) float64 in the local frame (``marker``: at the directions given)
    kind, height : the kind's name and H
    record : the parameters as used, JSON-ready (the offset resolved; an analytic map's
        ``repr``; a sun-gp map's sun), in the order :meth:`to_dict` gives them
    analytic : the :class:`AnalyticMap` of an analytic kind (its closed-form integrals)
    sun : the :class:`SunRecord` of a sun-gp map
    """

    data: np.ndarray
    kind: str
    height: int
    record: dict = field(default_factory=dict)
    analytic: AnalyticMap | None = None
    sun: SunRecord | None = None

    def to_dict(self) -> dict[str, Any]:
        """``{"kind", "height", **record}``, what ``envfit synth --json`` starts with."""
        return {"kind": self.kind, "height": self.height, **self.record}


@dataclass(frozen=True)
class SynthKind:
    """One kind of :data:`SYNTH_KINDS`: its parameters (name → default), its offset policy
    (None: no offset) and its factory ``make(height, seed, params) -> SynthesizedMap``."""

    name: str
    summary: str
    params: Mapping[str, Any]
    make: Callable[[int, Any, dict], SynthesizedMap]
    offset: OffsetPolicy | None = None


def _colour(v):
    """A colour as the analytic maps take it: a number, or a tuple of one value per channel
    (a one-element sequence is its number)."""
    if np.ndim(v) == 0:
        return v
    v = list(v)
    return v[0] if len(v) == 1 else tuple(v)


def _gp(height: int, seed, p: dict) -> SynthesizedMap:
    def make(offset):
        return (gaussian_process_map(p["s0"], height, seed=seed, channels=p["channels"],
                                     scale=p["amplitude"], method=p["method"]) + offset,)
    f, offset = GP_OFFSET.resolve(make, p["amplitude"], p["offset"])
    return SynthesizedMap(f, "gp", height, dict(
        s0=p["s0"], seed=seed, channels=p["channels"], offset=offset,
        amplitude=p["amplitude"], method=p["method"]))


def _sun_gp(height: int, seed, p: dict) -> SynthesizedMap:
    def make(offset):
        return sun_gp_map(height, seed=seed, s0=p["s0"], sun_theta=p["sun_theta"],
                          sun_phi=p["sun_phi"], sun_radius=p["sun_radius"],
                          sun_radiance=_colour(p["sun_radiance"]), channels=p["channels"],
                          offset=offset, scale=p["amplitude"],
                          options=SunGPOptions(method=p["method"]))
    f, sun, offset = SUN_GP_OFFSET.resolve(make, p["amplitude"], p["offset"])
    return SynthesizedMap(f, "sun-gp", height, dict(
        s0=p["s0"], seed=seed, channels=p["channels"], offset=offset,
        amplitude=p["amplitude"], method=p["method"], sun_frame=SUN_FRAME,
        sun={k: np.asarray(getattr(sun, k)).tolist() for k in
             ("direction", "theta", "phi", "radius", "radiance", "solid_angle",
              "rendered_solid_angle")}), sun=sun)


def _analytic(build: Callable[[dict], AnalyticMap], kind: str):
    def make(height: int, seed, p: dict) -> SynthesizedMap:
        m = build({k: _colour(v) for k, v in p.items()})
        return SynthesizedMap(m.render(height), kind, height, {"map": repr(m)}, analytic=m)
    return make


def _marker(height: int, seed, p: dict) -> SynthesizedMap:
    radius = p["marker_radius"] if p["marker_radius"] is not None else 3.0 * np.pi / height
    dirs = sht.grid_directions(height) if p["directions"] is None else p["directions"]
    f = marker_map(dirs, radius)
    return SynthesizedMap(f, "marker", height, {
        "marker_radius": radius,
        "markers": {label: {"axis": list(axis), "colour": list(colour), "amplitude": amp}
                    for label, axis, colour, amp in MARKERS}})


_GP_PARAMS = {"s0": 1.5, "channels": 3, "method": "sht", "offset": "auto", "amplitude": 1.0}
_SUN = {"sun_theta": 0.6, "sun_phi": 1.0, "sun_radius": 0.05, "sun_radiance": 200.0}


def _kinds() -> dict[str, SynthKind]:
    kinds = (
        SynthKind("gp", "Gaussian-process sample of covariance K_gd^(s0) (Eq. 8)",
                  _GP_PARAMS, _gp, GP_OFFSET),
        SynthKind("sun-gp", "a sun of known radiance and radius on a GP background",
                  {**_GP_PARAMS, **_SUN}, _sun_gp, SUN_GP_OFFSET),
        SynthKind("constant", "a constant map", {"value": 1.0},
                  _analytic(lambda p: ConstantMap(p["value"]), "constant")),
        SynthKind("sky", "a sky gradient from the horizon to the zenith",
                  {"horizon": (0.6, 0.7, 0.8), "zenith": (0.2, 0.35, 0.9)},
                  _analytic(lambda p: SkyGradientMap(p["horizon"], p["zenith"]), "sky")),
        SynthKind("sun", "a sun disc on a constant sky", {**_SUN, "sky": (0.5, 0.6, 0.9)},
                  _analytic(lambda p: SunSkyMap(**p), "sun")),
        SynthKind("step", "two values either side of a polar angle",
                  {"low": 0.1, "high": 1.0, "theta_edge": np.pi / 2},
                  _analytic(lambda p: StepMap(p["low"], p["high"], p["theta_edge"]), "step")),
        SynthKind("marker", "the self-check map: a marker of its own colour at each world axis",
                  {"marker_radius": None, "directions": None}, _marker))
    return {k.name: SynthKind(k.name, k.summary, MappingProxyType(dict(k.params)), k.make,
                              k.offset) for k in kinds}


#: kind name → :class:`SynthKind`, in the order ``envfit synth --kind`` lists them
SYNTH_KINDS: Mapping[str, SynthKind] = MappingProxyType(_kinds())


def synth_kind_names() -> tuple[str, ...]:
    """The kinds' names, in the order of :data:`SYNTH_KINDS`."""
    return tuple(SYNTH_KINDS)


def synthesize(kind: str, height: int, seed=0, **params) -> SynthesizedMap:
    """The map of kind ``kind`` (:data:`SYNTH_KINDS`) with ``height`` rows (width 2H).

    Parameters
    ----------
    kind : a name of :data:`SYNTH_KINDS`.
    height : H ≥ 2.
    seed : the random kinds' seed (anything ``numpy.random.default_rng`` takes).
    **params : the kind's parameters (``SYNTH_KINDS[kind].params``: name → default); one
        the kind does not take is an error.

    Raises :class:`SyntheticMapError` (a ``ValueError``; the generators' own errors too) for
    an unknown kind or parameter, or a bad value.

    >>> synthesize("constant", 2, value=(1.0, 2.0)).data[0, 0].tolist()
    [1.0, 2.0]
    """
    spec = SYNTH_KINDS.get(kind)
    if spec is None:
        raise SyntheticMapError(f"unknown synthetic map kind {kind!r}; use one of "
                                f"{', '.join(SYNTH_KINDS)}")
    unknown = sorted(set(params) - set(spec.params))
    if unknown:
        raise SyntheticMapError(f"kind {kind!r} takes no parameter {', '.join(unknown)}; its "
                                f"parameters: {', '.join(spec.params) or 'none'}")
    h = sht._check_height(height)
    if h < 2:
        raise SyntheticMapError(f"map height must be at least 2, got {height!r}")
    return spec.make(h, seed, {**spec.params, **params})

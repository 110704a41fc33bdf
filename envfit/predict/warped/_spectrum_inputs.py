r"""What the warped spectra of one map share across techniques and lobes, owned by one object.

The spectra of BRDF sampling, map sampling and MIS on one map (:func:`._warped_spectrum.
warped_spectrum`) need the same expensive pieces, each a function of the map, its sampler
and at most the lobe or the box:

* the map technique's quadrature nodes (:class:`._box_spectra._MapNodes`, ~100 bytes per
  node, 1.5 M of them on a 1024×512 map at G = 512) — per box B, for every lobe;
* the pixel quadrature of direction space (:class:`._pixel_moments._Pixels`) — per
  subdivision, which depends on the lobe's width;
* the exact means over axes of BRDF and map sampling's variances
  (:func:`._pixel_moments.exact_mean_variances`, an SH integration at 2048 axes) — per lobe;
* the proxies of the axis proposal (:mod:`._axis_proposal`) — per lobe;
* the lobe technique's grid of directions (:class:`._box_spectra._Grid`) — per lobe and G.

A :class:`SpectrumInputs` is built once from (envmap, sampler) and computes each piece on
first use, keeping the last one of each kind for the object's lifetime (as the spectra of one
map and lobe need them): a caller that builds several spectra of one map passes the same
object to each call and drops it after (its memory goes with it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.sampling import MapSampler
from envfit.predict.warped._axis_proposal import _pool_moments, _systematic
from envfit.predict.warped._box_spectra import _Grid, _MapNodes
from envfit.predict.warped._pixel_moments import _Pixels, _subdivision, exact_mean_variances

__all__ = ["SpectrumInputs"]


def _lobe_key(weight) -> tuple:
    """A lobe's identity: its class and shininess (the weight functions hold nothing else)."""
    return type(weight).__name__, getattr(weight, "shininess", None)


@dataclass(frozen=True, eq=False)
class SpectrumInputs:
    """The pieces the spectra of ``envmap`` sampled by ``sampler`` share (module docstring),
    each computed on first use and kept (the last one of each kind).

    >>> import numpy as np
    >>> from envfit.shading import weight_function
    >>> m = EnvMap(np.ones((8, 16, 1)))
    >>> inputs = SpectrumInputs.of(m)
    >>> inputs.nodes(4) is inputs.nodes(4), inputs.nodes(4) is inputs.nodes(8)
    (True, False)
    >>> A, w = inputs.axes(weight_function("diffuse", 30.0), 16)
    >>> A.shape
    (16, 3)
    """

    envmap: EnvMap
    sampler: MapSampler
    _memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def of(cls, envmap: EnvMap, sampler: MapSampler | None = None) -> "SpectrumInputs":
        """The inputs of ``envmap`` and its ``sampler`` (the sampler's defaults when None).

        Raises
        ------
        envfit.base.ParameterError
            ``envmap`` is not an :class:`~envfit.maps.EnvMap`.
        """
        if not isinstance(envmap, EnvMap):
            raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
        return cls(envmap, MapSampler(envmap) if sampler is None else sampler)

    def check(self, envmap: EnvMap, sampler: MapSampler | None) -> None:
        """Raise :class:`~envfit.base.ParameterError` unless these are the inputs of
        ``envmap`` and ``sampler`` (None: any)."""
        if envmap is not self.envmap or (sampler is not None and sampler is not self.sampler):
            raise ParameterError("the spectrum inputs were built for another map or sampler "
                                 "(SpectrumInputs.of(envmap, sampler))")

    def _get(self, kind: str, key: tuple, make):
        """``make()`` for ``key``, kept as this ``kind``'s one piece: a piece of another key
        of the same kind is freed first (a caller alternating between lobes recomputes,
        but the memory never holds two pixel quadratures or two node sets)."""
        hit = self._memo.get(kind)
        if hit is not None and hit[0] == key:
            return hit[1]
        self._memo.pop(kind, None)
        value = make()
        self._memo[kind] = (key, value)
        return value

    def nodes(self, band: int) -> _MapNodes:
        """The map technique's quadrature nodes for box B = ``band``."""
        return self._get("nodes", (int(band),),
                         lambda: _MapNodes(self.envmap, self.sampler, int(band)))

    def subdivision(self, weight) -> int:
        """The pixel subdivision of direction-space quadrature for the lobe ``weight``."""
        return _subdivision(self.envmap, weight)

    def pixels(self, weight) -> _Pixels:
        """The direction-space quadrature nodes for the lobe ``weight``."""
        sub = self.subdivision(weight)
        return self._get("pixels", (sub,), lambda: _Pixels(self.envmap, self.sampler, sub))

    def exact(self, weight) -> dict:
        """:func:`._pixel_moments.exact_mean_variances` of the lobe ``weight``."""
        key = (_lobe_key(weight), self.subdivision(weight))
        return self._get("exact", key, lambda: exact_mean_variances(
            self.envmap, self.pixels(weight), weight))

    def lobe_grid(self, weight, g: int) -> _Grid:
        """The lobe technique's g×g grid of directions for the lobe ``weight``."""
        return self._get("grid", (_lobe_key(weight), int(g)), lambda: _Grid(weight, int(g)))

    def axes(self, weight, count: int):
        """:func:`._axis_proposal.proposal_axes` for the lobe ``weight``: (axes (count, 3),
        weights (count,)), the proposal's proxies computed once per lobe."""
        moments = self._get("proxy", _lobe_key(weight),
                            lambda: _pool_moments(self.envmap, self.sampler, weight))
        return _systematic(moments, count)

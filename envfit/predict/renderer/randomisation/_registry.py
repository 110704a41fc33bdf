r"""The registry of randomisations (as colour-science's method registries) and its dispatcher
:func:`randomised_mse`: one name per way a renderer randomises the N points of a pixel, each
taking the same :class:`DyadicGrid` of the warped integrand.

* ``independent`` — i.i.d. uniform points;
* ``jittered`` — r × r strata with fresh uniform jitter, option ``r``; or a sampler's own
  x × y strata, option ``strata``; or envfit's rows, ``layout="rows"``;
* ``cmj`` — correlated multi-jittering, options ``nx``, ``ny`` and ``permutations``
  (``"uniform"``, Kensler's algorithm; or a sampler's hashed permutations, a
  :class:`~envfit.renderers.PermutationLaw`);
* ``digital_shift`` — a random XOR shift of a digital net, option ``net``;
* ``owen`` — nested uniform scrambling of a digital net, option ``net``;
* ``cp_shift`` — a Cranley–Patterson shift of a point set, options ``points``, ``net``
  (also envfit's own rules);
* ``orthogonal`` — a Bose orthogonal array of strength 2 with permuted strata and jitter,
  option ``dimension``;
* ``shared_sequence`` — one fixed scrambled sequence shared by every pixel, each pixel a run
  of it (drawn), options ``points`` (the sampler's runs), ``stream``, ``draws``, ``seed``.

A renderer's sampler names its randomisation (:attr:`envfit.renderers.SamplerSpec.randomisation`)
and its options (:attr:`~envfit.renderers.SamplerSpec.options`); which sampler is which is in
the renderer's folder.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from envfit.base import ParameterError

from ._cmj import cmj_mse
from ._cp_shift import cp_shift_mse
from ._digital_shift import digital_shift_mse
from ._grid import DyadicGrid, RandomisedMSE
from ._independent import independent_mse
from ._jittered import jittered_mse
from ._orthogonal import orthogonal_mse
from ._owen import owen_mse
from ._shared_sequence import shared_sequence_mse

__all__ = ["RANDOMISATIONS", "Randomisation", "randomised_mse"]


@dataclass(frozen=True)
class Randomisation:
    """One registered randomisation: its function ``f(grid, n, **options)`` and options."""

    name: str
    function: Callable[..., RandomisedMSE]
    options: tuple[str, ...]
    description: str


RANDOMISATIONS = {r.name: r for r in (
    Randomisation("independent", independent_mse, (), "i.i.d. uniform points: V/N"),
    Randomisation("jittered", jittered_mse, ("r", "layout", "strata"),
                  "jittered strata (r x r, a sampler's x x y, envfit's rows)"),
    Randomisation("cmj", cmj_mse, ("nx", "ny", "permutations"),
                  "Kensler's correlated multi-jittering"),
    Randomisation("digital_shift", digital_shift_mse, ("net",),
                  "random XOR shift of a digital net"),
    Randomisation("owen", owen_mse, ("net",), "nested uniform (Owen) scrambling of a net"),
    Randomisation("cp_shift", cp_shift_mse, ("points", "net"),
                  "Cranley-Patterson shift of a point set"),
    Randomisation("orthogonal", orthogonal_mse, ("dimension",),
                  "Bose orthogonal array (strength 2), permuted strata, jitter"),
    Randomisation("shared_sequence", shared_sequence_mse, ("points", "stream", "draws", "seed"),
                  "runs of one fixed scrambled sequence shared by all pixels (drawn)"),
)}


def randomised_mse(name: str, grid: DyadicGrid, n: int, **options) -> RandomisedMSE:
    r"""The exact mean squared error of :math:`\frac1N\sum_j h(u_j)` over the randomisation
    ``name`` of N = ``n`` points, from the grid of h.

    Parameters
    ----------
    name : str
        A key of :data:`RANDOMISATIONS`.
    grid : DyadicGrid
        The warped integrand's cell means, mean squares and variance.
    n : int
        Points per estimate (the renderer's samples per pixel after its own rounding).
    **options
        The method's options (``RANDOMISATIONS[name].options``).

    Raises
    ------
    ParameterError
        Unknown name or option, N < 1, N not allowed by the method or the grid.

    Examples
    --------
    >>> import numpy as np
    >>> g = DyadicGrid.from_callable(lambda u: u[:, 0] + u[:, 1], 6, nodes=2)
    >>> r = randomised_mse("independent", g, 16)
    >>> bool(np.isclose(r.mse[0], (1 / 6) / 16))     # Var(u1 + u2) = 2/12
    True
    """
    if name not in RANDOMISATIONS:
        raise ParameterError(f"unknown randomisation {name!r}; known: "
                             f"{', '.join(RANDOMISATIONS)}")
    if not isinstance(grid, DyadicGrid):
        raise ParameterError(f"grid must be a DyadicGrid, got {type(grid).__name__}")
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"n must be an integer >= 1, got {n!r}")
    n = int(n)
    entry = RANDOMISATIONS[name]
    unknown = sorted(set(options) - set(entry.options))
    if unknown:
        raise ParameterError(f"{name} takes the options {list(entry.options)}, "
                             f"not {unknown}")
    return entry.function(grid, n, **options)

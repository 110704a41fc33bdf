r"""Two techniques' streams (emitter and BSDF 2-D samples, each with its own warped integrand
:math:`h_1, h_2`) in one pixel: :math:`F = F_1 + F_2`, :math:`F_i = \frac1N\sum_j h_i(u_{ij})`
(the MIS weights inside the :math:`h_i`), and

.. math::  E(F - I)^2 = E(F_1 - I_1)^2 + E(F_2 - I_2)^2 + 2\,C_{12},\qquad
           C_{12} = E[(F_1 - I_1)(F_2 - I_2)].

* Independently randomised streams (pairing ``independent``: fresh jitter and other
  permutations per dimension, or per-dimension scramble seeds): each error has mean 0 and they
  are independent, so :math:`C_{12} = 0`.
* One randomised point set shared by both streams (pairing ``same_net_permuted``: the same
  XOR-shifted (0, 2)-net per pixel for every 2-D dimension, only the order permuted per
  dimension): the order does not change a mean, so
  :math:`F_1 - I_1 = \sum_{k\in D^*\setminus0}\hat h_1(k)\,\mathrm{wal}_k(\Delta)` and
  likewise for :math:`h_2` with the **same** Δ; orthonormality in Δ gives

  .. math::  C_{12} = \sum_{k\in D^*\setminus\{0\}} \hat h_1(k)\,\hat h_2(k)

  (real Walsh coefficients, so no conjugate), i.e. the MSE of the shift applied to
  :math:`h_1 + h_2`. Below the grid this is summed exactly; above it by polarisation of the
  :math:`P_\text{above}/N` rule on the grid of :math:`h_1 + h_2` (``total``), as
  :math:`(P(h_1+h_2) - P(h_1) - P(h_2))/(2N)`. For any other method whose points are shared,
  :math:`C_{12}` is the polarisation of that method's quadratic form, computed the same way.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError

from ._digital_shift import dual_sum
from ._grid import DyadicGrid, RandomisedMSE
from ._nets import get_net, net_exponent
from ._registry import randomised_mse

__all__ = ["MisMSE", "mis_mse"]


@dataclass(frozen=True)
class MisMSE:
    """The MSE of two techniques' streams: each alone and the cross term C₁₂ per channel."""

    method: str
    n: int
    shared: bool
    first: RandomisedMSE
    second: RandomisedMSE
    cross: np.ndarray

    @property
    def mse(self) -> np.ndarray:
        """E(F − I)² = mse₁ + mse₂ + 2·C₁₂ per channel."""
        return self.first.mse + self.second.mse + 2.0 * self.cross


def mis_mse(name: str, first: DyadicGrid, second: DyadicGrid, n: int, *, shared: bool = False,
            total: DyadicGrid | None = None, second_options: dict | None = None,
            **options) -> MisMSE:
    """The MSE of F₁ + F₂ with both streams randomised by ``name`` (N points each):
    independently (``shared=False``) or as one shared point set (``shared=True``, needs
    ``total``, the grid of h₁ + h₂, for the power above the grid). ``second_options``: the
    second stream's options where they differ from the first's (an orthogonal array: its
    dimension); for a shared set they must not."""
    if first.size != second.size or first.channels != second.channels:
        raise ParameterError("the two techniques' grids must have the same size and channels")
    second_options = options if second_options is None else second_options
    one = randomised_mse(name, first, n, **options)
    two = randomised_mse(name, second, n, **second_options)
    if not shared:
        return MisMSE(name, n, False, one, two, np.zeros_like(one.mse))
    if second_options != options:
        raise ParameterError("a shared point set randomises both streams alike: "
                             "second_options must equal the options")
    if total is None or total.size != first.size:
        raise ParameterError("a shared point set needs total, the grid of h1 + h2 "
                             "(DyadicGrid.from_callable of their sum), of the same size")
    both = randomised_mse(name, total, n, **options)
    if name == "digital_shift":
        sampled = (options.get("net", "sobol"), int(n)) in first.shift_above
        m = net_exponent(n, None if sampled else first.size)
        mask = get_net(options.get("net", "sobol")).dual_mask(m, first.size)
        below = dual_sum(first.walsh, second.walsh, mask)
        cross = below + (both.above - one.above - two.above) / 2.0
    else:
        cross = (both.mse - one.mse - two.mse) / 2.0
    return MisMSE(name, n, True, one, two, cross)

r"""A BSDF that picks one of two lobes by a number of its own, under a sampler whose 1-D
dimension is N strata with one point in each, paired at random with the 2-D points.

A rough plastic (:class:`envfit.shading.microfacet.RoughPlastic`; the renderer's folder's
``_bsdf`` cites its source) takes ``sample1`` (a 1-D number) and ``sample2`` (a 2-D one): the
specular lobe when ``sample1`` < :math:`p` (``prob_specular``), the diffuse one otherwise, then ω from
``sample2`` in that lobe, weighted by f·cos over the *mixture* pdf. The randomisations of
:data:`STRATIFIED_1D` draw the 1-D number as one point in each of the N strata
[k/N, (k+1)/N):

* ``jittered``, ``cmj``: ``(σ(i) + jitter) / N``, σ a permutation of the N strata, jittered;
* ``digital_shift``: the van der Corput points of N = 2^m XOR one 32-bit shift, in a permuted
  order: again one point in each stratum, all at one offset in it, uniform;
* ``owen``: a coordinate of a nested-uniform-scrambled Sobol' net of N = 2^m points (the
  third coordinate of a 3-D request whose first two draw the direction): one point in each
  stratum, uniform in it — but ordered by the net, not at random: the renderer model adds
  what that order changes, drawn over the sampler's own points
  (:meth:`envfit.predict.renderer._lobe_parts.LobeChoice._order_excess`), as for
  ``digital_shift``'s sampler order;

the order permuted by each dimension's own seed (which renderer's samplers draw so, read
from which source, its folder says). Hence the number K of samples that pick lobe
a is :math:`K_0 = \lfloor Np\rfloor` or :math:`K_0 + 1`, the latter with probability
:math:`\{Np\}` (the one point in the stratum holding p is uniform in it), and given K the
samples that pick a are a random K-subset of the N 2-D points (two dimensions' permutations,
independent; taken as uniform).

With :math:`a(u)`, :math:`b(u)` the estimator's value when lobe a, resp. b, draws from u,
:math:`d = a - b`, :math:`s_j` the indicator of lobe a at point :math:`x_j`, the pixel value
is :math:`F = \frac1N\sum_j [b(x_j) + s_j d(x_j)]` and, with :math:`q = K/N`,

.. math::
   E[F\mid X, K] = \frac1N\sum_j c_q(x_j),\quad c_q = q\,a + (1-q)\,b; \qquad
   \mathrm{Var}[F\mid X, K] = \frac{q(1-q)}{N-1}\,\hat v_X(d)

(the variance of a sample of K without replacement), :math:`\hat v_X` the points' population
variance, whose mean over the randomisation is :math:`\sigma^2(d) - V_N(d)` (each point is
uniform). With I = p∫a + (1−p)∫b and D = ∫d:

.. math::
   \mathrm{MSE} = \sum_{K} P(K)\Big[V_N(c_q) + (q - p)^2 D^2
                  + \frac{q(1-q)}{N-1}\big(\sigma^2(d) - V_N(d)\big)\Big],

:math:`V_N(h)` the randomisation's MSE of the mean of h (:func:`randomised_mse`). N = 1
gives the mixture's variance :math:`pV(a) + (1-p)V(b) + p(1-p)D^2`; i.i.d. lobe choices (the
``independent`` sampler) are not this case (K binomial): there the two numbers are one
uniform point of the square (``RoughPlastic.sample_square``).

A second stream that shares the 2-D point set (MIS under a sampler that gives every 2-D
dimension the same randomised net, :mod:`._mis`) has an error that is a function of X alone, so
its cross term is :math:`E_K\,C_N(h_e, c_q) = C_N(h_e, c_p)` (linear in q, E q = p).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid
from ._mis import mis_mse
from ._registry import randomised_mse

__all__ = ["STRATIFIED_1D", "lobe_choice_mse", "lobe_choice_mis"]

#: the randomisations whose sampler draws a 1-D number as N jittered strata (module
#: docstring): :func:`lobe_choice_mse` holds for their random order
STRATIFIED_1D = ("jittered", "cmj", "digital_shift", "owen")

GridOf = Callable[[float, float], DyadicGrid]


def _counts(n: int, p: float):
    """((K, P(K)), …): K = ⌊Np⌋ or ⌊Np⌋ + 1 with probability {Np}."""
    k0 = math.floor(n * p)
    frac = n * p - k0
    out = [(k0, 1.0 - frac), (k0 + 1, frac)]
    return [(k, w) for k, w in out if w > 1e-12 and 0 <= k <= n]


def lobe_choice_mse(name: str, grid_of: GridOf, n: int, p: float, **options) -> np.ndarray:
    r"""The MSE (per channel) of one BSDF stream whose lobe a is picked when a stratified 1-D
    number is below ``p`` (module docstring), the 2-D points randomised by ``name``.

    Parameters
    ----------
    name : str
        A randomisation of :data:`STRATIFIED_1D` (the 2-D points').
    grid_of : callable
        ``grid_of(x, y)`` is the :class:`DyadicGrid` of :math:`x\,a + y\,b` (a, b the two
        lobes' warped integrands on the same square).
    n : int
        Samples per pixel.
    p : float
        Lobe a's probability, in [0, 1].
    **options
        The randomisation's options.

    Examples
    --------
    >>> import numpy as np
    >>> a, b = (lambda u: 2 * u[:, 0]), (lambda u: np.ones(len(u)))
    >>> def grid_of(x, y):
    ...     return DyadicGrid.from_callable(lambda u: x * a(u) + y * b(u), 5, nodes=2)
    >>> mse = lobe_choice_mse("jittered", grid_of, 1, 0.25, r=1)[0]
    >>> bool(np.isclose(mse, 0.25 * (4 / 12)))        # p V(a) + (1 - p) V(b) + p(1-p)·0
    True
    """
    if name not in STRATIFIED_1D:
        raise ParameterError(f"a lobe choice is modelled for the randomisations "
                             f"{', '.join(STRATIFIED_1D)}; got {name!r}")
    if not 0.0 <= p <= 1.0:
        raise ParameterError(f"p must be in [0, 1], got {p!r}")
    d = grid_of(1.0, -1.0)
    big_d, sigma2 = d.integral, d.variance
    v_d = randomised_mse(name, d, n, **options).mse if n > 1 else 0.0
    total = np.zeros_like(big_d)
    for k, w in _counts(n, p):
        q = k / n
        v_c = randomised_mse(name, grid_of(q, 1.0 - q), n, **options).mse
        choice = q * (1.0 - q) / (n - 1) * np.clip(sigma2 - v_d, 0.0, None) if n > 1 else 0.0
        total = total + w * (v_c + (q - p) ** 2 * big_d ** 2 + choice)
    return total


def lobe_choice_mis(name: str, first: DyadicGrid, grid_of: GridOf, n: int, p: float, *,
                    shared: bool, options: dict, options_b: dict, total_of=None):
    r"""The MSE of an emitter stream (``first``, the grid of :math:`h_e`) plus a BSDF stream
    with a lobe choice (:func:`lobe_choice_mse`): (mse, emitter part, BSDF part, cross), per
    channel. ``shared``: both 2-D streams are one point set (a shared net); the cross term is
    :math:`C_N(h_e, c_p)` (module docstring), which needs ``total_of(x, y)``, the grid of
    :math:`h_e + x\,a + y\,b`."""
    b_mse = lobe_choice_mse(name, grid_of, n, p, **options_b)
    e_mse = randomised_mse(name, first, n, **options).mse
    cross = np.zeros_like(e_mse)
    if shared:
        if total_of is None:
            raise ParameterError("a shared point set needs total_of, the grid of h_e + c_p")
        cross = mis_mse(name, first, grid_of(p, 1.0 - p), n, shared=True,
                        total=total_of(p, 1.0 - p), **options).cross
    return e_mse + b_mse + 2.0 * cross, e_mse, b_mse, cross

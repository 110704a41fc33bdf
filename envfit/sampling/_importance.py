r"""The estimators renderers use for the shading integral: map importance sampling, BRDF
(lobe) sampling and Veach's multiple importance sampling of the two.

All of them estimate the same integral as :func:`envfit.shading._ground_truth.shading_integral`
(Eq. 17 of Marques, Bouville, Bouatouch), with the same integrand — the map's bilinear
interpolant :math:`f` = :meth:`envfit.maps._envmap.EnvMap.lookup` times the normalised zonal
lobe about the axis :math:`a`,

.. math::  I(a) = \int_{S^2} f(\omega)\,\rho_a(\omega)\,d\omega, \qquad
           \rho_a(\omega) = \frac{p(\omega\cdot a)}{2\pi r_s}, \qquad
           r_s = \int_0^1 p(z)\,dz,

with :math:`p` = :func:`envfit.shading._ground_truth.weight_function` (diffuse :math:`p = z`,
glossy :math:`p = e^{n(z-1)}`), zero on the lower hemisphere of :math:`a`, so
:math:`\int\rho_a = 1`.

Techniques (each maps square points :math:`u\in[0,1)^2` of *any* point set — random,
jitter, Sobol, LP, BNOT, the square lattice of spherical Fibonacci, see
:func:`envfit.theory._pointsets.square_points` — to directions with a known pdf per solid
angle, so quasi-Monte Carlo and importance sampling combine):

* **map** — :class:`envfit.sampling._map_sampler.MapSampler`: pdf ∝ luminance × pixel solid
  angle, piecewise constant, sampled by inverse CDF (pbrt-v4's image infinite light, Mitsuba
  3's ``envmap`` emitter).
* **brdf** — the lobe's own sampler, the morph of :mod:`envfit.theory._pointsets`
  (Lambert lift :math:`z'=u_0, \phi = 2\pi u_1`, then :math:`z = F^{-1}(z')` =
  ``weight.morph``: diffuse :math:`z=\sqrt{z'}`, glossy Eq. 67), whose pdf per solid angle is
  exactly :math:`q_a(\omega) = p(\omega\cdot a)/(2\pi r_s) = \rho_a(\omega)`
  (:func:`brdf_pdf`): the lobe is sampled perfectly, so :math:`\rho_a/q_a = 1` and the
  estimate is the mean of :math:`f` — :func:`envfit.shading._estimators.quadrature_estimates`
  with equal weights, written here with its pdf explicit for MIS.
* **mis** — Veach, *Robust Monte Carlo Methods for Light Transport Simulation* (PhD thesis,
  Stanford 1997), ch. 9: the multi-sample and one-sample models with the balance and power
  heuristics (:func:`mis_estimates`, :func:`mis_weights`).

:data:`ESTIMATORS` maps the names to the functions and :func:`importance_estimates`
dispatches on it (no string if-chains; :data:`HEURISTICS` and :data:`MODES` likewise).

Randomisation (``seed``): each axis m gets an independent uniform twist :math:`\alpha_m`
of its frame about the axis — the same draws as ``quadrature_estimates(..., seed=seed)``,
:func:`envfit.shading._estimators.twisted_frames` — and, with ``shift=True``, an independent
Cranley–Patterson rotation :math:`u \mapsto (u + s_m) \bmod 1`, :math:`s_m` uniform on
:math:`[0,1)^2` (Cranley & Patterson 1976), drawn next from the same generator. With a
shift, every estimator is unbiased for *any* point set (each shifted point is uniform on
the square); without one, a deterministic set gives a deterministic (QMC) estimate.
``shift="points"`` instead shifts every point of every axis independently: the points are
then i.i.d. uniform, plain Monte Carlo with a fresh point set per axis, in one vectorised
call.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.theory._pointsets import square_points
>>> m = EnvMap(np.full((8, 16, 3), 0.5))
>>> u = square_points("sobol", 64)
>>> est = importance_estimates(m, [[0.0, 1.0, 0.0]], u, "brdf")     # constant map: exact
>>> est.round(12).tolist()
[[0.5, 0.5, 0.5]]
>>> sorted(ESTIMATORS)
['brdf', 'map', 'mis']
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from envfit.defaults import DEFAULT_SHININESS
from envfit.base import as_unit_vectors
from envfit.base import ParameterError
from envfit.base import check_memory
from envfit.maps import EnvMap
from envfit.shading import LOOKUP_BLOCK, twisted_frames
from envfit.shading import weight_function
from envfit.sampling._map_sampler import MapSampler, square_samples
from envfit.theory import WeightFunction
from envfit.theory import lambert_to_hemisphere

__all__ = ["brdf_pdf", "map_is_estimates",
           "brdf_sampling_estimates", "mis_estimates", "mis_weights", "importance_estimates",
           "ESTIMATORS", "HEURISTICS", "MODES"]


# ----------------------------------------------------------------------------- inputs

class _Shifts:
    """The shifts of the points, per block of axes: ``shift=True`` one Cranley–Patterson shift
    per axis (drawn after the twists, as before); ``shift="points"`` an independent uniform
    shift of *every point* of every axis (then the N points of an axis are i.i.d. uniform
    whatever the set: plain Monte Carlo, with a fresh set per axis), drawn per block from
    ``default_rng([seed, m0])``; without a seed or shift, none."""

    def __init__(self, m: int, seed, shift):
        if shift not in (True, False, "points", None):
            raise ParameterError(f"shift must be True, False or 'points', got {shift!r}")
        self.mode = shift if seed is not None else False
        self.seed = seed
        self.per_axis = np.zeros((m, 2))
        if self.mode is True:
            rng = np.random.default_rng(seed)
            rng.uniform(0.0, 2.0 * np.pi, m)                 # the twists, drawn first
            self.per_axis = rng.random((m, 2))

    def block(self, m0: int, m1: int, n: int) -> np.ndarray:
        """(m1 − m0, 1 or n, 2) shifts of the block's axes."""
        if self.mode == "points":
            return np.random.default_rng([int(self.seed), m0]).random((m1 - m0, n, 2))
        return self.per_axis[m0:m1, None, :]

    @property
    def active(self) -> bool:
        return bool(self.mode)


def _randomisation(A: np.ndarray, seed, shift) -> tuple[np.ndarray, _Shifts]:
    """Frames (M, 3, 3) (twisted with ``seed``, as quadrature_estimates) and the shifts."""
    return twisted_frames(A, seed), _Shifts(A.shape[0], seed, shift)


def _blocks(m_total: int, n: int, c: int, what: str):
    """Axis blocks (m0, m1) with about LOOKUP_BLOCK directions each, memory checked once."""
    mb = max(1, LOOKUP_BLOCK // max(n, 1))
    check_memory(min(m_total, mb) * max(n, 1) * 8 * (20 + 3 * c),
                 f"{what}: a block of {min(m_total, mb)} axes x {n} samples",
                 hint="use fewer samples")
    return [(m0, min(m_total, m0 + mb)) for m0 in range(0, m_total, mb)]


def _shifted(U: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(mb, N, 2): the points shifted by s (mb, 1 or N, 2) (mod 1), kept in [0, 1)."""
    out = U[None, :, :] + s
    out -= np.floor(out)
    return np.minimum(out, np.nextafter(1.0, 0.0))


# ----------------------------------------------------------------------------- the lobe

def brdf_pdf(weight: WeightFunction, cos) -> np.ndarray:
    r"""Pdf per solid angle of the lobe sampler (the morph), :math:`q(z) = p(z)/(2\pi r_s)`.

    It is also the normalised lobe :math:`\rho_a` of the integrand: with the Lambert lift
    (uniform :math:`z'`, φ) and :math:`z = F^{-1}(z')`, :math:`F(z) = \int_0^z p/r_s`, the
    density in z is :math:`p(z)/r_s` and per solid angle (:math:`d\omega = dz\,d\phi`)
    :math:`p(z)/(2\pi r_s)`; zero for z < 0. Diffuse: z/π; glossy:
    :math:`n e^{n(z-1)}/(2\pi(1-e^{-n}))`.

    >>> from envfit.theory import Diffuse
    >>> bool(np.isclose(brdf_pdf(Diffuse(), 0.5), 0.5 / np.pi)), float(brdf_pdf(Diffuse(), -0.1))
    (True, 0.0)
    """
    return np.asarray(weight.p(cos), dtype=np.float64) / (2.0 * np.pi * float(weight.r_s))


# ----------------------------------------------------------------------------- techniques

def _map_technique(envmap, sampler, weight, A, U):
    """Map samples for axes A (K, 3), one point each (K, 2): f (K, C), p_map (K,), ρ = q (K,)."""
    d, pm = sampler.sample(U)
    rho = brdf_pdf(weight, np.einsum("ki,ki->k", d, A))
    return envmap.lookup(d), pm, rho


def _brdf_technique(envmap, sampler, weight, R, U):
    """Lobe samples for frames R (K, 3, 3), one point each: f (K, C), p_map (K,) or None, ρ = q."""
    local = lambert_to_hemisphere(U, morph=weight.morph)
    d = np.einsum("kij,kj->ki", R, local)
    rho = brdf_pdf(weight, local[:, 2])
    pm = None if sampler is None else sampler.pdf(d)
    return envmap.lookup(d), pm, rho


def _setup(envmap, axes, brdf, shininess, seed, shift):
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    weight = weight_function(brdf, shininess)
    A = as_unit_vectors(axes, name="axes", allow_empty=True)
    R, s = _randomisation(A, seed, shift)
    return weight, A, R, s


def map_is_estimates(envmap: EnvMap, axes, u, sampler: MapSampler | None = None,
                     brdf="diffuse", shininess: float = DEFAULT_SHININESS, *, seed=None,
                     shift: bool | str = True) -> np.ndarray:
    r"""Map importance-sampling estimates :math:`\frac1N\sum_j f(\omega_j)\rho_a(\omega_j)/p(\omega_j)`, (M, C).

    :math:`\omega_j` = ``sampler.sample(u)`` (:class:`MapSampler`, built from the map with its
    defaults when None), p its pdf per solid angle, :math:`\rho_a` the normalised lobe
    (:func:`brdf_pdf`), 0 below the horizon of a — samples there are wasted, which is why
    this technique alone is poor for a glossy lobe and good for a small bright source.

    Parameters
    ----------
    envmap : the map; f = ``envmap.lookup``.
    axes : (M, 3) or (3,) world axes (normalised internally).
    u : (N, 2) square points in [0, 1)² of any point set.
    sampler : a :class:`MapSampler` of this map (reuse it across calls: it costs O(HW)).
    brdf, shininess : the lobe, as :func:`envfit.shading._ground_truth.weight_function`.
    seed, shift : None — the same N directions for every axis (computed once); otherwise an
        independent Cranley–Patterson shift of u per axis (module docstring), which makes
        the estimate unbiased for deterministic sets too.

    Work: N lookups (M·N with a shift), in blocks of
    :data:`envfit.shading._estimators.LOOKUP_BLOCK` directions, memory checked.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> u = np.random.default_rng(1).random((256, 2))
    >>> float(map_is_estimates(m, [0, 1.0, 0], u, MapSampler(m, floor=0))[0, 0]) > 0
    True
    """
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U = square_samples(u)
    sampler = MapSampler(envmap) if sampler is None else sampler
    n, c = U.shape[0], envmap.channels
    out = np.empty((A.shape[0], c))
    if not s.active:
        d, pm = sampler.sample(U)
        f = envmap.lookup(d)                                            # (N, C)
        for m0, m1 in _blocks(A.shape[0], n, c, "map importance sampling"):
            rho = brdf_pdf(weight, A[m0:m1] @ d.T)                       # (mb, N)
            out[m0:m1] = (rho / pm) @ f / n
        return out
    for m0, m1 in _blocks(A.shape[0], n, c, "map importance sampling"):
        mb = m1 - m0
        Ub = _shifted(U, s.block(m0, m1, n)).reshape(-1, 2)
        f, pm, rho = _map_technique(envmap, sampler, weight, np.repeat(A[m0:m1], n, axis=0), Ub)
        out[m0:m1] = np.einsum("mn,mnc->mc", (rho / pm).reshape(mb, n), f.reshape(mb, n, c)) / n
    return out


def brdf_sampling_estimates(envmap: EnvMap, axes, u, sampler=None, brdf="diffuse",
                            shininess: float = DEFAULT_SHININESS, *, seed=None,
                            shift: bool | str = True) -> np.ndarray:
    r"""BRDF (lobe) importance-sampling estimates :math:`\frac1N\sum_j f(\omega_j)\rho_a(\omega_j)/q_a(\omega_j)`, (M, C).

    :math:`\omega_j = R_a\,\ell(u_j)`: the Lambert lift of u morphed for the lobe
    (``weight.morph``, diffuse :math:`z=\sqrt{z'}`, glossy Eq. 67), rotated by the axis's frame
    (:func:`envfit.shading._estimators.twisted_frames`); :math:`q_a` = :func:`brdf_pdf` is its
    pdf. Since :math:`q_a = \rho_a` the ratio is 1 (taken as 1 also at the one point where both
    vanish, z = 0 of the diffuse lobe, e.g. LP's (0, 0)), so this equals
    :func:`envfit.shading._estimators.quadrature_estimates` with the morphed points and equal
    weights 1/N — for ``seed=None``, or any seed with ``shift=False`` (same twists). With a
    seed and ``shift=True`` the points are also Cranley–Patterson shifted per axis.
    ``sampler`` is accepted for a uniform signature and unused.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> brdf_sampling_estimates(m, [0, 1.0, 0], [[0.3, 0.7]], brdf="glossy").round(12).tolist()
    [[2.0]]
    """
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U = square_samples(u)
    n, c = U.shape[0], envmap.channels
    out = np.empty((A.shape[0], c))
    for m0, m1 in _blocks(A.shape[0], n, c, "BRDF sampling"):
        mb = m1 - m0
        Ub = _shifted(U, s.block(m0, m1, n)).reshape(-1, 2)
        f, _, rho = _brdf_technique(envmap, None, weight, np.repeat(R[m0:m1], n, axis=0), Ub)
        ratio = np.divide(rho, rho, out=np.ones_like(rho), where=rho > 0)   # ρ/q, q = ρ
        out[m0:m1] = np.einsum("mn,mnc->mc", ratio.reshape(mb, n), f.reshape(mb, n, c)) / n
    return out


# ----------------------------------------------------------------------------- MIS

def _balance_weights(q: np.ndarray) -> np.ndarray:
    s = q.sum(axis=0)
    return np.divide(q, s, out=np.zeros_like(q), where=s > 0)


def _balance_over_q(q: np.ndarray, i: int) -> np.ndarray:
    s = q.sum(axis=0)
    return np.divide(1.0, s, out=np.zeros_like(s), where=s > 0)


def _power_weights(q: np.ndarray) -> np.ndarray:
    q2 = q * q
    s = q2.sum(axis=0)
    return np.divide(q2, s, out=np.zeros_like(q), where=s > 0)


def _power_over_q(q: np.ndarray, i: int) -> np.ndarray:
    s = (q * q).sum(axis=0)
    return np.divide(q[i], s, out=np.zeros_like(s), where=s > 0)


class Heuristic(NamedTuple):
    """A MIS heuristic: ``weights(q)`` → w (K, …) and ``over_q(q, i)`` → :math:`w_i/q_i`,
    for :math:`q_k = \\nu_k p_k` (K, …) (the second avoids 0/0 where :math:`q_i = 0`)."""

    weights: Callable[[np.ndarray], np.ndarray]
    over_q: Callable[[np.ndarray, int], np.ndarray]


#: Veach 1997 §9.2: balance :math:`w_i = q_i/\sum_k q_k`, power (β = 2) :math:`q_i^2/\sum_k q_k^2`
HEURISTICS: dict[str, Heuristic] = {
    "balance": Heuristic(_balance_weights, _balance_over_q),
    "power": Heuristic(_power_weights, _power_over_q),
}


def mis_weights(pdfs, fractions, heuristic: str = "balance") -> np.ndarray:
    r"""MIS weights :math:`w_i(\omega)` of K techniques at sample positions, (K, …).

    ``pdfs`` (K, …) are the techniques' densities :math:`p_k(\omega)` at the same positions,
    ``fractions`` (K,) their sample shares :math:`\nu_k` (:math:`n_k/N` multi-sample,
    :math:`c_k` one-sample); with :math:`q_k = \nu_k p_k`: balance :math:`w_i = q_i/\sum_k q_k`,
    power :math:`w_i = q_i^2/\sum_k q_k^2` (Veach 1997, Eqs. 9.4 and 9.13 with β = 2). They sum
    to 1 wherever some :math:`q_k > 0` (0 elsewhere).

    >>> mis_weights([[1.0, 0.0], [3.0, 2.0]], [0.5, 0.5]).tolist()
    [[0.25, 0.0], [0.75, 1.0]]
    >>> mis_weights([[1.0], [3.0]], [0.5, 0.5], "power").ravel().tolist()
    [0.1, 0.9]
    """
    p = np.asarray(pdfs, dtype=np.float64)
    nu = np.asarray(fractions, dtype=np.float64).reshape((-1,) + (1,) * (p.ndim - 1))
    return _heuristic(heuristic).weights(nu * p)


def _heuristic(name) -> Heuristic:
    try:
        return HEURISTICS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"heuristic must be one of {', '.join(HEURISTICS)}; "
                             f"got {name!r}") from None


def _multi_layout(U_parts, fraction, n):
    """Multi-sample: the first n₁ = round(fraction·N) points go to the map, the rest to the
    lobe (or the two given sets). Returns (map mask (N,), ν (2,), remap)."""
    n1 = U_parts[1]
    sel = np.arange(n) < n1
    return sel, np.array([n1 / n, (n - n1) / n]), None


def _one_layout(U_parts, fraction, n):
    """One-sample: u₀ < c picks the map (u₀/c), else the lobe ((u₀ − c)/(1 − c))."""
    return None, np.array([fraction, 1.0 - fraction]), fraction


#: sample allocation models of Veach 1997 §9.2.2 (multi-sample) and §9.2.4 (one-sample)
MODES = {"multi": _multi_layout, "one": _one_layout}


def _mis_points(u, mode, fraction):
    """(U (N, 2), n₁ or None) for the mode: a pair (u_map, u_brdf) only for multi."""
    if isinstance(u, (tuple, list)) and len(u) == 2 and not np.isscalar(u[0]) \
            and np.ndim(u[0]) == 2:
        if mode != "multi":
            raise ParameterError("a pair (u_map, u_brdf) of point sets needs mode='multi'")
        a, b = square_samples(u[0], "u_map"), square_samples(u[1], "u_brdf")
        return np.vstack([a, b]), a.shape[0]
    U = square_samples(u)
    return U, int(np.floor(fraction * U.shape[0] + 0.5))


def _mis_options(heuristic, mode, fraction) -> tuple[Heuristic, float]:
    """The checked heuristic and map share c₁ = ``fraction`` (in [0, 1]) of a MIS call."""
    if mode not in MODES:
        raise ParameterError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    heur = _heuristic(heuristic)
    try:
        c1 = float(fraction)
    except (TypeError, ValueError):
        raise ParameterError(f"fraction must be a number in [0, 1], got {fraction!r}") from None
    if not 0.0 <= c1 <= 1.0:
        raise ParameterError(f"fraction must be a number in [0, 1], got {fraction!r}")
    return heur, c1


def _mis_assign(Ub: np.ndarray, sel_pos, split) -> tuple[np.ndarray, np.ndarray]:
    """(map mask (mb, N), points) of a block's shifted points Ub (mb, N, 2): multi-sample
    (``split`` None) the mask ``sel_pos`` (N,) per axis; one-sample u₀ < c, u₀ rescaled."""
    mb, n = Ub.shape[:2]
    if split is None:
        return np.broadcast_to(sel_pos, (mb, n)), Ub
    sel = Ub[..., 0] < split
    u0 = Ub[..., 0]
    Ub[..., 0] = np.where(sel, u0 / max(split, 1e-300), (u0 - split) / max(1.0 - split, 1e-300))
    return sel, np.clip(Ub, 0.0, np.nextafter(1.0, 0.0))


@dataclass(frozen=True)
class _MISTechniques:
    """What every block of a MIS run shares: the map, its sampler, the BRDF weight function,
    the techniques' shares ν and the heuristic (:func:`mis_weights`)."""
    envmap: EnvMap
    sampler: MapSampler
    weight: WeightFunction
    nu: np.ndarray
    heur: Heuristic


def _mis_block(t: _MISTechniques, A, R, Ub, sel) -> np.ndarray:
    r"""Per-axis sum of :math:`w_i g/(\nu_i p_i)` over a block's N samples, (mb, C): axes A
    (mb, 3), frames R (mb, 3, 3), points Ub (mb, N, 2), map samples ``sel`` (mb, N)."""
    mb, n = sel.shape
    axis_of = np.broadcast_to(np.arange(mb)[:, None], (mb, n))
    contrib = np.zeros((mb, n, t.envmap.channels))
    steps = ((_map_technique, A, np.nonzero(sel)), (_brdf_technique, R, np.nonzero(~sel)))
    for i, (technique, frames, k) in enumerate(steps):
        if k[0].size:
            f, pm, rho = technique(t.envmap, t.sampler, t.weight, frames[axis_of[k]], Ub[k])
            q = np.stack([t.nu[0] * pm, t.nu[1] * rho])
            contrib[k] = f * (rho * t.heur.over_q(q, i))[:, None]
    return contrib.sum(axis=1)


def mis_estimates(envmap: EnvMap, axes, u, sampler: MapSampler | None = None,
                  brdf="diffuse", shininess: float = DEFAULT_SHININESS, *,
                  heuristic: str = "balance",
                  mode: str = "multi", fraction: float = 0.5, seed=None,
                  shift: bool | str = True) -> np.ndarray:
    r"""Multiple importance sampling of the map and lobe techniques (Veach 1997, ch. 9), (M, C).

    With :math:`p_1` the map pdf (:class:`~envfit.sampling._map_sampler.MapSampler`),
    :math:`p_2 = q_a` the lobe pdf (:func:`brdf_pdf`), :math:`g = f\rho_a` the integrand and
    :math:`\nu_k` the shares,

    .. math:: F = \frac1N\sum_{j=1}^{N} \frac{w_{i_j}(\omega_j)\,g(\omega_j)}
                                        {\nu_{i_j}\,p_{i_j}(\omega_j)},

    :math:`i_j` the technique of sample j, weights :func:`mis_weights`:

    * ``mode="multi"`` (Veach §9.2.2): :math:`n_1` = round(fraction·N) map samples (the first
      n₁ points of u) and :math:`n_2 = N - n_1` lobe samples (the rest),
      :math:`\nu_k = n_k/N`; the estimator is :math:`\sum_i \frac1{n_i}\sum_j w_i g/p_i`.
      ``u`` may instead be a pair ``(u_map, u_brdf)`` of two point sets (then n_k are their
      sizes and ``fraction`` is unused) — better for sets ordered along a coordinate (the
      first half of SF's lattice covers only z' > ½; LP is not a sequence), whose halves are
      poorly stratified; with a shift (``seed``) any split is still unbiased.
    * ``mode="one"`` (Veach §9.2.4): each sample picks the map with probability
      :math:`c_1` = fraction by :math:`u_0 < c_1` and reuses the rescaled :math:`u_0`
      (:math:`u_0/c_1`, or :math:`(u_0-c_1)/(1-c_1)`), so a QMC set stays stratified;
      :math:`\nu_k = c_k`. With the balance heuristic this is IS with the mixture pdf
      :math:`c_1p_1 + c_2p_2`: :math:`F = \frac1N\sum g/(c_1p_1 + c_2p_2)`.

    Defaults and why: ``heuristic="balance"`` — Veach's Theorem 9.2 bounds its variance by the
    optimum of any weighting plus :math:`(1/\min_i n_i - 1/N)\,I^2`, and in the one-sample
    model it is optimal (Theorem 9.5); ``"power"`` (β = 2) does better where one technique is
    already very good (low-variance cases, §9.2.3). ``mode="multi"`` — deterministic
    allocation, no variance from the technique choice. ``fraction=0.5`` — without knowing
    which technique suits the map and lobe (a sun favours the map, a sharp lobe on a smooth
    sky the BRDF), the even split is the minimax choice: MIS with it is never worse than the
    better technique with half the samples (plus the bound above), whereas a skewed split
    can starve the technique that matters.

    Other parameters as :func:`map_is_estimates`; with a seed each axis's frame is twisted
    and (``shift``) its points Cranley–Patterson shifted.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> u = np.random.default_rng(0).random((64, 2))
    >>> bool(np.isfinite(mis_estimates(m, [[0, 1.0, 0]], u, mode="one")).all())
    True
    """
    heur, c1 = _mis_options(heuristic, mode, fraction)
    weight, A, R, s = _setup(envmap, axes, brdf, shininess, seed, shift)
    U, n1 = _mis_points(u, mode, c1)
    n, c = U.shape[0], envmap.channels
    sel_pos, nu, split = MODES[mode]((U, n1), c1, n)
    sampler = MapSampler(envmap) if sampler is None else sampler
    techniques = _MISTechniques(envmap, sampler, weight, nu, heur)
    out = np.empty((A.shape[0], c))
    for m0, m1 in _blocks(A.shape[0], n, c, "multiple importance sampling"):
        sel, Ub = _mis_assign(_shifted(U, s.block(m0, m1, n)), sel_pos, split)
        out[m0:m1] = _mis_block(techniques, A[m0:m1], R[m0:m1], Ub, sel) / n
    return out


# ----------------------------------------------------------------------------- dispatch

#: name → estimator; every one takes (envmap, axes, u, sampler, brdf, shininess, *, seed, shift)
ESTIMATORS: dict[str, Callable[..., np.ndarray]] = {
    "map": map_is_estimates,
    "brdf": brdf_sampling_estimates,
    "mis": mis_estimates,
}


def importance_estimates(envmap: EnvMap, axes, u, method: str = "mis", **kwargs) -> np.ndarray:
    """The estimator named ``method`` in :data:`ESTIMATORS` (keywords passed on), (M, C).

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((4, 8, 1), 1.0))
    >>> importance_estimates(m, [1.0, 0, 0], [[0.5, 0.5]], "bogus")
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: method must be one of map, brdf, mis; got 'bogus'
    """
    try:
        fn = ESTIMATORS[method]
    except (KeyError, TypeError):
        raise ParameterError(f"method must be one of {', '.join(ESTIMATORS)}; "
                             f"got {method!r}") from None
    return fn(envmap, axes, u, **kwargs)

r"""Periodic blue noise through optimal transport (BNOT), exact periodic power diagrams.

de Goes, Breeden, Ostromoukhov & Desbrun, "Blue Noise through Optimal Transport",
ACM Trans. Graph. 31(6) (SIGGRAPH Asia 2012) — the "BNOT" point set of Sec. 7.1 of
Marques, Bouville & Bouatouch (reference [8] there).

The domain is the flat torus :math:`T = [0,1)^2` (the unit square with periodic
boundaries). For sites :math:`x_1…x_n \in T` and weights :math:`w_1…w_n` the *power
cell* of site i is

.. math::  V_i^w = \{x \in T : |x - x_i|_T^2 - w_i \le |x - x_j|_T^2 - w_j \;\forall j\}

(:math:`|\cdot|_T` the toroidal distance). BNOT alternates two steps until the sites stop
moving:

1. **Capacity constraint** (semi-discrete optimal transport from the uniform measure to
   the sites with masses 1/n): find w with :math:`|V_i^w| = 1/n` for every i. The weights
   maximise the concave dual function (Aurenhammer, Hoffmann & Aronov 1998)

   .. math:: g(w) = \sum_i \int_{V_i^w} (|x - x_i|^2 - w_i)\,dx + \frac1n \sum_i w_i,
             \qquad \partial g/\partial w_i = \frac1n - |V_i^w|,

   whose negated Hessian is the weighted graph Laplacian of the power diagram,
   :math:`\partial|V_i|/\partial w_j = -\ell_{ij} / (2|x_i - x_j|)` for neighbours
   j ≠ i (:math:`\ell_{ij}` the length of the common edge) and
   :math:`\partial|V_i|/\partial w_i = \sum_{j} \ell_{ij}/(2|x_i-x_j|)`. Newton's method
   (sparse direct solve, one weight pinned) with the damping of Kitagawa, Mérigot &
   Thibert ("Convergence of a Newton algorithm for semi-discrete optimal transport",
   JEMS 2019): halve the step until every cell keeps at least half of its smallest
   initial area and the residual decreases by the factor (1 − τ/2).
2. **Lloyd step**: move every site to the centroid :math:`b_i` of its power cell
   (periodic wrap). With the weights optimal, :math:`2|V_i|(x_i - b_i)` is the gradient
   of the optimal-transport energy :math:`E(X) = \max_w g(w; X)` of de Goes et al., so
   the alternation is a fixed-step descent on E.

Run long enough, this slowly crystallises into hexagonal patches (the radial spectrum
peak keeps growing); the authors' reference implementation therefore stops at a
gradient threshold and then detects and breaks regular patches — :func:`bnot_square`
follows that schedule. Note that *any* set of distinct sites admits capacity weights;
what characterises BNOT points is that they are (near) centroids of their
capacity-constrained cells (:attr:`BNOTDiagnostics.centroid_residual`).

Deviations of :func:`bnot_square` from the reference implementation: Lloyd steps replace
its final line-searched gradient steps on the same energy (same fixed points); weights are
warm-started instead of reset each step; ``rounds`` defaults to 3 instead of 20 for
n > 150, and to 0 for n ≤ 150, where the threshold (relative to a cell's second moment it
is ≈ 1.6/n) flags most sites, so that breaking amounts to restarting from random points
(the reference also special-cases n ≤ 150, with 20-step phases). With n = 1024 the radial
spectrum, low-frequency power and minimum distance are the same with 0, 3 or 20 rounds to
within a few percent.

Power diagrams come from :mod:`envfit.theory._power_cells` (exact, periodic).

Costs (2-core machine, measured while another job kept it busy — about half that when
idle): ``bnot_square(256)`` ≈ 3.5 s, ``bnot_square(1024)`` ≈ 5.5 s, ``bnot_square(4096)``
≈ 15 s; one :func:`power_diagram` at n = 1024 ≈ 10–20 ms (Qhull ≈ 60 % of it); a
capacity solve from zero weights for 1024 random sites ≈ 0.15 s (5–7 Newton steps).

Examples
--------
>>> from envfit.theory._bnot import bnot_square, bnot_diagnostics
>>> pts = bnot_square(64, seed=1)
>>> pts.shape
(64, 2)
>>> bnot_diagnostics(pts).max_relative_area_error < 1e-8
True
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from envfit.theory._errors import TheoryParameterError
from envfit.theory._power_cells import (PowerDiagram, _check_sites, _check_weights,
                                        _toroidal_delta, _wrap, power_diagram)

__all__ = ["capacity_weights", "bnot_square",
           "BNOTDiagnostics", "bnot_diagnostics", "radial_power_spectrum",
           "min_toroidal_distance"]

# ----------------------------------------------------------------------------- OT weights
def capacity_weights(sites, weights=None, *, tol: float = 1e-10, max_iter: int = 100,
                     _return_info: bool = False, _check: bool = True):
    r"""Weights making every power cell of the sites have area exactly 1/n.

    Damped Newton ascent on the concave semi-discrete optimal-transport dual
    :math:`g(w)` (see the module docstring): solve
    :math:`J\,\delta = 1/n - |V(w)|` with J the sparse area Jacobian (graph Laplacian,
    one weight pinned, ``scipy.sparse.linalg.spsolve``), then halve τ until
    :math:`\min_i |V_i(w+\tau\delta)| \ge \varepsilon_0` and
    :math:`\|r(w+\tau\delta)\| \le (1-\tau/2)\|r(w)\|` (Kitagawa–Mérigot–Thibert 2019),
    :math:`\varepsilon_0 = \tfrac12\min(\min_i |V_i(w_0)|, 1/n)`.

    Stops when :math:`\max_i |n|V_i| - 1| \le` ``tol`` (floored at 1e−13, about the
    rounding level of the areas). Starts from ``weights`` if all
    their cells are non-empty, else from zero (the Voronoi diagram).

    Returns
    -------
    (weights (n,), PowerDiagram at those weights)

    Examples
    --------
    >>> import numpy as np
    >>> w, pd = capacity_weights(np.random.default_rng(0).random((100, 2)))
    >>> bool(np.max(np.abs(pd.areas * 100 - 1)) < 1e-10)
    True
    """
    x = _check_sites(sites)
    n = x.shape[0]
    if _check and n > 1 and min_toroidal_distance(x) == 0.0:
        raise TheoryParameterError("capacity_weights: two sites coincide")
    tol = max(float(tol), 1e-13)
    w = _check_weights(weights, n)
    pd = power_diagram(x, w)
    if np.any(pd.areas <= 0):
        w = np.zeros(n)
        pd = power_diagram(x, w)
    target = 1.0 / n
    r = target - pd.areas
    eps0 = 0.5 * min(pd.areas.min(), target)
    it = 0
    while np.max(np.abs(r)) * n > tol and it < max_iter:
        it += 1
        pd, r = _damped_newton_step(x, w, pd, r, eps0)
        w = pd.weights
    if np.max(np.abs(r)) * n > tol:  # pragma: no cover
        raise TheoryParameterError(
            f"capacity_weights did not converge in {max_iter} Newton steps "
            f"(max relative area error {np.max(np.abs(r)) * n:.3g})")
    if _return_info:
        return w, pd, it
    return w, pd


def _damped_newton_step(x: np.ndarray, w: np.ndarray, pd: PowerDiagram, r: np.ndarray,
                        eps0: float) -> tuple[PowerDiagram, np.ndarray]:
    r"""One damped Newton step of :func:`capacity_weights` from the weights ``w`` (their
    diagram ``pd``, residual ``r``): the power diagram at the new weights and its area
    residual :math:`1/n - |V|`.

    :math:`J\,\delta = r` with J the sparse area Jacobian (one weight pinned), then τ halved
    from 1 until every cell keeps at least ``eps0`` and :math:`\|r\|` drops by
    :math:`(1 - \tau/2)` (Kitagawa–Mérigot–Thibert 2019).
    """
    from scipy.sparse.linalg import spsolve  # local: scipy.sparse.linalg is slow to import

    n = x.shape[0]
    J = pd.area_jacobian().tocsc()
    delta = np.zeros(n)
    delta[1:] = spsolve(J[1:, 1:], r[1:])
    rn = np.linalg.norm(r)
    tau = 1.0
    while True:
        cand = power_diagram(x, w + tau * delta)
        rc = 1.0 / n - cand.areas
        if cand.areas.min() >= eps0 and np.linalg.norm(rc) <= (1.0 - 0.5 * tau) * rn:
            return cand, rc
        tau *= 0.5
        if tau < 1e-12:  # pragma: no cover - Newton direction is an ascent direction
            raise TheoryParameterError("capacity_weights: line search failed")


# ----------------------------------------------------------------------------- BNOT
def _regular_sites(pd: PowerDiagram, tau: float) -> np.ndarray:
    """Sites inside regular (crystallised) patches, by the reference BNOT criterion.

    R_i = mean_j |I_i - I_j| / C over the neighbours j of i, with I_i the second moment
    of cell i about its site and C = 1/n the capacity; regular if R_i < τ C²/4.
    """
    n = pd.n
    i, j = pd.edges[:, 0], pd.edges[:, 1]
    deg = np.bincount(i, minlength=n)
    dev = np.bincount(i, weights=np.abs(pd.second_moments[i] - pd.second_moments[j]),
                      minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        reg = dev / deg * n
    return np.nonzero(reg < tau * 0.25 / n ** 2)[0]


def _bnot_impl(n, seed, iterations, tol, rounds, inner_tol):
    rng = np.random.default_rng(seed)
    x = rng.random((n, 2))
    w = np.zeros(n)
    total = 0
    for rnd in range(rounds + 1):
        converged = False
        for _ in range(iterations):
            total += 1
            w, pd = capacity_weights(x, w, tol=inner_tol, _check=False)
            step = _toroidal_delta(pd.centroids, x)
            x = pd.centroids
            if np.sqrt(np.sum(step * step)) <= tol:
                converged = True
                break
        if not converged or rnd == rounds:
            break
        # break regular patches (de Goes et al. 2012; reference implementation):
        # jitter the regular sites and their neighbours by up to C = 1/n, teleport up
        # to 100 regular sites to random positions, restart from zero weights
        w, pd = capacity_weights(x, w, tol=inner_tol, _check=False)
        reg = _regular_sites(pd, 1.0)
        if reg.size == 0:
            break
        nb = pd.edges[np.isin(pd.edges[:, 0], reg), 1]
        jit = np.union1d(reg, nb)
        ang = rng.uniform(0.0, 2.0 * np.pi, jit.size)
        rad = rng.uniform(0.0, 1.0 / n, jit.size)
        x = x.copy()
        x[jit] += rad[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
        tele = rng.choice(reg, size=min(reg.size, 100), replace=False)
        x[tele] = rng.random((tele.size, 2))
        x = _wrap(x)
        w = np.zeros(n)
    return x, total


def _bnot_arguments(n, seed, iterations, tol, rounds, inner_tol) -> tuple:
    """:func:`bnot_square`'s arguments checked and normalised (``rounds`` defaulted), in the
    order of :func:`_bnot_impl` (and the cache key of :func:`_bnot_cached`)."""
    n = int(n)
    if n < 1:
        raise TheoryParameterError(f"number of points must be >= 1, got {n}")
    if rounds is None:
        rounds = 3 if n > 150 else 0
    iterations, rounds = int(iterations), int(rounds)
    if iterations < 0 or rounds < 0:
        raise TheoryParameterError("iterations and rounds must be >= 0")
    if not (tol >= 0 and inner_tol > 0):
        raise TheoryParameterError("tol must be >= 0 and inner_tol > 0")
    return n, seed, iterations, float(tol), rounds, float(inner_tol)


@functools.lru_cache(maxsize=16)
def _bnot_cached(n, seed, iterations, tol, rounds, inner_tol):
    out, _ = _bnot_impl(n, seed, iterations, tol, rounds, inner_tol)
    out.setflags(write=False)
    return out


def bnot_square(n: int, *, seed=0, iterations: int = 500, tol: float = 3e-3,
                rounds: int | None = None, inner_tol: float = 1e-3) -> np.ndarray:
    r"""n points of periodic blue noise through optimal transport (de Goes et al. 2012).

    Algorithm (the structure of the authors' reference implementation, ``optimize_all``):

    1. n seeded uniform random sites, zero weights.
    2. Repeat: solve the capacity weights :math:`|V_i^w| = 1/n` (:func:`capacity_weights`
       to ``inner_tol`` relative, warm-started), move every site to the centroid
       :math:`b_i` of its power cell (periodic) — until the step is small,
       :math:`(\sum_i |b_i - x_i|^2)^{1/2} \le` ``tol`` (at most ``iterations`` steps).
       This is the reference's stopping rule: its threshold on the norm of the energy
       gradient :math:`2|V_i|(b_i - x_i)` is :math:`0.03\,\varepsilon/n` with ε = 0.2,
       i.e. tol = 0.003 (rms step ≈ 0.003 × the point spacing 1/√n).
    3. Break regularity: a site whose cell second moment
       :math:`I_i = \int_{V_i}|x-x_i|^2dx` differs from its neighbours' by
       :math:`\mathrm{mean}_j |I_i - I_j| < C^3/4` (C = 1/n) sits in a crystallised
       (hexagonal) patch; jitter these sites and their neighbours by a random vector of
       length ≤ C, teleport up to 100 of them to random positions, reset the weights to 0
       and go back to 2 — at most ``rounds`` times, stopping early when no patch is found
       or when step 2 did not converge.

    The result is the sites after the last Lloyd step. Deviations from the reference
    implementation (Lloyd steps for its final gradient steps, warm-started weights, fewer
    ``rounds``): see the module docstring.

    Parameters
    ----------
    n : number of points (≥ 1).
    seed : seed of the initial sites and of the regularity breaking
        (``numpy.random.default_rng``).
    iterations : cap on the Lloyd steps of one convergence phase (reference: 500).
    tol : threshold on :math:`(\sum_i |b_i - x_i|^2)^{1/2}`.
    rounds : maximum number of regularity-breaking rounds (reference: 20); default
        3 if n > 150 else 0.
    inner_tol : relative capacity tolerance of the weight solves inside the loop
        (:func:`bnot_diagnostics` re-solves the returned points' weights to 1e−10).

    Returns
    -------
    (n, 2) float64 array in [0, 1)².

    Cost (2 cores): see the module docstring. Results are cached per argument tuple
    within the process (integer seeds only).

    Examples
    --------
    >>> p = bnot_square(256, seed=3)
    >>> p.shape, bool(p.min() >= 0 and p.max() < 1)
    ((256, 2), True)
    """
    args = _bnot_arguments(n, seed, iterations, tol, rounds, inner_tol)
    if seed is not None and not isinstance(seed, (int, np.integer)):
        return _bnot_impl(*args)[0]
    return _bnot_cached(*args).copy()


@dataclass(frozen=True)
class BNOTDiagnostics:
    """Quality of a (BNOT) point set on the torus; see :func:`bnot_diagnostics`."""
    weights: np.ndarray
    areas: np.ndarray
    max_relative_area_error: float
    newton_steps: int
    centroid_residual: float      # max |centroid_i - x_i|_T · √n  (0 at a Lloyd fixed point)
    min_distance: float           # min toroidal distance between two points
    min_distance_normalised: float  # min_distance · √n  (hexagonal lattice: 1.0746)


def bnot_diagnostics(points, *, tol: float = 1e-10) -> BNOTDiagnostics:
    r"""Solve the capacity weights of ``points`` and report how well they hold.

    Returns the weights, the cell areas :math:`|V_i^w|` for them, the max relative area
    error :math:`\max_i |n|V_i| - 1|`, the number of Newton steps from w = 0, the Lloyd
    residual max :math:`|b_i - x_i|_T\sqrt n` (b_i the cell centroid) and the minimum
    toroidal distance (also times √n).

    Examples
    --------
    >>> import numpy as np
    >>> d = bnot_diagnostics(np.random.default_rng(0).random((64, 2)))
    >>> bool(d.max_relative_area_error < 1e-10)
    True
    """
    x = _check_sites(points)
    n = x.shape[0]
    w, pd, it = capacity_weights(x, None, tol=tol, _return_info=True)
    rel = float(np.max(np.abs(pd.areas * n - 1.0)))
    res = float(np.max(np.linalg.norm(_toroidal_delta(pd.centroids, x), axis=1)) * np.sqrt(n))
    dmin = min_toroidal_distance(x)
    return BNOTDiagnostics(weights=w, areas=pd.areas, max_relative_area_error=rel,
                           newton_steps=it, centroid_residual=res, min_distance=dmin,
                           min_distance_normalised=dmin * np.sqrt(n))


# ----------------------------------------------------------------------------- analysis
def min_toroidal_distance(points) -> float:
    """Smallest distance between two of the points on the flat torus [0,1)² (inf if n < 2).

    >>> min_toroidal_distance([[0.05, 0.5], [0.95, 0.5]])
    0.1
    """
    x = _check_sites(points)
    if x.shape[0] < 2:
        return float("inf")
    from scipy.spatial import cKDTree  # local: scipy.spatial is slow to import

    tree = cKDTree(x, boxsize=1.0)
    d, _ = tree.query(x, k=2)
    return float(round(d[:, 1].min(), 15))


def radial_power_spectrum(points2d, *, kmax: int | None = None, bin_width: float = 1.0,
                          return_counts: bool = False):
    r"""Radially averaged periodogram of a point set on the torus [0,1)².

    .. math:: P(\mathbf k) = \frac1n \Big|\sum_{j=1}^{n} e^{-2\pi i\,\mathbf k\cdot x_j}\Big|^2,
              \qquad \mathbf k \in \mathbb Z^2,\ 0 < |\mathbf k| ,

    averaged over annuli :math:`(r - w/2) \le |\mathbf k| < (r + w/2)`, r = w, 2w, …
    (w = ``bin_width``), up to ``kmax`` (default ⌈3√n⌉). For uniform random points
    E P(k) = 1 for every k ≠ 0; blue noise has P ≪ 1 below ≈ √n and P ≈ 1 above.
    The sum over points is separable, so the whole grid of frequencies costs two
    n×(2 kmax+1) exponential tables and one matrix product.

    Returns
    -------
    radius : (B,) mean ``|k|`` in each non-empty annulus;
    power : (B,) mean P over the annulus;
    counts : (B,) number of frequency vectors per annulus (if ``return_counts``).

    Examples
    --------
    >>> import numpy as np
    >>> r, p = radial_power_spectrum(np.random.default_rng(0).random((400, 2)), kmax=40)
    >>> bool(0.7 < p.mean() < 1.3)
    True
    """
    x = _check_sites(points2d)
    n = x.shape[0]
    if kmax is None:
        kmax = int(np.ceil(3.0 * np.sqrt(n)))
    kmax = int(kmax)
    if kmax < 1 or not (bin_width > 0):
        raise TheoryParameterError("kmax must be >= 1 and bin_width > 0")
    k = np.arange(-kmax, kmax + 1)
    ex = np.exp(-2j * np.pi * np.outer(x[:, 0], k))   # (n, K)
    ey = np.exp(-2j * np.pi * np.outer(x[:, 1], k))
    s = ex.T @ ey                                      # s[a, b] = Σ_j e^{-2πi(k_a x + k_b y)}
    p = (s.real ** 2 + s.imag ** 2) / n
    kx, ky = np.meshgrid(k, k, indexing="ij")
    rad = np.hypot(kx, ky).reshape(-1)
    p = p.reshape(-1)
    sel = (rad > 0) & (rad <= kmax)
    rad, p = rad[sel], p[sel]
    b = np.floor(rad / bin_width + 0.5).astype(np.int64)
    cnt = np.bincount(b)
    nz = cnt > 0
    radius = np.bincount(b, weights=rad)[nz] / cnt[nz]
    power = np.bincount(b, weights=p)[nz] / cnt[nz]
    if return_counts:
        return radius, power, cnt[nz]
    return radius, power

r"""Preconditioned conjugate gradients for the Sobolev kernel system :math:`K\alpha = f`
without the N x N matrix: O(N log N) products, O(N k) memory.

The matrix is :math:`K_{ij} = c_s - |p_i - p_j|^{2s-2}` (Eq. 14, SPD; condition ~N^s, ~5e8
at s = 1.9, N = 20 000). Three pieces, all built once per node set and reused for every
right-hand side (channels, maps of a library):

**The product** :class:`NodeOperator` — the near/far split of
:mod:`envfit.sobolev._nearfar` at the nodes themselves: the far field :math:`P_L(p_i\cdot p_j)`
by a ducc0 adjoint synthesis + synthesis at the fixed node angles (precomputed, with the
:math:`w_l` per coefficient), the near correction :math:`g - P_L` for pairs closer than
:math:`\delta` as a precomputed sparse matrix (kd-tree pairs, ~:data:`OPERATOR_NEIGHBOURS`
per node). :math:`\delta` is chosen larger than for an evaluation (fewer SH degrees,
:math:`L \approx 20/\delta`; the sparse part is cheap once stored). ducc0 0.42's
``sht.*_general`` transforms take the node angles per call and offer no reusable plan; at
N = 20 000, L = 204 a transform pair costs ~17 ms per channel (2 cores), so a product is
dominated by them and a plan-based ``ducc0.nufft.plan`` route was not tried.

**The preconditioner** :class:`LagrangePreconditioner` — a two-level method:

* *local Lagrange functions* (Faul, Goodsell & Powell 2005; Fuselier, Hangelbroek,
  Narcowich, Ward & Wright 2013): for node i and its k nearest neighbours :math:`N_i`
  (cKDTree), the coefficients :math:`c^{(i)}` of the local cardinal function with constant
  reproduction, :math:`[K_{N_i} \; 1; 1^T \; 0][c; d] = [e_i; 0]`, i.e.
  :math:`c = u - v (1^T u)/(1^T v)`, :math:`u = K_{N_i}^{-1} e_i`,
  :math:`v = K_{N_i}^{-1} 1` (one k x k Cholesky per node in a parallel numba kernel,
  :func:`envfit.sobolev._interpolation_kernels.local_lagrange`). Column i of the sparse
  :math:`Z` (N x N, N k entries) is :math:`c^{(i)}`, so :math:`KZ \approx I`; the
  preconditioner uses :math:`Z_s = (Z + Z^T)/2`.
* *coarse correction*: :math:`Q = S^T K_{SS}^{-1} S` on a subset S of m nodes (those
  nearest to m spherical Fibonacci points; dense Cholesky of :math:`K_{SS}`).
  :math:`Z` annihilates constants (:math:`1^T Z = 0`) and is inaccurate for the lowest
  degrees; :math:`Q` supplies them.
* combined as the *balancing* (BNN) preconditioner
  :math:`B = Q + (I - QK) Z_s (I - KQ)` (symmetric; positive definite when :math:`Z_s`
  is positive on the range of :math:`I - KQ`, checked in the tests), applied in the
  equivalent *A-DEF2* form of Tang, Nabben, Vuik & Erlangga (2009, J. Sci. Comput. 39):
  start :math:`x_0 = Q f`, :math:`z = y + Q(r - Ky)`, :math:`y = Z_s r`. With
  :math:`p_{k} = z_k + \beta p_{k-1}` the product :math:`Kp` is updated from :math:`Ky`
  and the coarse product :math:`KQ v = K_{:,S} K_{SS}^{-1} v_S` (m sources, evaluated at
  the nodes): **one full product per iteration**. Measured (dense eigenvalues, N = 4000,
  s = 1.9, k = 60, m = 50): spectrum of BK in [0.92, 1.04] (cond 1.12); without the coarse
  level (N = 2000, k = 40) KZ has eigenvalues from 0 (the constant) to 61 and
  :math:`Z_s` one negative eigenvalue.

**The stopping rule** ties the iteration to the reconstruction: the change of the
interpolant :math:`e = \sum_j (\alpha^*_j - \alpha_j) K(\cdot, p_j)` is bounded everywhere
by the reproducing property,
:math:`|e(x)| \le \sqrt{K(x,x)}\,\|e\|_{H} = \sqrt{c_s\, r^T K^{-1} r}`, and
:math:`r^T K^{-1} r \le r^T B r / \lambda_{\min}(BK)` (:math:`r^T B r = r^T z` is CG's own
inner product; :math:`\lambda_{\min}` is estimated by the smallest Ritz value of CG's
Lanczos matrix, halved for safety — the Ritz value approaches :math:`\lambda_{\min}` from
above, so this step is an estimate, not a proof; the tests check the bound against the
dense solution; a channel that takes no CG step — it met its tolerance at once, e.g. on
a warm start — has an empty Lanczos matrix and uses the smallest Ritz value of the other
channels or of earlier solves, BK being one operator). CG stops when this bound is below
``tol`` per channel, so any RMSE of the reconstruction (per pixel or weighted, against any map) moves by at most
``tol`` (:math:`|\,\|a\| - \|b\|\,| \le \|a - b\|`).

Channels are solved side by side: each column has its own CG coefficients (the result is
what a single-column solve gives; not O'Leary's block CG, whose shared Krylov space would
save little at ~6-8 iterations) but one call of the product, the preconditioner and the
coarse level serves all columns.
"""
from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import cho_factor, cho_solve, eigvalsh_tridiagonal
from scipy.spatial import cKDTree

from envfit.theory import kernel_constant
from envfit.theory import sphere_points

from envfit.base import EnvfitError, ParameterError
from envfit.base import iterative_coarse_nodes
from envfit.sobolev import _interpolation_kernels as _kernels
from envfit.sobolev._nearfar import (SHT_EPSILON, CellList, _to_theta_phi, far_field_expansion,
                                     near_radius, nearfar_power_sums)

__all__ = ["NodeOperator", "LagrangePreconditioner", "SolveInfo", "IterativeSolver",
           "IterativeSolverError", "pcg_adef2", "operator_radius", "OPERATOR_NEIGHBOURS", "LOCAL_NEIGHBOURS",
           "iterative_coarse_nodes"]

#: mean number of near pairs per node of the product's sparse part (the memory model of
#: :func:`envfit.base._resources.iterative_nbytes` assumes 48 and k = 60)
OPERATOR_NEIGHBOURS = 48.0
#: k, the nodes of each local Lagrange function
LOCAL_NEIGHBOURS = 60
#: the coarse product K[:, S] y is summed directly up to this many pairs N m
_COARSE_DIRECT_MAX = 2e7


def operator_radius(n: int) -> float:
    r"""Near radius :math:`\delta` of the product at N nodes: about
    :data:`OPERATOR_NEIGHBOURS` nodes within it (cap fraction :math:`\delta^2/4`), clamped to
    [0.02, 0.6], two significant digits (the far-field expansion is cached per delta)."""
    d = math.sqrt(4.0 * OPERATOR_NEIGHBOURS / max(int(n), 1))
    return float(f"{min(max(d, 0.02), 0.6):.2g}")


@functools.lru_cache(maxsize=1)
def _blas_controller():
    from threadpoolctl import ThreadpoolController
    return ThreadpoolController()


def _one_blas_thread():
    """Context: BLAS on one thread. The coarse level's m x m Cholesky and solves are tiny;
    OpenBLAS's threads waking next to numba's pool made a 400 x 400 ``dpotrf`` take 1-2 s
    instead of 1.3 ms on the loaded 2-core machine (measured)."""
    return _blas_controller().limit(limits=1, user_api="blas")


class IterativeSolverError(EnvfitError, RuntimeError):
    """The iterative path could not solve a system (CG breakdown, non-finite numbers, or no
    convergence within ``maxiter``). :class:`~envfit.sobolev._interpolation.SobolevInterpolator`
    with ``solver="auto"`` falls back to the dense Cholesky path on it (and records why in
    ``solve_info.reason``); with ``solver="iterative"`` it is the one-line error."""


# ----------------------------------------------------------------------------- product

class NodeOperator:
    r""":math:`x \mapsto Kx` at the nodes by the near/far split (see the module docstring).

    ``matvec(X)`` for X (N, C) costs 2 C ducc0 SH transforms of degree L plus a sparse
    product with ~:data:`OPERATOR_NEIGHBOURS` N entries; accuracy that of
    :mod:`envfit.sobolev._nearfar` (~1e-12 of :math:`\sum_j |x_j K_{ij}|`).
    """

    def __init__(self, points: np.ndarray, s: float, *, delta: float | None = None,
                 nthreads: int = 1, tree: cKDTree | None = None):
        self.n = points.shape[0]
        self.s, self.a = float(s), float(s) - 1.0
        self.c = kernel_constant(self.s)
        self.delta = operator_radius(self.n) if delta is None else float(delta)
        self.nthreads = int(nthreads)
        ff = far_field_expansion(self.s, self.delta)
        self.lmax = ff.lmax
        self._loc = _to_theta_phi(points)
        l_of = np.concatenate([np.arange(m, ff.lmax + 1) for m in range(ff.lmax + 1)])
        self._weights = ff.sh_weights[l_of]
        tree = cKDTree(points) if tree is None else tree
        self.near = _near_matrix(points, tree, self.delta, self.a, ff.near_cheb)
        self.products = 0

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """K x for x (N, C); returns (N, C)."""
        import ducc0
        self.products += 1
        out = np.asarray(self.near @ x)
        for j in range(x.shape[1]):
            alm = ducc0.sht.adjoint_synthesis_general(
                lmax=self.lmax, spin=0, map=np.ascontiguousarray(x[:, j])[None, :], loc=self._loc,
                epsilon=SHT_EPSILON, nthreads=self.nthreads)
            alm *= self._weights
            far = ducc0.sht.synthesis_general(alm=alm, spin=0, lmax=self.lmax, loc=self._loc,
                                              epsilon=SHT_EPSILON, nthreads=self.nthreads)
            out[:, j] += far[0]
        # K x = c_s (sum x) - sum_j x_j g(|p_i - p_j|^2)
        np.subtract(self.c * x.sum(axis=0), out, out=out)
        return out


def _near_matrix(points, tree, delta, a, cheb) -> sp.csr_matrix:
    r"""Sparse :math:`(g - P_L)(d^2_{ij})` for :math:`d_{ij} < \delta`, diagonal
    :math:`-P_L(1)` (:math:`g(0) = 0`); :math:`P_L` near the cusp from its Chebyshev
    coefficients in :math:`d^2` (:class:`~envfit.sobolev._nearfar.FarFieldExpansion`)."""
    n = points.shape[0]
    pairs = tree.query_pairs(delta, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d2 = np.sum((points[i] - points[j]) ** 2, axis=1)
    keep = d2 < delta * delta
    i, j, d2 = i[keep], j[keep], d2[keep]
    x = 2.0 * d2 / (delta * delta) - 1.0
    v = d2 ** a - np.polynomial.chebyshev.chebval(x, cheb)
    diag = -float(np.polynomial.chebyshev.chebval(-1.0, cheb))
    idx = np.arange(n)
    m = sp.coo_matrix((np.concatenate([v, v, np.full(n, diag)]),
                       (np.concatenate([i, j, idx]), np.concatenate([j, i, idx]))), shape=(n, n))
    return m.tocsr()


def _kernel_block(p: np.ndarray, q: np.ndarray, s: float) -> np.ndarray:
    """Dense K(p_i, q_j) from coordinate differences (small blocks only)."""
    d2 = np.sum((p[:, None, :] - q[None, :, :]) ** 2, axis=-1)
    return kernel_constant(s) - d2 ** (s - 1.0)


# ---------------------------------------------------------------------- preconditioner

class LagrangePreconditioner:
    """Local Lagrange functions + a coarse level (see the module docstring).

    Attributes: ``z`` (the symmetrised :math:`Z_s`, CSR), ``coarse`` (indices S),
    ``k``, ``m``, ``seconds`` (build time).
    """

    def __init__(self, points: np.ndarray, s: float, *, k: int = LOCAL_NEIGHBOURS,
                 m: int | None = None, tree: cKDTree | None = None, nthreads: int = 1):
        t0 = time.perf_counter()
        n = points.shape[0]
        self.s = float(s)
        self.k = int(min(k, n))
        tree = cKDTree(points) if tree is None else tree
        self.z = _local_lagrange(points, tree, self.s, self.k)
        m = iterative_coarse_nodes(n) if m is None else int(min(m, max(1, n // 4)))
        _, near = tree.query(sphere_points("sf", m, seed=0), k=1)
        self.coarse = np.unique(near)
        self.m = self.coarse.size
        cp = self._coarse_points = points[self.coarse]
        self._coarse_cells = None
        self.nthreads = int(nthreads)
        self._coarse_xyz = tuple(np.ascontiguousarray(cp[:, i]) for i in range(3))
        self._nodes = np.ascontiguousarray(points)
        with _one_blas_thread():
            self._coarse_factor = cho_factor(_kernel_block(cp, cp, self.s), lower=True)
        self.seconds = time.perf_counter() - t0

    def local(self, r: np.ndarray) -> np.ndarray:
        r""":math:`Z_s r`."""
        return np.asarray(self.z @ r)

    def coarse_coefficients(self, r: np.ndarray) -> np.ndarray:
        r""":math:`K_{SS}^{-1} r_S` (m, C)."""
        with _one_blas_thread():
            return cho_solve(self._coarse_factor, r[self.coarse])

    def coarse_solve(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""``(Q r, K Q r)``: :math:`Q r = S^T K_{SS}^{-1} r_S` and its product with K."""
        y = self.coarse_coefficients(r)
        qr = np.zeros_like(r)
        qr[self.coarse] = y
        return qr, self._coarse_product(y)

    def _coarse_product(self, y: np.ndarray) -> np.ndarray:
        r""":math:`K_{:,S}\, y` at every node: :math:`c_s \sum y - \sum_j y_j |p_i - p_j|^{2s-2}`
        (m sources): direct fused numba sums below :data:`_COARSE_DIRECT_MAX` pairs, else the
        near/far split (:func:`~envfit.sobolev._nearfar.nearfar_power_sums`)."""
        a = self.s - 1.0
        kind = _kernels.power_kind(a)
        n, nc = self._nodes.shape[0], y.shape[1]
        if n * self.m > _COARSE_DIRECT_MAX:
            if self._coarse_cells is None:
                self._coarse_delta = near_radius(self.m)
                self._coarse_cells = CellList.build(self._coarse_points, self._coarse_delta)
            out = nearfar_power_sums(self._coarse_points, self._coarse_cells, self._nodes,
                                     np.asarray(y, order="F"), self.s, self._coarse_delta,
                                     a, kind, self.nthreads)
        else:
            out = np.empty((n, nc))
            px, py, pz = self._coarse_xyz
            for c in range(nc):
                col = np.empty(n)
                _kernels.power_sums_1(self._nodes, px, py, pz, np.ascontiguousarray(y[:, c]),
                                      a, kind, col)
                out[:, c] = col
        np.subtract(kernel_constant(self.s) * y.sum(axis=0), out, out=out)
        return out


def _local_lagrange(points, tree, s, k) -> sp.csr_matrix:
    """:math:`Z_s = (Z + Z^T)/2`, Z's column i the local Lagrange coefficients of node i."""
    n = points.shape[0]
    _, nb = tree.query(points, k=k, workers=-1)
    nb = np.ascontiguousarray(nb.reshape(n, k), dtype=np.int64)
    # the query lists node i first (distance 0); make sure of it with exact duplicates
    first = nb[:, 0] != np.arange(n)
    if first.any():
        rows = np.nonzero(first)[0]
        pos = np.argmax(nb[rows] == rows[:, None], axis=1)
        nb[rows, pos] = nb[rows, 0]
        nb[rows, 0] = rows
    coef = np.empty((n, k))
    xyz = [np.ascontiguousarray(points[:, i]) for i in range(3)]
    _kernels.local_lagrange(*xyz, nb, s - 1.0, _kernels.power_kind(s - 1.0),
                            kernel_constant(s), coef)
    cols = np.repeat(np.arange(n), k)
    z = sp.csr_matrix((coef.ravel(), (nb.ravel(), cols)), shape=(n, n))
    return ((z + z.T) * 0.5).tocsr()


# --------------------------------------------------------------------------------- CG

@dataclass(frozen=True)
class SolveInfo:
    """How the coefficients were obtained (one per solve).

    ``solver``: ``"cholesky"`` or ``"iterative"``; ``reason``: why (``auto``'s choice);
    ``iterations``: CG iterations (0 for Cholesky); ``products``: full K products;
    ``residual``: per channel :math:`\\|f - K\\alpha\\|_2 / \\|f\\|_2` (true residual with the
    near/far product; NaN where not computed); ``error_bound``: per channel bound of
    :math:`\\sup_x |\\tilde f_{\\rm iter}(x) - \\tilde f_{\\rm exact}(x)|` (module doc);
    ``tol``: the bound it was asked for; ``lambda_min``, ``lambda_max``: Ritz estimates of
    the spectrum of BK; ``fallback``: why the iterative path was abandoned for the dense
    one (CG breakdown or no convergence, ``solver="auto"`` only; empty when it was not);
    ``seconds_setup``, ``seconds_solve``.
    """
    solver: str
    reason: str
    iterations: int = 0
    products: int = 0
    residual: tuple = ()
    error_bound: tuple = ()
    tol: float = float("nan")
    lambda_min: float = float("nan")
    lambda_max: float = float("nan")
    converged: bool = True
    fallback: str = ""
    seconds_setup: float = 0.0
    seconds_solve: float = 0.0

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


def _ritz_extremes(alphas, betas) -> tuple[float, float]:
    r"""Smallest and largest Ritz value of one column's CG run: the extreme eigenvalues of
    its Lanczos tridiagonal matrix :math:`T_k` (Saad, *Iterative Methods for Sparse Linear
    Systems*, 2nd ed., Sec. 6.7.3):

    .. math:: (T_k)_{jj} = \frac{1}{\alpha_j} + \frac{\beta_j}{\alpha_{j-1}}, \qquad
              (T_k)_{j,j+1} = \frac{\sqrt{\beta_{j+1}}}{\alpha_j}

    (:math:`\beta_0 = 0`) from the k step lengths ``alphas`` and the k − 1 ratios
    ``betas`` = :math:`\beta_1 \ldots \beta_{k-1}`. ``k = 0`` (no Krylov step: the column
    met its tolerance at the start, e.g. on a warm start) gives ``(nan, nan)``; ``k = 1``
    the Rayleigh quotient :math:`1/\alpha_0`. Only the leading steps with a finite positive
    :math:`\alpha` and finite non-negative :math:`\beta` are used (a breakdown ends the
    Lanczos relation there).
    """
    a = np.asarray(alphas, dtype=np.float64).ravel()
    b = np.asarray(betas, dtype=np.float64).ravel()
    if b.size != max(a.size - 1, 0):
        raise ValueError(f"need k - 1 = {max(a.size - 1, 0)} betas for k = {a.size} step "
                         f"lengths, got {b.size}")
    good = np.isfinite(a) & (a > 0)
    good[1:] &= np.isfinite(b) & (b >= 0)
    k = int(np.argmin(good)) if not good.all() else a.size
    if k == 0:
        return float("nan"), float("nan")
    a, b = a[:k], b[:k - 1]
    diag = 1.0 / a
    diag[1:] += b / a[:-1]
    if k == 1:
        return float(diag[0]), float(diag[0])
    ev = eigvalsh_tridiagonal(diag, np.sqrt(b) / a[:-1])
    return float(ev[0]), float(ev[-1])


def _coldot(a, b):
    return np.einsum("ij,ij->j", a, b)


def _finite_min(*values) -> float:
    """The smallest finite value among the arrays / numbers given; NaN if there is none."""
    v = np.concatenate([np.ravel(np.asarray(x, dtype=np.float64)) for x in values])
    v = v[np.isfinite(v)]
    return float(v.min()) if v.size else float("nan")


def _lambda_for_bound(lam_min: np.ndarray, prior: float) -> np.ndarray:
    r"""Per column, the :math:`\lambda_{\min}(BK)` estimate the stopping bound divides by:
    the column's own smallest Ritz value; for a column without Krylov steps yet (the first
    pass, or a column that met its tolerance at once) the smallest Ritz value of the other
    columns or of earlier solves (``prior``; BK is one operator for all of them), else 1
    (the preconditioner's design point, BK ≈ I)."""
    shared = _finite_min(lam_min, prior)
    fallback = shared if math.isfinite(shared) else 1.0
    return np.where(np.isfinite(lam_min), lam_min, fallback)


def pcg_adef2(op: NodeOperator, prec: LagrangePreconditioner, f: np.ndarray, tol: np.ndarray,
              maxiter: int, x0: np.ndarray | None = None,
              lambda_prior: float = float("nan")) -> tuple[np.ndarray, dict]:
    r"""A-DEF2 preconditioned CG on :math:`K x = f` for every column of f (N, C).

    ``tol`` (C,): stop a column when :math:`\sqrt{c_s r^T z / (\lambda_{\min}/2)} \le`
    ``tol`` (the sup-norm bound of the interpolant's change, module docstring), with
    :math:`\lambda_{\min}` from :func:`_lambda_for_bound` (``lambda_prior``: the smallest
    Ritz value of earlier solves with the same operator; a column that meets its tolerance
    at once keeps an empty Lanczos matrix). ``x0`` (warm start :math:`\bar x`) enters as
    :math:`x_0 = \bar x + Q(f - K\bar x)`. Returns ``(x, stats)``: ``iterations``,
    ``bound`` (C,), ``lambda_min``, ``lambda_max`` (NaN if no step), ``converged``.
    """
    nc, cs = f.shape[1], op.c
    if x0 is None:
        x, kx = prec.coarse_solve(f)
    else:
        kx0 = op.matvec(x0)
        q, kq = prec.coarse_solve(f - kx0)
        x, kx = x0 + q, kx0 + kq
    r = f - kx
    p = kp = rz_old = None
    active = np.ones(nc, dtype=bool)
    alphas = [[] for _ in range(nc)]
    betas = [[] for _ in range(nc)]
    lam = (np.full(nc, np.nan), np.full(nc, np.nan))
    it = 0
    while True:
        y = prec.local(r)
        ky = op.matvec(y)
        q, kq = prec.coarse_solve(r - ky)
        z, kz = y + q, ky + kq
        rz = _coldot(r, z)
        lmin = _lambda_for_bound(lam[0], lambda_prior)
        bound = np.sqrt(cs * np.maximum(rz, 0.0) / np.maximum(0.5 * lmin, 1e-3))
        active &= bound > tol
        if not active.any() or it >= maxiter or np.any(rz[active] <= 0):
            break
        if p is None:
            p, kp = z.copy(), kz.copy()
            beta = np.zeros(nc)
        else:
            beta = np.where(active, rz / np.where(rz_old != 0, rz_old, 1.0), 0.0)
            p = z + beta * p
            kp = kz + beta * kp
        pkp = _coldot(p, kp)
        if np.any(pkp[active] <= 0):          # K p · p ≤ 0: breakdown (K not SPD in floats)
            break
        step = np.where(active, rz / np.where(active, pkp, 1.0), 0.0)
        x += step * p
        r -= step * kp
        for c in np.nonzero(active)[0]:
            if alphas[c]:
                betas[c].append(beta[c])
            alphas[c].append(step[c])
            lam[0][c], lam[1][c] = _ritz_extremes(alphas[c], betas[c])
        rz_old = rz
        it += 1
    return x, {"iterations": it, "bound": bound, "lambda_min": _finite_min(lam[0]),
               "lambda_max": -_finite_min(-lam[1]), "converged": bool(not active.any())}


class IterativeSolver:
    """The product and the preconditioner of one node set and s, reused for every solve.

    ``solve(f, tol)`` returns ``(alpha, SolveInfo)``; ``tol`` is the sup-norm bound of the
    reconstruction's change (absolute, per channel).
    """

    def __init__(self, points: np.ndarray, s: float, *, k: int = LOCAL_NEIGHBOURS,
                 m: int | None = None, nthreads: int = 1, maxiter: int = 200):
        if k < 2 or (m is not None and m < 1) or maxiter < 1:
            raise ParameterError(f"iterative solver: need k >= 2, m >= 1, maxiter >= 1 "
                                 f"(got k={k}, m={m}, maxiter={maxiter})")
        t0 = time.perf_counter()
        tree = cKDTree(points)
        self.op = NodeOperator(points, s, nthreads=nthreads, tree=tree)
        self.prec = LagrangePreconditioner(points, s, k=k, m=m, tree=tree, nthreads=nthreads)
        self.maxiter = int(maxiter)
        #: the smallest Ritz value of BK seen by any solve so far (NaN before the first step)
        self.lambda_min_seen = float("nan")
        self.seconds_setup = time.perf_counter() - t0

    def solve(self, f: np.ndarray, tol: np.ndarray, *, reason: str = "",
              x0: np.ndarray | None = None) -> tuple[np.ndarray, SolveInfo]:
        """CG for ``f`` (N, C) to the sup-norm bound ``tol`` (per channel), optionally warm
        started at ``x0``. The smallest Ritz value seen by any solve of this solver is kept
        (``lambda_min_seen``) and used for columns that take no step (:func:`pcg_adef2`).

        Raises :class:`IterativeSolverError` when the Krylov iteration breaks down
        numerically (an exception of the linear algebra, or non-finite coefficients); a run
        that ends unconverged is returned with ``converged=False``."""
        t0 = time.perf_counter()
        before = self.op.products
        try:
            x, st = pcg_adef2(self.op, self.prec, f, np.broadcast_to(tol, (f.shape[1],)),
                              self.maxiter, x0=x0, lambda_prior=self.lambda_min_seen)
            res = f - self.op.matvec(x)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            raise IterativeSolverError(f"CG broke down ({type(exc).__name__}: {exc})") from None
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(res))):
            raise IterativeSolverError("CG broke down (non-finite coefficients)")
        self.lambda_min_seen = _finite_min(self.lambda_min_seen, st["lambda_min"])
        fn = np.linalg.norm(f, axis=0)
        rel = np.linalg.norm(res, axis=0) / np.where(fn > 0, fn, 1.0)
        info = SolveInfo(solver="iterative", reason=reason, iterations=st["iterations"],
                         products=self.op.products - before,
                         residual=tuple(float(v) for v in rel),
                         error_bound=tuple(float(v) for v in st["bound"]),
                         tol=float(np.max(tol)), lambda_min=st["lambda_min"],
                         lambda_max=st["lambda_max"], converged=st["converged"],
                         seconds_setup=self.seconds_setup,
                         seconds_solve=time.perf_counter() - t0)
        return x, info

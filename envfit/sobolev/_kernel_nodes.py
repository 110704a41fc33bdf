r"""The kernel on a node set: the nodes in the layout the numba kernels read, the kernel
matrix factorised in place, and the sums :math:`\sum_j \alpha_j |q - p_j|^{2s-2}` that
evaluate an interpolant (:class:`envfit.sobolev._interpolation.SobolevInterpolator`).

Marques, Bouville, Bouatouch, Sec. 9.1, Eq. 14: the interpolant
:math:`\tilde f(q) = c_s \sum_j \alpha_j - \sum_j \alpha_j |q - p_j|^{2s-2}` is evaluated
from these power sums by one of two methods:

``"direct"`` (exact)
    a fused numba loop (distance, power, accumulation; no temporaries) with a
    vectorised float64 power (``envfit.sobolev._interpolation_kernels.fast_pow``, ~1e-15 relative; ``sqrt``
    for s = 1.5). M N power evaluations; more than three channels go through a bounded
    power block and BLAS.
``"nearfar"`` (fast summation, :mod:`envfit.sobolev._nearfar`)
    the kernel's power part :math:`g(t) = (2 - 2t)^{s-1}`, ``t = q.p``, is replaced
    outside a cap of chordal radius :math:`\delta` by a polynomial :math:`P_L(t)`
    (Chebyshev interpolation on :math:`[-1, 1 - \delta^2/2]` truncated at 1e-15;
    L ~ 20-25/delta), which by the addition theorem is a spherical-harmonic convolution:
    :math:`\sum_j \alpha_j P_L(q\cdot p_j) = \sum_{lm} w_l Y_{lm}(q) \sum_j \alpha_j
    Y^*_{lm}(p_j)` (two ducc0 NUFFT-based SH transforms, accuracy 3e-13). Pairs closer
    than :math:`\delta` get the exact correction :math:`g - P_L` (3-D cell list,
    ~8 neighbours per query). Cost O(C (L^2 log L + M + N)) for the transforms plus
    ~8 M C near pairs, instead of M N C; error
    ~1e-12 :math:`\sum_j |\alpha_j K(q, p_j)|` (vs ~1e-15 for direct), which is far
    below the interpolation error (the RMSE against a map is unchanged to 6+ digits).

``"auto"`` (default) picks ``"nearfar"`` when M N >= 5e7 and N >= 500.

>>> import numpy as np
>>> nodes = KernelNodes.build(np.eye(3), 1.5)
>>> out = nodes.power_sums_direct(np.array([[0.0, 0.0, 1.0]]), np.ones((3, 1)))
>>> bool(np.isclose(out[0, 0], 2 * 2 ** 0.5))     # |z - x| = |z - y| = sqrt 2, |z - z| = 0
True
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numba
import numpy as np
from scipy.spatial import cKDTree

from envfit.theory import cholesky_inplace
from envfit.theory import kernel_constant

from envfit.base import DuplicatePointsError
from envfit.sobolev import _interpolation_kernels as _kernels
from envfit.sobolev._nearfar import CellList, near_radius, nearfar_power_sums

__all__ = ["KernelNodes", "EVAL_METHODS", "DUPLICATE_DISTANCE", "closest_pair", "nthreads"]

#: two nodes closer than this (chordal distance) are duplicates
DUPLICATE_DISTANCE = 1e-12
#: a Cholesky pivot p with p^2 < this * c_s means coincident nodes (rounding-level pivot)
_SINGULAR_PIVOT = 64 * np.finfo(np.float64).eps

EVAL_METHODS = ("auto", "direct", "nearfar")
#: bytes of temporaries one evaluation block may use
BLOCK_BYTES = 64 * 2**20
#: "auto" uses near/far above this many kernel entries (and N >= _AUTO_MIN_N)
_AUTO_MIN_ENTRIES = 5e7
_AUTO_MIN_N = 500


def closest_pair(points: np.ndarray) -> tuple[int, int, float]:
    """Indices (i < j) and chordal distance of the closest pair of nodes (kd-tree, O(N log N))."""
    if points.shape[0] < 2:
        return 0, 0, math.inf
    dist, idx = cKDTree(points).query(points, k=2)
    i = int(np.argmin(dist[:, 1]))
    # with exact duplicates the query may list the point itself second: take the other one
    j = int(idx[i, 1]) if int(idx[i, 1]) != i else int(idx[i, 0])
    return min(i, j), max(i, j), float(dist[i, 1])


def nthreads() -> int:
    """The numba thread count (every kernel, BLAS call and ducc0 transform uses all cores)."""
    return max(1, int(numba.get_num_threads()))


@dataclass
class KernelNodes:
    r"""Unit-vector nodes :math:`p_j` and the kernel :math:`K^{(s)}_{gd}` on them (Eq. 14).

    ``px, py, pz`` are the contiguous coordinates the numba kernels read, ``a = s - 1`` the
    exponent of the power part with its :func:`~envfit.sobolev._interpolation_kernels.power_kind`, and
    ``constant`` :math:`c_s = 2^{2s-1}/s`. The cell lists of the near/far split are built on
    first use and kept per near radius.
    """
    points: np.ndarray
    s: float
    a: float
    kind: int
    constant: float
    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray
    cells: dict = field(default_factory=dict, repr=False)

    @classmethod
    def build(cls, pts: np.ndarray, s: float) -> "KernelNodes":
        """The nodes ``pts`` (N, 3, unit vectors, checked by the caller) for smoothness s."""
        a = s - 1.0
        return cls(points=pts, s=s, a=a, kind=_kernels.power_kind(a), constant=kernel_constant(s),
                   px=np.ascontiguousarray(pts[:, 0]), py=np.ascontiguousarray(pts[:, 1]),
                   pz=np.ascontiguousarray(pts[:, 2]))

    @property
    def n(self) -> int:
        return self.points.shape[0]

    def factorize(self, timings: dict) -> np.ndarray:
        r"""The lower Cholesky factor of :math:`K_{ij} = c_s - |p_i - p_j|^{2a}`, in place.

        The only N x N allocation: a Fortran-ordered buffer whose lower triangle a numba
        kernel writes, factorised by :func:`envfit.theory._cholesky.cholesky_inplace`.
        Records ``timings["matrix"]`` and ``timings["cholesky"]`` (seconds). Raises
        :class:`~envfit.base._errors.DuplicatePointsError`, naming the closest pair, when K is
        numerically singular (a failed pivot, or one at rounding level).
        """
        n = self.n
        t0 = time.perf_counter()
        # zeros (calloc: pages are zeroed lazily, no extra pass) so the unused upper triangle
        # holds no garbage: cho_solve(check_finite=True) on .cholesky must not see NaNs
        buf = np.zeros((n, n), dtype=np.float64, order="F")
        _kernels.fill_kernel_matrix(self.px, self.py, self.pz, self.a, self.kind, self.constant, buf)
        t1 = time.perf_counter()
        info = cholesky_inplace(buf)
        timings["matrix"] = t1 - t0
        timings["cholesky"] = time.perf_counter() - t1
        if info < 0:  # pragma: no cover - argument error
            raise RuntimeError(f"dpotrf argument {-info} is invalid")
        if info == 0:
            # coincident nodes can also slip through with a pivot at rounding level
            pivot = float(np.min(np.diagonal(buf)))
            if pivot * pivot >= _SINGULAR_PIVOT * self.constant:
                return buf
        i, j, d = closest_pair(self.points)
        where = f"dpotrf failed at column {info}" if info > 0 else "a pivot at rounding level"
        raise DuplicatePointsError(
            f"the {n}x{n} kernel matrix is numerically singular ({where}); closest nodes: "
            f"points {i} and {j} at distance {d:.1e}: remove or merge (near-)duplicate samples")

    def method_for(self, m: int, method: str) -> str:
        """``"direct"`` or ``"nearfar"`` for M = ``m`` queries (``"auto"``: by M N and N)."""
        if method != "auto":
            return method
        return "nearfar" if (m * self.n >= _AUTO_MIN_ENTRIES and self.n >= _AUTO_MIN_N) else "direct"

    def power_sums_direct(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        r""":math:`\sum_j \alpha_{jc} |q_i - p_j|^{2a}`, (M, C), by the fused numba loops."""
        m, nc = q.shape[0], alpha.shape[1]
        out = np.empty((m, nc))
        a, kind, px, py, pz = self.a, self.kind, self.px, self.py, self.pz
        if nc == 1:
            _kernels.power_sums_1(q, px, py, pz, np.ascontiguousarray(alpha[:, 0]), a, kind,
                                  out[:, 0])
        elif nc == 3:
            w = [np.ascontiguousarray(alpha[:, c]) for c in range(3)]
            _kernels.power_sums_3(q, px, py, pz, w[0], w[1], w[2], a, kind, out)
        else:  # many right-hand sides: power block (bounded memory) then BLAS
            rows = max(1, BLOCK_BYTES // (8 * self.n))
            block = np.empty((min(rows, m), self.n))
            for i0 in range(0, m, rows):
                i1 = min(m, i0 + rows)
                blk = block[: i1 - i0]
                _kernels.power_block(q[i0:i1], px, py, pz, a, kind, blk)
                np.matmul(blk, alpha, out=out[i0:i1])
        return out

    def cell_list(self, delta: float) -> CellList:
        """The nodes' cell list for near radius ``delta`` (built once)."""
        cl = self.cells.get(delta)
        if cl is None:
            cl = self.cells[delta] = CellList.build(self.points, delta)
        return cl

    def power_sums_nearfar(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        r"""The same sums by the near/far split (:func:`~envfit.sobolev._nearfar.nearfar_power_sums`)."""
        delta = near_radius(self.n)
        return nearfar_power_sums(self.points, self.cell_list(delta), q, alpha, self.s, delta,
                                  self.a, self.kind, nthreads())

r"""Kernel interpolation of scattered samples on the sphere with the generalized distance kernel.

Marques, Bouville, Bouatouch, Sec. 9.1 / Table 2: an environment map is sampled at N unit
vectors :math:`p_j` and reconstructed with the reproducing kernel of the Sobolev space
:math:`H^s(S^2)`,

.. math::  K^{(s)}_{gd}(u, v) = \frac{2^{2s-1}}{s} - |u - v|^{2s-2}, \qquad 1 < s < 2
           \quad (14)

.. math::  \tilde f(u) = \sum_{j=1}^N \alpha_j K(u, p_j), \qquad K\alpha = f

(:math:`K_{ij} = K(p_i, p_j)`, symmetric positive definite for distinct nodes). The
interpolant is the minimum-norm element of :math:`H^s` through the data and, under the
Gaussian-process reading (``envfit.theory._sobolev``), the posterior mean for the prior
covariance :math:`\sigma^2 K`.

Numerics
--------
* **Factorisation.** float64 Cholesky, *in place*: the matrix is written straight into a
  Fortran-ordered buffer (lower triangle only) by a parallel numba kernel and factorised by
  :func:`envfit.theory._cholesky.cholesky_inplace` (LAPACK ``dpotrf`` on 2048-column panels,
  BLAS-3 updates in tiles that stay clear of OpenBLAS's threaded-``dsyrk`` crash on
  AVX-512 CPUs at N >= 16 000; same speed as one ``dpotrf``): one N x N allocation, 3.2 GB at N = 20000
  (``scipy.linalg.cho_factor`` on a C-ordered matrix would copy it). The condition
  number grows like :math:`N^s` (~5e8 at s = 1.9, N = 20000), so there is no float32
  shortcut. A memory guard (:func:`envfit.base._resources.check_memory`) runs before the
  allocation and names the largest N that fits.
* **Distances** are formed from coordinate differences, ``|u - v|^2 = sum (u_k - v_k)^2``,
  which keeps full relative accuracy next to the cusp of the kernel; the Gram form
  ``2 - 2 u.v`` (a rank-3 "BLAS" product, memory bound anyway) loses it there.
* **Evaluation** :math:`\tilde f(q) = c_s \sum_j \alpha_j - \sum_j \alpha_j |q - p_j|^{2s-2}`
  by the power sums of :class:`envfit.sobolev._kernel_sums.KernelNodes`: ``"direct"`` (a fused
  numba loop, exact to ~1e-15), ``"nearfar"`` (an SH convolution plus an exact near-field
  correction, O(N log N), ~1e-12) or ``"auto"`` (``"nearfar"`` when M N >= 5e7 and N >= 500).
* **Threads.** numba kernels, BLAS/LAPACK calls and ducc0 transforms alternate and never
  overlap; each uses all cores (``numba.get_num_threads()``; BLAS via its own pool, limit it
  with ``threadpoolctl`` if the caller runs several interpolators in parallel).
* **Leave-one-out residuals** (Rippa 1999) :math:`e_i = \alpha_i / (K^{-1})_{ii}` need the
  diagonal of :math:`K^{-1} = L^{-T} L^{-1}`: :math:`(K^{-1})_{ii} = \|L^{-1} e_i\|^2`,
  computed in column blocks by BLAS ``dtrsm`` on the trailing triangle (no copy of L,
  N x 512 workspace). Cost N^3/3 flops, the same as the Cholesky factorisation itself
  (~45 s at N = 20000 on 2 cores); computed once and cached.
* **Profiled likelihood** :math:`\ell = -\tfrac12(N\log\hat\sigma^2 + \log\det K +
  N(1+\log 2\pi))`, :math:`\hat\sigma^2 = f^T K^{-1} f / N` per channel, log det from the
  Cholesky diagonal: O(N C) once the factor exists.

Example
-------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> p = rng.normal(size=(200, 3))
>>> f = p[:, 2] ** 2                      # any samples
>>> it = SobolevInterpolator(p, f, 1.5)
>>> bool(np.allclose(it(p), f, atol=1e-9))  # interpolates the data
True
"""
from __future__ import annotations

import time

import numpy as np
from scipy.linalg import lapack

from envfit.theory import inverse_diagonal

from envfit.sobolev._iterative import IterativeSolver, IterativeSolverError, SolveInfo
from envfit.sobolev._kernel_nodes import (BLOCK_BYTES, DUPLICATE_DISTANCE, EVAL_METHODS, KernelNodes,
                                          closest_pair, nthreads)
from envfit.sobolev._likelihood import ProfiledLikelihood, profiled_log_likelihood
from envfit.base import as_unit_vectors, check_s
from envfit.base import DuplicatePointsError, ParameterError
from envfit.base import (MEMORY_FRACTION, SOLVERS, available_memory_bytes, check_memory,
                         format_bytes, interpolator_nbytes, largest_feasible_n, memory_budget_bytes)

__all__ = ["SobolevInterpolator", "ProfiledLikelihood", "as_unit_vectors", "SolveInfo",
           "DUPLICATE_DISTANCE", "EVAL_METHODS", "SOLVERS", "SOLVER_RTOL", "AUTO_ITERATIVE_MIN_N"]

#: iterative solver's default stopping rule: the bound of the interpolant's change
#: (sup norm) at most this times the RMS of each channel's samples
SOLVER_RTOL = 1e-8
#: ``solver="auto"`` solves iteratively from this N on (below it the dense Cholesky is
#: as fast or faster). Measured with ``bench/bench_solver.py`` section (c) on the 2-core
#: AMD EPYC (Zen 4, AVX-512) of this project, forest.exr samples, 3 channels, s = 1.5, load
#: 2.4-3.6: Cholesky / iterative fit 0.20 / 0.32 s at N = 1000, 0.41 / 0.42 s at 2000,
#: 0.86 / 0.62 s at 3000, 2.21 / 0.82 s at 4000 (docs/performance.md, "The iterative solver").
AUTO_ITERATIVE_MIN_N = 3000


# ----------------------------------------------------------------------------- helpers

def _as_values(values, n: int, *, name: str = "values") -> tuple[np.ndarray, bool]:
    """(N, C) float64 Fortran-ordered copy of ``values`` and whether the input was 1-D."""
    try:
        v = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a numeric array") from None
    vector = v.ndim == 1
    if vector:
        v = v[:, None]
    if v.ndim != 2 or v.shape[0] != n:
        raise ParameterError(f"{name} must have shape ({n},) or ({n}, C), got {np.shape(values)}")
    if v.shape[1] == 0:
        raise ParameterError(f"{name} has no channels")
    if not np.isfinite(v).all():
        raise ParameterError(f"{name} contain NaN or Inf")
    return np.array(v, dtype=np.float64, order="F"), vector


# ------------------------------------------------------------------ the interpolator

class SobolevInterpolator:
    r"""Interpolate values at unit vectors with the generalized distance kernel (Eq. 14).

    Parameters
    ----------
    points : (N, 3) array
        Node directions (normalised here; NaN/Inf or zero vectors are rejected).
    values : (N,) or (N, C) array
        Samples (one column per channel or per map; one factorisation serves them all).
    s : float
        Sobolev smoothness, 1 < s < 2.
    check_duplicates : bool
        Look for nodes closer than :data:`DUPLICATE_DISTANCE` before factorising
        (kd-tree, O(N log N)). A failed factorisation is always reported as
        :class:`~envfit.base._errors.DuplicatePointsError` with the closest pair.

    Attributes
    ----------
    points (N, 3), s, n, nchannels, kernel_constant (:math:`c_s = 2^{2s-1}/s`),
    coefficients (:math:`\alpha`, N x C), cholesky (``(L, True)``, the in-place factor as
    :func:`scipy.linalg.cho_solve` expects it), log_det (:math:`\log\det K`).

    Raises
    ------
    ParameterError, DuplicatePointsError, MemoryBudgetError

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> p = rng.normal(size=(300, 3)); f = np.c_[p[:, 0], p[:, 1] ** 2]
    >>> it = SobolevInterpolator(p, f, 1.7)
    >>> it.coefficients.shape, it([0.0, 0.0, 1.0]).shape
    ((300, 2), (2,))
    """

    def __init__(self, points, values, s, *, check_duplicates: bool = True,
                 solver: str = "auto", rtol: float = SOLVER_RTOL):
        self.s = check_s(s)
        if solver not in SOLVERS:
            raise ParameterError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
        if not (isinstance(rtol, (int, float)) and 0.0 < float(rtol) < 1.0):
            raise ParameterError(f"rtol must be a number in (0, 1), got {rtol!r}")
        pts = as_unit_vectors(points)
        n = pts.shape[0]
        vals, self._vector = _as_values(values, n)
        self._setup_nodes(pts, vals.shape[1])
        self._solver_mode = solver
        path, reason = self._choose_solver(solver)
        budget = available_memory_bytes() * MEMORY_FRACTION
        what = (f"interpolating {n} samples (the {n}x{n} float64 kernel matrix alone is "
                f"{format_bytes(8.0 * n * n)})" if path == "cholesky" else
                f"interpolating {n} samples with the iterative solver (sparse preconditioner "
                f"and near-field matrix, O(N k))")
        check_memory(interpolator_nbytes(n, self.nchannels, path), what,
                     hint=f"the largest N that fits is "
                          f"{largest_feasible_n(budget, self.nchannels, path)}")
        if check_duplicates and n > 1:
            i, j, d = closest_pair(pts)
            if d < DUPLICATE_DISTANCE:
                raise DuplicatePointsError(
                    f"points {i} and {j} coincide (distance {d:.1e} < {DUPLICATE_DISTANCE:g}): "
                    f"the kernel matrix is singular; remove or merge duplicate samples")
        self._values = vals
        self.rtol = float(rtol)
        if path == "iterative":
            path, reason = self._solve_iterative(pts, vals, reason)
        if path == "cholesky":
            self._solve_dense(reason, fallback=self._fallback)
        self.last_solve_info = self.solve_info

    def _solve_dense(self, reason: str, fallback: str = "") -> None:
        """Factorise K and solve for the stored values (sets coefficients, solve_info)."""
        self._iterative = None
        self._factor = self._factorize()
        self.log_det = float(2.0 * np.sum(np.log(np.diagonal(self._factor))))
        t = time.perf_counter()
        self._alpha = self._solve_matrix(self._values)
        self.timings["solve"] = time.perf_counter() - t
        self.solve_info = SolveInfo(solver="cholesky", reason=reason, fallback=fallback,
                                    seconds_setup=self.timings["matrix"] + self.timings["cholesky"],
                                    seconds_solve=self.timings["solve"])

    def _solve_iterative(self, pts: np.ndarray, vals: np.ndarray, reason: str) -> tuple[str, str]:
        """CG (sets coefficients, solve_info); ``("cholesky", why)`` to fall back: ``auto``
        whose CG broke down or did not converge while the dense matrix fits. ``"iterative"``
        raises :class:`~envfit.sobolev._iterative.IterativeSolverError` then."""
        t = time.perf_counter()
        self._iterative = IterativeSolver(pts, self.s, nthreads=nthreads())
        self.timings["setup"] = time.perf_counter() - t
        try:
            self._alpha, self.solve_info = self._iterative.solve(vals, self._tol(vals),
                                                                 reason=reason)
        except IterativeSolverError as exc:
            return "cholesky", self._iterative_failed(reason, str(exc))
        self.timings["solve"] = self.solve_info.seconds_solve
        if self.solve_info.converged:
            return "iterative", reason
        return "cholesky", self._iterative_failed(
            reason, f"CG did not converge after {self.solve_info.iterations} iterations")

    def _iterative_failed(self, reason: str, why: str) -> str:
        """The reason of the dense fallback (``solver="auto"`` where K fits in memory);
        else :class:`~envfit.sobolev._iterative.IterativeSolverError` saying what to do."""
        fits = interpolator_nbytes(self.n, self.nchannels, "cholesky") <= memory_budget_bytes()
        if self._solver_mode == "auto" and fits:
            self._fallback = why
            return f"{reason}; {why}: dense fallback"
        hint = ("solver 'auto' falls back to the dense Cholesky path (--solver auto)"
                if fits else f"the dense {self.n}x{self.n} matrix does not fit in memory "
                             f"either: use fewer samples")
        raise IterativeSolverError(f"the iterative solver failed on {self.n} samples: {why}; "
                                   f"{hint}")

    def _setup_nodes(self, pts: np.ndarray, nchannels: int) -> None:
        """The attributes every interpolant has (nodes, s, constants), nothing solved yet."""
        self.n = pts.shape[0]
        self.nchannels = nchannels
        self._nodes = KernelNodes.build(pts, self.s)
        self.kernel_constant = self._nodes.constant
        self.points = pts
        #: wall-clock seconds of the construction steps ("matrix", "cholesky", "solve";
        #: iterative: "setup", "solve")
        self.timings = {}
        self._factor = None
        self._iterative = None
        self._fallback = ""
        self.log_det = float("nan")
        self._kinv_diag = None

    def _choose_solver(self, solver: str) -> tuple[str, str]:
        """The path (``"cholesky"`` or ``"iterative"``) and why."""
        if solver != "auto":
            return solver, f"solver={solver!r} requested"
        n = self.n
        if interpolator_nbytes(n, self.nchannels, "cholesky") > memory_budget_bytes():
            return "iterative", (f"auto: the dense {n}x{n} matrix does not fit in memory "
                                 f"({format_bytes(8.0 * n * n)})")
        if n >= AUTO_ITERATIVE_MIN_N:
            return "iterative", f"auto: N = {n} >= {AUTO_ITERATIVE_MIN_N} (measured crossover)"
        return "cholesky", f"auto: N = {n} < {AUTO_ITERATIVE_MIN_N} (measured crossover)"

    @property
    def solver(self) -> str:
        """``"cholesky"`` or ``"iterative"``: how :attr:`coefficients` were obtained."""
        return self.solve_info.solver

    def _tol(self, vals: np.ndarray) -> np.ndarray:
        """Per channel absolute bound of the interpolant's change: rtol x RMS(samples)."""
        rms = np.sqrt(np.mean(vals * vals, axis=0))
        return self.rtol * np.where(rms > 0, rms, np.finfo(float).tiny)

    def refine(self, tol) -> SolveInfo:
        r"""Iterate on until the interpolant moves by at most ``tol`` (absolute, sup norm;
        scalar or per channel) from the exact solution; warm start from the current
        coefficients. Returns (and stores in :attr:`solve_info`) the new solve's record.
        Cholesky interpolants are exact already: their record is returned unchanged. With
        ``solver="auto"``, a refinement whose CG breaks down or does not converge is replaced
        by the dense solve where K fits (``solve_info.fallback`` says why)."""
        if self._iterative is None:
            return self.solve_info
        tol = np.broadcast_to(np.asarray(tol, dtype=np.float64), (self.nchannels,))
        reason = self.solve_info.reason
        try:
            alpha, info = self._iterative.solve(self._values, tol, reason=reason, x0=self._alpha)
        except IterativeSolverError as exc:
            self._solve_dense(self._iterative_failed(reason, f"refinement: {exc}"),
                              fallback=f"refinement: {exc}")
            return self.solve_info
        if not info.converged and self._solver_mode == "auto":
            why = f"refinement: CG did not converge after {info.iterations} iterations"
            try:
                self._solve_dense(self._iterative_failed(reason, why), fallback=why)
                return self.solve_info
            except IterativeSolverError:
                pass                 # the dense matrix does not fit: keep the CG result
        self._alpha = alpha
        self.solve_info = info
        return info

    @classmethod
    def from_coefficients(cls, points, coefficients, s) -> "SobolevInterpolator":
        r"""An evaluation-only interpolant :math:`\sum_j \alpha_j K(\cdot, p_j)` from known
        coefficients :math:`\alpha` (N,) or (N, C), without building or factorising K.

        Used where the factorisation happened elsewhere (e.g. one factorisation solved for
        a whole library of maps, :mod:`envfit.batch._library`): evaluation needs only the nodes and
        :math:`\alpha` (O(N C) memory), so a worker can evaluate without the N x N factor.
        :meth:`evaluate` gives bit-for-bit what the fitted interpolator gives for the same
        :math:`\alpha`; :meth:`solve`, :meth:`loo_residuals` and
        :meth:`log_likelihood_profiled` raise :class:`~envfit.base._errors.ParameterError`.

        >>> import numpy as np
        >>> p = np.random.default_rng(2).normal(size=(50, 3))
        >>> full = SobolevInterpolator(p, p[:, 2], 1.5)
        >>> light = SobolevInterpolator.from_coefficients(p, full.coefficients[:, 0], 1.5)
        >>> bool(np.array_equal(light(p[:5]), full(p[:5])))
        True
        """
        self = cls.__new__(cls)
        self.s = check_s(s)
        pts = as_unit_vectors(points)
        alpha, self._vector = _as_values(coefficients, pts.shape[0], name="coefficients")
        self._setup_nodes(pts, alpha.shape[1])
        self._solver_mode = None
        self._values = None
        self._alpha = alpha
        self.solve_info = SolveInfo(solver="given", reason="from_coefficients")
        return self

    # -- construction ------------------------------------------------------------
    def _factorize(self) -> np.ndarray:
        """The in-place Cholesky factor of K (:meth:`~envfit.sobolev._kernel_nodes.KernelNodes.factorize`)."""
        return self._nodes.factorize(self.timings)

    # -- linear algebra ------------------------------------------------------------
    @property
    def cholesky(self) -> tuple[np.ndarray, bool]:
        """``(L, True)``: lower Cholesky factor of K (Fortran order, factorised in place).

        Only the lower triangle is meaningful (the strict upper one was never written).
        Usable directly with :func:`scipy.linalg.cho_solve`.
        """
        self._require_factor()
        return self._factor, True

    @property
    def coefficients(self) -> np.ndarray:
        r""":math:`\alpha = K^{-1} f`, shape (N, C)."""
        return self._alpha

    def _require_factor(self) -> None:
        """Make sure the dense factor exists: ``solver="auto"`` builds it on demand (log det,
        LOO, likelihood need it); ``"iterative"`` and ``from_coefficients`` raise."""
        if self._factor is not None:
            return
        if self._iterative is None:
            raise ParameterError("this interpolant was built from coefficients alone "
                                 "(from_coefficients): it has no factorisation to solve with")
        if self._solver_mode != "auto":
            raise ParameterError(
                "the log-determinant, leave-one-out residuals, likelihood and Cholesky factor "
                "need the dense factorisation, and this interpolator was built with "
                "solver='iterative': build it with solver='cholesky' (or 'auto', which "
                "factorises on demand)")
        n = self.n
        check_memory(interpolator_nbytes(n, self.nchannels, "cholesky"),
                     f"the dense factorisation for the log-determinant / LOO ({n}x{n} float64 "
                     f"kernel matrix, {format_bytes(8.0 * n * n)})",
                     hint="the iterative solver gives coefficients and evaluations, not log det K")
        self._factor = self._factorize()
        self.log_det = float(2.0 * np.sum(np.log(np.diagonal(self._factor))))

    def _solve_matrix(self, vals: np.ndarray) -> np.ndarray:
        self._require_factor()
        x, info = lapack.dpotrs(self._factor, vals, lower=1)
        if info != 0:  # pragma: no cover
            raise RuntimeError(f"dpotrs failed (info={info})")
        return x

    def solve(self, new_values) -> np.ndarray:
        r""":math:`K^{-1} f` for new samples at the same nodes (same factorisation, or the
        same iterative product and preconditioner).

        ``new_values`` (N,) or (N, C); the result has the same shape. Cost: two triangular
        solves, O(N^2 C); iterative: a few O(N log N) products per channel (stopping rule of
        the constructor's ``rtol``; the record is in :attr:`last_solve_info`).
        """
        vals, vector = _as_values(new_values, self.n, name="new_values")
        if self._factor is None and self._iterative is not None:
            x, self.last_solve_info = self._iterative.solve(vals, self._tol(vals),
                                                            reason=self.solve_info.reason)
        else:
            x = self._solve_matrix(vals)
        return x[:, 0] if vector else x

    def _coefficients_for(self, values):
        if values is None:
            self._require_factor()
            alpha = self._alpha if self._iterative is None else self._solve_matrix(self._values)
            return self._values, alpha, self._vector
        vals, vector = _as_values(values, self.n)
        return vals, self._solve_matrix(vals), vector

    def inverse_diagonal(self) -> np.ndarray:
        r""":math:`\mathrm{diag}(K^{-1})` (N,), computed once (N^3/3 flops, see module doc)."""
        self._require_factor()
        if self._kinv_diag is None:
            block = int(min(512, max(64, BLOCK_BYTES // (8 * max(self.n, 1)))))
            self._kinv_diag = inverse_diagonal(self._factor, block=block)
        return self._kinv_diag

    def loo_residuals(self, values=None) -> np.ndarray:
        r"""Leave-one-out residuals :math:`e_i = f_i - \tilde f^{(-i)}(p_i) = \alpha_i / (K^{-1})_{ii}`.

        Rippa's closed form: no refits. ``values`` default to the fitted ones; shape (N,) or
        (N, C) like them.
        """
        _, alpha, vector = self._coefficients_for(values)
        e = alpha / self.inverse_diagonal()[:, None]
        return e[:, 0] if vector else e

    def log_likelihood_profiled(self, values=None) -> ProfiledLikelihood:
        r"""GP marginal log-likelihood of the samples with the scale profiled out, per channel.

        Model :math:`f \sim N(0, \sigma^2 K)`; the maximising
        :math:`\hat\sigma^2 = f^T K^{-1} f / N` gives
        :math:`\ell = -\tfrac12 (N \log\hat\sigma^2 + \log\det K + N (1 + \log 2\pi))`.
        Returns ``(loglik, sigma)`` (:math:`\hat\sigma`), arrays of shape (C,) or scalars for
        1-D values (:func:`envfit.sobolev._likelihood.profiled_log_likelihood`, from this
        factorisation's solve and log-determinant).
        """
        vals, alpha, vector = self._coefficients_for(values)
        return profiled_log_likelihood(vals[:, 0] if vector else vals,
                                       alpha[:, 0] if vector else alpha, self.log_det)

    # -- evaluation ----------------------------------------------------------------
    def __call__(self, query) -> np.ndarray:
        """Interpolant at ``query`` (..., 3) directions: shape (...,) or (..., C) like ``values``."""
        return self.evaluate(query)

    def evaluate(self, query, coefficients=None, *, method: str = "auto") -> np.ndarray:
        r""":math:`\sum_j \alpha_j K(q, p_j)` at query directions (..., 3).

        ``coefficients`` (N,) or (N, C) default to the fitted :attr:`coefficients`; the
        output is (...,) or (..., C) accordingly. ``method``: ``"direct"``, ``"nearfar"``
        or ``"auto"`` (see the module docstring).
        """
        if method not in EVAL_METHODS:
            raise ParameterError(f"unknown evaluation method {method!r}; choose one of "
                                 f"{', '.join(EVAL_METHODS)}")
        qshape = np.shape(query)[:-1] if np.ndim(query) >= 1 else ()
        q = as_unit_vectors(query, name="query")
        if coefficients is None:
            alpha, vector = self._alpha, self._vector
        else:
            alpha, vector = _as_values(coefficients, self.n, name="coefficients")
        if self._nodes.method_for(q.shape[0], method) == "direct":
            out = self._power_sums_direct(q, alpha)
        else:
            out = self._power_sums_nearfar(q, alpha)
        # f(q) = c sum_j alpha_j - sum_j alpha_j |q - p_j|^(2s-2)
        np.subtract(self.kernel_constant * alpha.sum(axis=0), out, out=out)
        if vector:
            return out[:, 0].reshape(qshape)
        return out.reshape(qshape + (alpha.shape[1],))

    def _power_sums_direct(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        return self._nodes.power_sums_direct(q, alpha)

    def _power_sums_nearfar(self, q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        return self._nodes.power_sums_nearfar(q, alpha)

    def __repr__(self) -> str:
        return (f"SobolevInterpolator(n={self.n}, channels={self.nchannels}, s={self.s:g}, "
                f"solver={self.solve_info.solver}, log_det={self.log_det:.6g})")

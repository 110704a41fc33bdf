r"""Quadrature estimates of shading integrals (Eq. 34) for many axes and weightings at once.

Used by validation and the advisor; the worst-case error of a rule (Eq. 41) is
:func:`envfit.theory._quadrature.worst_case_error`.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from envfit.maps import EnvMap
from envfit.base import ParameterError
from envfit.shading._estimators import twisted_frames
from envfit.base import check_memory
from envfit.shading._spectra import (bandlimited_worst_case_error, bandlimited_worst_case_errors,
                                     low_degree_power_ratio, lookup_transfer, map_degree_power,
                                     model_scatter, pixel_degree_power, rule_error_power,
                                     sh_truncation_curve_transfer, spectral_rmse)


#: directions looked up per block (per thread) in :func:`quadrature_estimates_multi`
LOOKUP_BLOCK = 1 << 18


def random_axes(m: int, seed) -> np.ndarray:
    """M axes uniform on the sphere (normalised standard normal vectors), (M, 3).

    >>> a = random_axes(1000, 0)
    >>> a.shape, bool(np.allclose(np.linalg.norm(a, axis=1), 1)), bool(abs(a[:, 2].mean()) < 0.1)
    ((1000, 3), True, True)
    """
    v = np.random.default_rng(seed).standard_normal((int(m), 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def quadrature_estimates_multi(envmap: EnvMap, axes, local_points, weight_sets, *, seed=None,
                               workers: int = 2, block: int = LOOKUP_BLOCK) -> np.ndarray:
    r"""Eq. 34 for several weight vectors on the same rotated points, (K, M, C).

    :math:`\tilde I_k(a_m) = \sum_j w_{kj} f(R_m R_z(\alpha_m) u_j)` — exactly
    :func:`envfit.shading._estimators.quadrature_estimates` (same frames, same twist
    :math:`\alpha_m` drawn from ``numpy.random.default_rng(seed)``) for every weight vector,
    but the M·N bilinear lookups are done once and shared (equal weights and OSW use the
    same points), in blocks of ``block`` directions spread over ``workers`` threads (numpy
    releases the GIL in the lookup's array operations: ≈2× on 2 cores).

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((4, 8, 1), 2.0))
    >>> est = quadrature_estimates_multi(m, [[0, 1.0, 0]], [[0, 0, 1.0], [0.6, 0, 0.8]],
    ...                                  [[0.5, 0.5], [1.0, 0.0]], seed=0)
    >>> est.shape, est[:, 0, 0].round(12).tolist()
    ((2, 1, 1), [2.0, 2.0])
    """
    A = np.atleast_2d(np.asarray(axes, dtype=np.float64))
    if A.ndim != 2 or A.shape[1] != 3 or not np.all(np.isfinite(A)):
        raise ParameterError(f"axes must be finite with shape (M, 3), got {A.shape}")
    A = A / np.linalg.norm(A, axis=1, keepdims=True)
    P = np.asarray(local_points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] == 0 or not np.all(np.isfinite(P)):
        raise ParameterError(f"local_points must be finite with shape (N, 3), got {P.shape}")
    P = P / np.linalg.norm(P, axis=1, keepdims=True)
    W = np.atleast_2d(np.asarray(weight_sets, dtype=np.float64))
    if W.shape[1] != P.shape[0] or not np.all(np.isfinite(W)):
        raise ParameterError(f"weight_sets must be (K, {P.shape[0]}) finite, got {W.shape}")
    m_total, n = A.shape[0], P.shape[0]
    R = twisted_frames(A, seed)
    c = envmap.channels
    out = np.empty((W.shape[0], m_total, c))
    mb = max(1, int(block) // n)
    workers = max(1, int(workers))
    check_memory(workers * min(m_total, mb) * n * 8 * (8 + 2 * c),
                 f"{workers} blocks of {min(m_total, mb)} axes x {n} points",
                 hint="use fewer points or workers")

    def work(m0: int) -> None:
        m1 = min(m_total, m0 + mb)
        dirs = np.einsum("mij,nj->mni", R[m0:m1], P)
        vals = envmap.lookup(dirs)                                   # (mb, N, C)
        out[:, m0:m1, :] = np.einsum("mnc,kn->kmc", vals, W)

    starts = list(range(0, m_total, mb))
    if workers == 1 or len(starts) == 1:
        for m0 in starts:
            work(m0)
    else:
        with ThreadPoolExecutor(workers) as ex:
            list(ex.map(work, starts))
    return out

r"""Point sets on the hemisphere for shading integrals (Sec. 7.1 of the paper).

Marques, Bouville & Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Sec. 7.1, test six generators:
Sobol (0,2)-sequence, BNOT, Larcher–Pillichshammer, spherical Fibonacci, random and
stratified jitter. Every set goes through one pipeline:

1. **Unit square** :math:`(x, y) \in [0,1)^2` — the generators below. The spherical
   Fibonacci set, defined directly on the hemisphere, is returned in the same form
   :math:`(x, y) = (z', \phi/2\pi)`.
2. **Morph** (importance sampling, Sec. 7.2): :math:`z = m(z')` with m an increasing map
   of [0, 1] onto itself — :func:`morph_diffuse` (:math:`z=\sqrt{z'}`),
   :func:`morph_glossy` (Eq. 67) or any callable (e.g. a weight function's own morph).
   If the square points are uniform, the morphed directions have the density
   :math:`p(z) \propto dz'/dz` on the hemisphere.
3. **Lift** (Lambert cylindrical equal-area projection): :math:`z' = x`,
   :math:`\phi = 2\pi y`, direction :math:`(\sqrt{1-z^2}\cos\phi, \sqrt{1-z^2}\sin\phi, z)`
   in the local frame whose +z axis is the hemisphere's axis (the map's local frame
   convention: :math:`d = (\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta)`).
   The Jacobian of (x, y) ↦ d is the constant 2π, so area on the square is proportional
   to solid angle.
4. **Rotation** to the frames of shading points: :func:`frame_from_axis`,
   :func:`rotate_to_axes` (optionally with an independent random twist about each axis).

Examples
--------
>>> from envfit.theory._pointsets import generate, morph_diffuse
>>> d = generate("sobol", 1024, morph=morph_diffuse)
>>> d.shape, bool(abs(d[:, 2].mean() - 2 / 3) < 1e-2)
((1024, 3), True)
"""
from __future__ import annotations

import math
import warnings
from typing import Callable

import numpy as np

from envfit.theory._bnot import bnot_square
from envfit.theory._errors import TheoryParameterError

__all__ = ["GOLDEN_RATIO", "POINTSETS", "DETERMINISTIC_POINTSETS", "sobol02",
           "larcher_pillichshammer", "random_square", "stratified_jitter", "jitter_strata",
           "spherical_fibonacci", "square_points", "morph_diffuse", "morph_glossy",
           "lambert_to_hemisphere", "generate", "hemisphere_points", "frame_from_axis",
           "rotate_to_axes"]

GOLDEN_RATIO = (1.0 + math.sqrt(5.0)) / 2.0


def _check_n(n) -> int:
    try:
        k = int(n)
    except (TypeError, ValueError):
        raise TheoryParameterError(f"number of points must be an integer, got {n!r}") from None
    if k != n or k < 1:
        raise TheoryParameterError(f"number of points must be an integer >= 1, got {n!r}")
    return k


# ----------------------------------------------------------------------------- square sets
def sobol02(n: int, *, seed=None, scramble: bool = False) -> np.ndarray:
    r"""The first n points of the Sobol (0,2)-sequence in base 2 (Sobol 1967), (n, 2).

    Dimension 0 is the van der Corput sequence (generator matrix I), dimension 1 uses
    Sobol's second direction numbers (the Pascal matrix mod 2); together they form a
    (0,2)-sequence: for every m, each block of 2^m consecutive points (in particular the
    first 2^m) is a (0,m,2)-net — every dyadic box
    :math:`[a2^{-d_1},(a+1)2^{-d_1})\times[b2^{-d_2},(b+1)2^{-d_2})`,
    :math:`d_1+d_2=m`, holds exactly one point. Computed with
    ``scipy.stats.qmc.Sobol(d=2, scramble=False)``; the first point is (0, 0).

    The paper's Sobol set is deterministic (``scramble=False``, ``seed`` ignored). With
    ``scramble=True`` scipy's linear matrix scramble plus digital shift (Matoušek 1998) is
    applied with ``seed``; it preserves the net property.

    Examples
    --------
    >>> sobol02(4)
    array([[0.  , 0.  ],
           [0.5 , 0.5 ],
           [0.75, 0.25],
           [0.25, 0.75]])
    """
    n = _check_n(n)
    from scipy.stats import qmc  # local: scipy.stats costs ~1 s to import
    eng = qmc.Sobol(d=2, scramble=bool(scramble), seed=seed if scramble else None)
    with warnings.catch_warnings():  # "balance properties" warning for n != 2^m
        warnings.simplefilter("ignore", UserWarning)
        return eng.random(n)


def _parity(v: np.ndarray) -> np.ndarray:
    """Parity (XOR of all bits) of unsigned 64-bit integers, by folding."""
    v = v.copy()
    for s in (32, 16, 8, 4, 2, 1):
        v ^= v >> np.uint64(s)
    return v & np.uint64(1)


def _lp_radical_inverse(i: np.ndarray) -> np.ndarray:
    """LP radical inverse: digit j (1 = most significant) = XOR of the bits i_k, k ≥ j-1."""
    i = np.asarray(i, dtype=np.uint64)
    nbits = int(i.max()).bit_length() if i.size else 0
    acc = np.zeros(i.shape, dtype=np.uint64)
    for j in range(1, nbits + 1):
        bit = _parity(i >> np.uint64(j - 1))
        acc |= bit << np.uint64(nbits - j)
    return acc.astype(np.float64) / float(2 ** nbits) if nbits else np.zeros(i.shape)


def larcher_pillichshammer(n: int) -> np.ndarray:
    r"""The Larcher–Pillichshammer point set, (n, 2): :math:`(i/n,\ \Phi_{LP}(i))`.

    :math:`\Phi_{LP}` is the base-2 radical inverse with the upper-triangular all-ones
    generator matrix (Larcher & Pillichshammer 2001; the form used by Kollig & Keller,
    "Efficient multidimensional sampling", 2002): if :math:`i = \sum_k i_k 2^k` then
    digit j of :math:`\Phi_{LP}(i) = \sum_j y_j 2^{-j}` is
    :math:`y_j = i_{j-1} \oplus i_j \oplus i_{j+1} \oplus \dots` (the parity of
    :math:`\lfloor i/2^{j-1} \rfloor`).

    For n = 2^m it is a (0,m,2)-net in base 2 (one point in every dyadic box of area
    1/n) with particularly low L2 discrepancy. Any n ≥ 1 is accepted (a Hammersley-type
    set (i/n, Φ_LP(i)), low-discrepancy but a net only at powers of two). Deterministic.

    Examples
    --------
    >>> larcher_pillichshammer(4)
    array([[0.  , 0.  ],
           [0.25, 0.5 ],
           [0.5 , 0.75],
           [0.75, 0.25]])
    """
    n = _check_n(n)
    i = np.arange(n, dtype=np.uint64)
    return np.column_stack([np.arange(n, dtype=np.float64) / n, _lp_radical_inverse(i)])


def random_square(n: int, *, seed=None) -> np.ndarray:
    """n independent uniform points in [0,1)² (``numpy.random.default_rng(seed)``).

    >>> random_square(3, seed=0).shape
    (3, 2)
    """
    n = _check_n(n)
    return np.random.default_rng(seed).random((n, 2))


def jitter_strata(n: int) -> tuple[np.ndarray, np.ndarray]:
    r"""The n strata of :func:`stratified_jitter`: lower and upper corners, each (n, 2).

    k = round(√n) rows (bands in y); row r holds :math:`c_r = \lfloor n/k \rfloor` or
    :math:`\lceil n/k \rceil` cells (the first n mod k rows get one more), has height
    :math:`c_r/n` and is cut into :math:`c_r` equal cells of width :math:`1/c_r`. Every
    stratum has area exactly 1/n and aspect ratio near 1; when n is a perfect square this
    is the usual √n×√n grid, when n = k·m with k = round(√n) a k×m grid. Row-major order.

    >>> lo, hi = jitter_strata(4); lo.tolist()
    [[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.5, 0.5]]
    """
    n = _check_n(n)
    k = max(1, int(round(math.sqrt(n))))
    counts = np.full(k, n // k, dtype=np.int64)
    counts[: n % k] += 1
    row = np.repeat(np.arange(k), counts)
    col = np.arange(n) - np.repeat(np.cumsum(counts) - counts, counts)
    c = counts[row].astype(np.float64)
    y_edges = np.concatenate([[0], np.cumsum(counts)]) / n
    lo = np.column_stack([col / c, y_edges[row]])
    hi = np.column_stack([(col + 1) / c, y_edges[row + 1]])
    hi[:, 0] = np.where(col + 1 == counts[row], 1.0, hi[:, 0])
    return lo, hi


def stratified_jitter(n: int, *, seed=None) -> np.ndarray:
    """Stratified jitter (SJ): one uniform random point in each stratum of
    :func:`jitter_strata` (n strata of area 1/n), (n, 2), row-major.

    >>> p = stratified_jitter(9, seed=1); lo, hi = jitter_strata(9)
    >>> bool(((p >= lo) & (p < hi)).all())
    True
    """
    n = _check_n(n)
    lo, hi = jitter_strata(n)
    u = np.random.default_rng(seed).random((n, 2))
    p = lo + u * (hi - lo)
    return np.minimum(p, np.nextafter(hi, lo))  # keep the half-open strata


def spherical_fibonacci(n: int) -> np.ndarray:
    r"""Spherical Fibonacci points on the hemisphere (Marques et al. 2013), square form.

    :math:`z'_j = 1 - \frac{2j+1}{2N}`, :math:`\phi_j = 2\pi\,\mathrm{frac}(j/\Phi)`,
    j = 0…N−1, Φ the golden ratio (docs/ERRATA.md, "Point sets"). Returned as
    :math:`(x_j, y_j) = (z'_j, \phi_j/2\pi)` so that :func:`lambert_to_hemisphere`
    (z' = x, φ = 2πy) gives back exactly these directions and the same morphs apply.
    :math:`\mathrm{frac}(j/\Phi)` is computed as :math:`j(\Phi-1) \bmod 1`
    (1/Φ = Φ − 1), which keeps full precision for large j. Deterministic.

    Examples
    --------
    >>> spherical_fibonacci(2)
    array([[0.75      , 0.        ],
           [0.25      , 0.61803399]])
    """
    n = _check_n(n)
    j = np.arange(n, dtype=np.float64)
    return np.column_stack([1.0 - (2.0 * j + 1.0) / (2.0 * n),
                            np.mod(j * (GOLDEN_RATIO - 1.0), 1.0)])


def _bnot(n, seed):
    return bnot_square(n, seed=seed)


#: name -> square generator ``f(n, seed) -> (n, 2)``; deterministic sets ignore the seed.
POINTSETS: dict[str, Callable[[int, object], np.ndarray]] = {
    "sf": lambda n, seed: spherical_fibonacci(n),
    "sobol": lambda n, seed: sobol02(n),
    "lp": lambda n, seed: larcher_pillichshammer(n),
    "bnot": _bnot,
    "random": lambda n, seed: random_square(n, seed=seed),
    "jitter": lambda n, seed: stratified_jitter(n, seed=seed),
}
DETERMINISTIC_POINTSETS = frozenset({"sf", "sobol", "lp"})


def square_points(name: str, n: int, *, seed=0) -> np.ndarray:
    """The (n, 2) unit-square form of point set ``name`` (see :data:`POINTSETS`).

    >>> square_points("lp", 2).tolist()
    [[0.0, 0.0], [0.5, 0.5]]
    """
    if name not in POINTSETS:
        raise TheoryParameterError(
            f"unknown point set {name!r}; choose one of {sorted(POINTSETS)}")
    return POINTSETS[name](_check_n(n), seed)


# ----------------------------------------------------------------------------- morphs
def morph_diffuse(zp):
    r"""Cosine-weighted importance sampling: :math:`z = \sqrt{z'}` (Sec. 7.2).

    Uniform z' ∈ [0,1] gives the density :math:`p(\omega) = z/\pi` on the hemisphere
    (so E[z] = 2/3).

    >>> float(morph_diffuse(0.25))
    0.5
    """
    return np.sqrt(np.asarray(zp, dtype=np.float64))


def morph_glossy(zp, shininess: float):
    r"""Importance sampling of the glossy lobe :math:`e^{n(z-1)}` (Eq. 67):

    .. math:: z = \frac1n \ln\!\big(1 + z'(e^n - 1)\big)
                = 1 + \frac1n \ln\!\big(z' + (1 - z')e^{-n}\big),

    evaluated as :math:`1 + \mathrm{logaddexp}(\ln z', \ln(1-z') - n)/n`, which neither
    overflows (e^n) nor underflows (e^{-n} = 0 for n > 745, where the second form would
    give ln 0 at z' = 0); z' = 0 ↦ 0 and z' = 1 ↦ 1 exactly. It inverts the normalised CDF
    :math:`z' = (e^{nz} - 1)/(e^n - 1)`, so uniform z' gives the density
    :math:`p(z) \propto e^{n(z-1)}` on the hemisphere (about the mirror direction).
    Use ``functools.partial(morph_glossy, shininess=30)`` as a ``morph`` callable.

    >>> round(float(morph_glossy(0.5, 30.0)), 6)
    0.976895
    """
    n = float(shininess)
    if not (n > 0 and math.isfinite(n)):
        raise TheoryParameterError(f"glossy shininess n must be > 0, got {shininess!r}")
    zp = np.asarray(zp, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return 1.0 + np.logaddexp(np.log(zp), np.log1p(-zp) - n) / n


def _apply_morph(zp: np.ndarray, morph) -> np.ndarray:
    if morph is None:
        return zp
    if not callable(morph):
        raise TheoryParameterError(f"morph must be a callable z' -> z or None, got {morph!r}")
    z = np.asarray(morph(zp), dtype=np.float64)
    if z.shape != zp.shape:
        raise TheoryParameterError(f"morph returned shape {z.shape}, expected {zp.shape}")
    if not np.all(np.isfinite(z)) or z.min(initial=0.0) < -1e-12 or z.max(initial=0.0) > 1 + 1e-12:
        raise TheoryParameterError("morph must map [0, 1] into [0, 1] (finite values)")
    return np.clip(z, 0.0, 1.0)


# ----------------------------------------------------------------------------- lift
def lambert_to_hemisphere(xy, *, morph=None) -> np.ndarray:
    r"""Lift unit-square points to unit vectors on the upper hemisphere, (n, 3).

    Lambert cylindrical equal-area projection :math:`z' = x`, :math:`\phi = 2\pi y`,
    then the optional morph :math:`z = m(z')`, then
    :math:`d = (\sqrt{1-z^2}\cos\phi,\ \sqrt{1-z^2}\sin\phi,\ z)` (local frame, axis +z).
    Without morph the map has constant area element
    :math:`|\partial_x d \times \partial_y d| = 2\pi`: uniform square points become
    uniform directions.

    Examples
    --------
    >>> lambert_to_hemisphere([[1.0, 0.0], [0.0, 0.25]]).round(12).tolist()
    [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]
    """
    xy = np.asarray(xy, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise TheoryParameterError(f"square points must have shape (n, 2), got {xy.shape}")
    if not np.all(np.isfinite(xy)) or xy.size and (xy[:, 0].min() < 0 or xy[:, 0].max() > 1):
        raise TheoryParameterError("square points must be finite with x in [0, 1]")
    z = _apply_morph(xy[:, 0], morph)
    phi = 2.0 * np.pi * xy[:, 1]
    r = np.sqrt((1.0 - z) * (1.0 + z))
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def generate(name: str, n: int, *, seed=0, morph=None) -> np.ndarray:
    r"""n unit vectors on the upper hemisphere (local frame, axis +z) from point set
    ``name`` ∈ :data:`POINTSETS`, (n, 3).

    Square points (:func:`square_points`) → morph → Lambert lift
    (:func:`lambert_to_hemisphere`). "sf", "sobol" and "lp" are deterministic and
    ignore ``seed``; "bnot", "random" and "jitter" draw from
    ``numpy.random.default_rng(seed)`` (BNOT results are cached per (n, seed)).

    Examples
    --------
    >>> d = generate("sf", 100, morph=morph_diffuse)
    >>> bool(abs(d[:, 2].mean() - 2 / 3) < 1e-4)
    True
    """
    return lambert_to_hemisphere(square_points(name, n, seed=seed), morph=morph)


def hemisphere_points(kind: str, n: int, *, seed=0, morph=None) -> np.ndarray:
    """Same as :func:`generate` (kept as the name used in the design notes)."""
    return generate(kind, n, seed=seed, morph=morph)


# ----------------------------------------------------------------------------- rotations
def frame_from_axis(axis) -> np.ndarray:
    r"""Orthonormal right-handed frame(s) whose third column is the given axis.

    Duff, Burgess, Christensen, Hery, Kensler, Liani & Villemin, "Building an Orthonormal
    Basis, Revisited" (JCGT 6(1), 2017): with :math:`s = \mathrm{sign}(z)`,
    :math:`a = -1/(s + z)`, :math:`b = xya`,
    :math:`t = (1 + s x^2 a,\ s b,\ -s x)`, :math:`u = (b,\ s + y^2 a,\ -y)`; the matrix
    :math:`R = [t\ u\ n]` maps local coordinates to world (:math:`R e_z = n`), continuous
    and accurate for every axis including ±z.

    Parameters
    ----------
    axis : (3,) or (M, 3) — normalised internally (must be non-zero and finite).

    Returns
    -------
    (3, 3) or (M, 3, 3) rotation matrices (det = +1).

    >>> R = frame_from_axis([0.0, 0.6, 0.8])
    >>> bool(np.allclose(R.T @ R, np.eye(3)) and np.allclose(R[:, 2], [0, 0.6, 0.8]))
    True
    """
    a = np.asarray(axis, dtype=np.float64)
    single = a.ndim == 1
    a = np.atleast_2d(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise TheoryParameterError(f"axis must have shape (3,) or (M, 3), got {np.shape(axis)}")
    norm = np.linalg.norm(a, axis=1)
    if not np.all(np.isfinite(a)) or np.any(norm == 0):
        raise TheoryParameterError("axes must be finite and non-zero")
    x, y, z = (a / norm[:, None]).T
    s = np.copysign(1.0, z)
    aa = -1.0 / (s + z)
    b = x * y * aa
    t = np.stack([1.0 + s * x * x * aa, s * b, -s * x], axis=1)
    u = np.stack([b, s + y * y * aa, -y], axis=1)
    R = np.stack([t, u, np.stack([x, y, z], axis=1)], axis=2)
    return R[0] if single else R


def rotate_to_axes(points_local, axes, *, seed=None) -> np.ndarray:
    r"""Rotate one local point set into the frame of each of M axes, (M, n, 3).

    :math:`p^{(m)}_j = R_m\,R_z(\alpha_m)\,p_j` with :math:`R_m` = :func:`frame_from_axis`
    (axes[m]) and, when ``seed`` is given, :math:`\alpha_m` i.i.d. uniform on [0, 2π)
    (``numpy.random.default_rng(seed)``) — an independent random rotation about each axis,
    which randomises the pattern of a QMC set per shading point without changing its
    distribution about the axis. ``seed=None``: no twist (α = 0). One einsum, no loop.

    Parameters
    ----------
    points_local : (n, 3) directions in the local frame (axis +z).
    axes : (M, 3) or (3,) axes (normalised internally); (3,) gives M = 1.

    >>> p = rotate_to_axes([[0, 0, 1.0]], [[1.0, 0, 0], [0, 2.0, 0]])
    >>> p.shape, p[:, 0].round(12).tolist()
    ((2, 1, 3), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    """
    P = np.asarray(points_local, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise TheoryParameterError(f"points_local must have shape (n, 3), got {P.shape}")
    R = frame_from_axis(np.atleast_2d(np.asarray(axes, dtype=np.float64)))
    if seed is not None:
        alpha = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, R.shape[0])
        c, s = np.cos(alpha), np.sin(alpha)
        t = R[:, :, 0] * c[:, None] + R[:, :, 1] * s[:, None]
        u = -R[:, :, 0] * s[:, None] + R[:, :, 1] * c[:, None]
        R = np.stack([t, u, R[:, :, 2]], axis=2)
    return np.einsum("mij,nj->mni", R, P)

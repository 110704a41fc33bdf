r"""The generic zonal weight function p(z) and its numerics: SH / HSH coefficients by
Gauss–Legendre quadrature, the CDF and its inverse, HSH → SH conversion.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Sec. 4 (Eqs. 18, 20, 23, 28, 31–33,
with the corrections of the errata, docs/ERRATA.md). The lobes with closed forms (diffuse,
glossy, Phong) subclass :class:`WeightFunction` in :mod:`envfit.theory._brdf`.

A weight function is zonal about the +z axis, :math:`p(u) = p(u\cdot z)`, and zero on the
lower hemisphere. :class:`WeightFunction` needs only :math:`p(z)` on [0, 1]: it finds the
polynomial degree D that resolves p to double precision (doubling Gauss–Legendre rules
until the shifted-Legendre coefficients of p drop below 1e-17 of the largest), then
integrates :math:`p P_l` with ``(lmax + D)//2 + 2`` Gauss–Legendre nodes on [0, 1], which
is exact for the polynomial part, and inverts the CDF numerically for the importance
sampling map.

>>> w = ZonalWeight(lambda z: z)
>>> bool(abs(w.sh_coefficients(2)[2] - 0.157696) < 1e-6)
True
"""
from __future__ import annotations

import math
import warnings
from typing import Callable

import numpy as np

from envfit.theory._errors import TheoryParameterError, check_degree
from envfit.theory._sh import legendre_moments as _legendre_moments

__all__ = ["WeightFunction", "ZonalWeight", "hsh_to_sh_matrix", "gauss_legendre_01"]

_RESOLVE_TOL = 1e-12          # a rounding plateau of the shifted-Legendre moments lies below this·int|p|
_RESOLVE_MAX_NODES = 1 << 14  # give up resolving p beyond this many nodes (warns)
_SHARED_CACHE: dict = {}      # (class, parameters) -> derived arrays, LRU order
_SHARED_CACHE_SIZE = 32


def gauss_legendre_01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss–Legendre nodes and weights on [0, 1] (exact for degree ≤ 2n−1).

    From ducc0 (Bogaert's FastGL), accurate to a few ulp for any n; scipy's
    ``roots_legendre`` weights carry relative errors growing like n·eps (1e-13 at n = 1000).
    """
    import ducc0

    n = int(n)
    theta = ducc0.misc.GL_thetas(n)
    w = ducc0.misc.GL_weights(n, 1) / (2.0 * np.pi)      # weights on [-1, 1]
    # z = (1 + cos θ)/2 = cos²(θ/2): no cancellation near z = 0
    z = np.cos(0.5 * theta) ** 2
    return z[::-1].copy(), 0.5 * w[::-1].copy()


def _legendre_matrix(x, lmax: int) -> np.ndarray:
    """P_l(x_k), shape (lmax+1, len(x))."""
    out = np.empty((lmax + 1, x.size))
    out[0] = 1.0
    if lmax >= 1:
        out[1] = x
    for l in range(1, lmax):
        out[l + 1] = ((2 * l + 1) * x * out[l] - l * out[l - 1]) / (l + 1)
    return out


def hsh_to_sh_matrix(lmax_sh: int, lmax_hsh: int) -> np.ndarray:
    r"""Zonal HSH → SH conversion matrix, shape ``(lmax_sh+1, lmax_hsh+1)`` (Eqs. 32–33, errata).

    .. math:: M_{ll'} = \int_{S^2}\tilde Y_{l',0} Y_{l,0}\,dS
              = \sqrt{\frac{(2l+1)(2l'+1)}{2}}\int_0^1 P_l(z)P_{l'}(2z-1)\,dz

    with l the SH degree (row) and l' the HSH degree (column). The integrand is a
    polynomial of degree l + l', so a Gauss–Legendre rule with
    ``(lmax_sh + lmax_hsh)//2 + 1`` nodes on [0, 1] is exact.

    >>> M = hsh_to_sh_matrix(1, 0)
    >>> bool(np.allclose(M[:, 0], [np.sqrt(0.5), np.sqrt(1.5) / 2]))
    True
    """
    lmax_sh = check_degree(lmax_sh, "lmax_sh")
    lmax_hsh = check_degree(lmax_hsh, "lmax_hsh")
    x, w = gauss_legendre_01((lmax_sh + lmax_hsh) // 2 + 2)
    Q = _legendre_matrix(2.0 * x - 1.0, lmax_hsh) * w          # (lmax_hsh+1, n)
    M = np.empty((lmax_sh + 1, lmax_hsh + 1))
    p_prev = np.ones_like(x)
    M[0] = Q @ p_prev
    if lmax_sh >= 1:
        p = x.copy()
        M[1] = Q @ p
        for l in range(1, lmax_sh):
            p_next = ((2 * l + 1) * x * p - l * p_prev) / (l + 1)
            p_prev, p = p, p_next
            M[l + 1] = Q @ p
    l = np.arange(lmax_sh + 1, dtype=np.float64)
    lp = np.arange(lmax_hsh + 1, dtype=np.float64)
    return np.sqrt((2 * l[:, None] + 1) * (2 * lp[None, :] + 1) / 2.0) * M


class WeightFunction:
    r"""A zonal weight function :math:`p(z)`, z = u·axis, zero for z < 0 (Sec. 4.1).

    Subclasses implement :meth:`_p_upper` (p on [0, 1], vectorised). Everything else has
    a generic numerical implementation; closed forms override it where known.

    Attributes/methods: :meth:`p`, :attr:`r_s` (Eq. 18), :meth:`sh_coefficients` (Eq. 20),
    :meth:`hsh_coefficients`, :meth:`morph` (importance-sampling map z' ↦ z, the inverse
    CDF of p on [0, 1]), :meth:`truncated_hsh_as_sh` (Eq. 31).
    """

    name: str = "weight"

    # -- to implement ---------------------------------------------------------------
    def _p_upper(self, z: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    # -- cache (instances are immutable in their parameters) ------------------------
    def _cache_key(self):
        """Hashable identity of the parameters, shared by equal instances (None: per instance)."""
        return None

    def _cache(self) -> dict:
        """Per-parameter cache of derived arrays (coefficients, embeddings).

        Equal parametrised instances (``Glossy(30.0)`` twice) share one entry of a small
        module-level LRU, so creating a new instance per call does not recompute.
        """
        key = self._cache_key()
        if key is None:
            c = self.__dict__.get("_theory_cache")
            if c is None:
                c = {}
                self.__dict__["_theory_cache"] = c
            return c
        c = _SHARED_CACHE.pop(key, None)
        if c is None:
            c = {}
        _SHARED_CACHE[key] = c                   # most recently used last
        while len(_SHARED_CACHE) > _SHARED_CACHE_SIZE:
            _SHARED_CACHE.pop(next(iter(_SHARED_CACHE)))
        return c

    # -- the function -----------------------------------------------------------------
    def p(self, z) -> np.ndarray:
        """p(z) for z ∈ [−1, 1]; 0 on the lower hemisphere (z < 0)."""
        z = np.asarray(z, dtype=np.float64)
        zc = np.clip(z, 0.0, 1.0)
        return np.where(z >= 0.0, self._p_upper(zc), 0.0)

    def __call__(self, z) -> np.ndarray:
        return self.p(z)

    # -- generic numerics -------------------------------------------------------------
    def resolution_degree(self) -> int:
        r"""Polynomial degree D of p on [0, 1] to double precision (generic path).

        Computes the shifted-Legendre moments :math:`\int_0^1 p(z)P_l(2z-1)dz`, l ≤ n/2, with
        an n-node Gauss–Legendre rule, doubling n (from 32) until the last quarter of them
        is a rounding plateau (all below 1e-12·∫|p|). D is then the last degree whose
        moment exceeds twice that plateau: beyond D, p is resolved to rounding. The
        plateau is ≈ l·eps·max p, so a very peaked p has a higher floor (e.g. ≈2e-14·∫p
        for e^{300(z−1)}). Warns (and returns the largest degree tried) if p is not
        resolved with 16384 nodes, e.g. a p with a kink inside (0, 1).
        """
        cache = self._cache()
        if "D" in cache:
            return cache["D"]
        n = 32
        while True:
            x, w = gauss_legendre_01(n)
            fw = self._p_upper(x) * w
            if not np.all(np.isfinite(fw)):
                raise TheoryParameterError(f"{self!r}: p(z) is not finite on [0, 1]")
            lh = n // 2
            mom = np.abs(_legendre_moments(2.0 * x - 1.0, fw, lh))
            size = max(float(np.abs(fw).sum()), np.finfo(float).tiny)
            plateau = mom[(3 * lh) // 4:].max()
            resolved = plateau <= _RESOLVE_TOL * size
            above = np.nonzero(mom > 2.0 * plateau)[0]
            D = int(above[-1]) if above.size else 0
            if (resolved and D < (3 * lh) // 4) or n >= _RESOLVE_MAX_NODES:
                if not resolved:
                    warnings.warn(f"{self!r}: p(z) is not resolved to double precision by a "
                                  f"degree-{lh} polynomial; coefficients lose accuracy",
                                  RuntimeWarning, stacklevel=2)
                    D = lh
                cache["D"] = D
                return D
            n *= 2

    def _nodes(self, lmax: int):
        D = self.resolution_degree()
        return gauss_legendre_01((lmax + D) // 2 + 2)

    @property
    def r_s(self) -> float:
        r""":math:`r_s = \frac{1}{2\pi}\int p\,dS = \int_0^1 p(z)dz` (Eq. 18)."""
        cache = self._cache()
        if "r_s" not in cache:
            x, w = self._nodes(0)
            r = float(w @ self._p_upper(x))
            if not (r > 0.0 and np.isfinite(r)):
                raise TheoryParameterError(f"{self!r}: ∫_0^1 p(z) dz must be positive, got {r}")
            cache["r_s"] = r
        return cache["r_s"]

    def _coefficients(self, kind: str, lmax: int, compute) -> np.ndarray:
        """Cache coefficient arrays, computed up to the next power of two ≥ lmax."""
        lmax = check_degree(lmax)
        cache = self._cache()
        have = cache.get(kind)
        if have is None or have.size <= lmax:
            top = max(64, 1 << int(math.ceil(math.log2(lmax + 1))))
            have = compute(top)
            have.setflags(write=False)
            cache[kind] = have
        return have[:lmax + 1].copy()

    def sh_coefficients(self, lmax: int) -> np.ndarray:
        r"""Normalised SH coefficients :math:`b_l`, l = 0…lmax (Eq. 20); :math:`b_0 = 1/(2\sqrt\pi)`.

        Generic path: Gauss–Legendre quadrature of
        :math:`\frac{1}{r_s}\sqrt{\frac{2l+1}{4\pi}}\int_0^1 p P_l\,dz` with
        ``(lmax + D)//2 + 2`` nodes (D from :meth:`resolution_degree`), exact to rounding
        (absolute error ≈ 1e-16·l from the Legendre recurrence) when p is smooth on [0, 1].
        """
        return self._coefficients("sh", lmax, self._sh_generic)

    def _sh_generic(self, lmax: int) -> np.ndarray:
        x, w = self._nodes(lmax)
        mom = _legendre_moments(x, self._p_upper(x) * w, lmax)
        l = np.arange(lmax + 1)
        return np.sqrt((2 * l + 1) / (4 * np.pi)) * mom / self.r_s

    def hsh_coefficients(self, lmax: int) -> np.ndarray:
        r"""Normalised HSH coefficients :math:`\tilde b_l`, l = 0…lmax; :math:`\tilde b_0 = 1/\sqrt{2\pi}`.

        :math:`\tilde b_l = \frac{1}{r_s}\sqrt{\frac{2l+1}{2\pi}}\int_0^1 p(z)P_l(2z-1)dz`
        (Eqs. 23, 28 with the errata normalisation), generic path by Gauss–Legendre.
        """
        return self._coefficients("hsh", lmax, self._hsh_generic)

    def _hsh_generic(self, lmax: int) -> np.ndarray:
        x, w = self._nodes(lmax)
        mom = _legendre_moments(2.0 * x - 1.0, self._p_upper(x) * w, lmax)
        l = np.arange(lmax + 1)
        return np.sqrt((2 * l + 1) / (2 * np.pi)) * mom / self.r_s

    def hsh_degree(self) -> int:
        """Degree beyond which the HSH coefficients are at the rounding level (:meth:`resolution_degree`)."""
        return self.resolution_degree()

    def truncated_hsh_as_sh(self, L: int, lmax: int) -> np.ndarray:
        r"""SH coefficients, l = 0…lmax, of p' = the HSH expansion of p truncated at degree L (Eq. 31).

        :math:`b^{(p')}_l = \sum_{l'=0}^{L}\tilde b_{l'} M_{ll'}`, M from
        :func:`hsh_to_sh_matrix`. These are the coefficients of :math:`p'/(2\pi r_s)`,
        with p' = 0 on the lower hemisphere, so the expansion does not terminate at L.
        """
        L = check_degree(L, "L")
        lmax = check_degree(lmax)
        return hsh_to_sh_matrix(lmax, L) @ self.hsh_coefficients(L)

    def cdf(self, z) -> np.ndarray:
        r""":math:`F(z) = \frac{1}{r_s}\int_0^z p(t)dt` on [0, 1] (generic: Legendre series of p)."""
        cache = self._cache()
        if "cdf_series" not in cache:
            # shifted-Legendre series of p to its resolution degree (GL projection), integrated
            deg = max(self.resolution_degree(), 16)
            x, w = gauss_legendre_01(deg + 2)
            mom = _legendre_moments(2.0 * x - 1.0, self._p_upper(x) * w, deg)
            coef = (2 * np.arange(deg + 1) + 1) * mom
            F = np.polynomial.Legendre(coef, domain=[0.0, 1.0]).integ(lbnd=0.0)
            cache["cdf_series"] = F
        F = cache["cdf_series"]
        z = np.clip(np.asarray(z, dtype=np.float64), 0.0, 1.0)
        return F(z) / self.r_s

    def morph(self, zprime) -> np.ndarray:
        r"""Importance-sampling map z' ∈ [0, 1] ↦ z = F⁻¹(z'), F the CDF of p on [0, 1].

        Uniform z' (equal-area lifting of the unit square, docs/ERRATA.md, "Point sets") gives
        z-samples with density :math:`p(z)/r_s`. Generic path: safeguarded Newton
        iteration on F(z) = z' from a tabulated inverse, bracketed, to ≈ 1e-15.
        """
        zp = np.asarray(zprime, dtype=np.float64)
        if np.any(~np.isfinite(zp)) or np.any(zp < 0.0) or np.any(zp > 1.0):
            raise TheoryParameterError("morph: z' must lie in [0, 1]")
        return self._morph_generic(zp)

    def _morph_generic(self, zp: np.ndarray) -> np.ndarray:
        cache = self._cache()
        if "cdf_table" not in cache:
            grid = np.linspace(0.0, 1.0, 4097)
            Fg = np.maximum.accumulate(self.cdf(grid))
            Fg[0], Fg[-1] = 0.0, 1.0
            cache["cdf_table"] = (grid, Fg)
        grid, Fg = cache["cdf_table"]
        flat = zp.ravel()
        if flat.size == 0:
            return zp.copy()
        k = np.clip(np.searchsorted(Fg, flat, side="right") - 1, 0, grid.size - 2)
        lo = grid[k].copy()
        hi = grid[k + 1].copy()
        z = 0.5 * (lo + hi)
        r_s = self.r_s
        for _ in range(60):
            f = self.cdf(z) - flat
            lo = np.where(f <= 0.0, z, lo)
            hi = np.where(f > 0.0, z, hi)
            dens = self._p_upper(z) / r_s
            with np.errstate(divide="ignore", invalid="ignore"):
                zn = z - f / dens
            bad = ~np.isfinite(zn) | (zn <= lo) | (zn >= hi)
            zn = np.where(bad, 0.5 * (lo + hi), zn)
            done = np.max(np.abs(zn - z)) <= 4e-16
            z = zn
            if done:
                break
        z = np.where(flat <= 0.0, 0.0, np.where(flat >= 1.0, 1.0, z))
        return z.reshape(zp.shape)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class ZonalWeight(WeightFunction):
    r"""A user-supplied zonal weight function, p given on [0, 1] as a vectorised callable.

    Everything (r_s, b_l, b̃_l, morph) goes through the generic numerical path.

    >>> phong20 = ZonalWeight(lambda z: z ** 20, name="phong20")
    >>> round(phong20.r_s, 12)
    0.047619047619
    """

    def __init__(self, func: Callable[[np.ndarray], np.ndarray], name: str = "zonal"):
        if not callable(func):
            raise TheoryParameterError("ZonalWeight needs a callable p(z)")
        self._func = func
        self.name = name

    def _p_upper(self, z):
        return np.asarray(self._func(z), dtype=np.float64) * np.ones_like(z)

    def __repr__(self) -> str:
        return f"ZonalWeight(name={self.name!r})"

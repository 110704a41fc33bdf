r"""Zonal weight functions p(z) (BRDF × cosine) and their SH / HSH coefficients.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Sec. 4 (with the corrections of
the errata, docs/ERRATA.md).

A weight function is zonal about the +z axis, :math:`p(u) = p(u\cdot z)`, and zero on the
lower hemisphere. With :math:`z = \cos\theta`:

.. math::
    r_s = \frac{1}{2\pi}\int_{S^2} p\,dS = \int_0^1 p(z)\,dz                  \quad (18)

    b_l = \frac{1}{2\pi r_s}\int_{S^2} p\,Y_{l,0}\,dS
        = \frac{1}{r_s}\sqrt{\frac{2l+1}{4\pi}}\int_0^1 p(z)P_l(z)\,dz         \quad (20)

    \tilde b_l = \frac{1}{r_s}\sqrt{\frac{2l+1}{2\pi}}\int_0^1 p(z)P_l(2z-1)\,dz   \quad (\text{HSH})

so that :math:`b_0 = 1/(2\sqrt\pi)` and :math:`\tilde b_0 = 1/\sqrt{2\pi}` for every p.

The generic path (:class:`~envfit.theory._weight_function.WeightFunction`, in
:mod:`envfit.theory._weight_function`, re-exported here) needs only :math:`p(z)` on [0, 1]:
Gauss–Legendre quadrature to the degree that resolves p, and a numerical inverse CDF. The
lobes here (:class:`Diffuse`, :class:`Glossy`, :class:`Phong`) override it with closed forms
where they exist.

>>> round(float(Diffuse().sh_coefficients(2)[2]), 6)
0.157696
>>> g = Glossy(30.0)
>>> bool(np.allclose(g.hsh_coefficients(5), WeightFunction.hsh_coefficients(g, 5)))
True
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from envfit.theory._errors import TheoryParameterError, check_degree
from envfit.theory._weight_function import (WeightFunction, ZonalWeight, gauss_legendre_01,
                                            hsh_to_sh_matrix)

__all__ = ["WeightFunction", "ZonalWeight", "Diffuse", "Glossy", "Phong",
           "hsh_to_sh_matrix", "gauss_legendre_01", "GLOSSY_CLOSED_FORM_N", "GLOSSY_SPLIT_N",
           "GLOSSY_MAX_SHININESS", "BRDFS", "PAPER_SHININESS"]


#: above this shininess the glossy lobe's b_l and D come from closed (Bessel) forms, where the
#: generic quadrature's rounding plateau (≈ l·eps·n of ∫p) would hide them (it warns from
#: n ≈ 1e4, and every node underflows at n = 1e6)
GLOSSY_CLOSED_FORM_N = 1000.0
#: the names of the two lobes of the paper's experiments (Sec. 7): "diffuse" (p = z) and
#: "glossy" (p = e^{n(z−1)}); every BRDF name list of theory and envfit is this tuple
BRDFS = ("diffuse", "glossy")
#: the glossy exponent n of the paper's Table 1 and Secs. 7–8 (n = 30), the default of every
#: glossy lobe in theory (envfit's :data:`envfit.defaults.DEFAULT_SHININESS` is this value)
PAPER_SHININESS = 30.0
#: at or below this shininess the lobe's jump e^{-n} at the horizon is ≥ 1e-7 and b_l decays
#: only as l^{-3/2}: b_l by the half-range Legendre products (:meth:`Glossy._sh_split`),
#: O(K·lmax) instead of the quadrature's O(lmax²)
GLOSSY_SPLIT_N = 16.0
#: the largest glossy exponent: its lobe is ≈ 1/√n = 3e-5 rad wide and resolved to double
#: precision by SH degree D ≈ 6√n ≈ 1.9e5 (:meth:`Glossy.resolution_degree`), the most the
#: coefficient arrays here are sized for
GLOSSY_MAX_SHININESS = 1e9


class Diffuse(WeightFunction):
    r"""Lambertian weight :math:`p(z) = z` on the upper hemisphere (Sec. 4.2), r_s = 1/2.

    :math:`b_0 = 1/(2\sqrt\pi)`, :math:`b_1 = 1/\sqrt{3\pi}`, :math:`b_l = 0` for odd l > 1,
    and for even l ≥ 2 (Eq. 22 as corrected in the errata)

    .. math:: b_l = (-1)^{l/2+1}\sqrt{\frac{2l+1}{\pi}}\frac{(l-2)!}{2^l (l/2-1)!(l/2+1)!}

    (computed with log-Gamma, so any l). HSH: :math:`\tilde b_0 = 1/\sqrt{2\pi}`,
    :math:`\tilde b_1 = 1/\sqrt{6\pi}`, zero beyond (Eq. 24). Morph :math:`z = \sqrt{z'}`.

    >>> Diffuse().sh_coefficients(6).round(6).tolist()
    [0.282095, 0.325735, 0.157696, 0.0, -0.035262, 0.0, 0.015892]
    """

    name = "diffuse"

    def _cache_key(self):
        return ("Diffuse",)

    def _p_upper(self, z):
        return np.asarray(z, dtype=np.float64).copy()

    @property
    def r_s(self) -> float:
        return 0.5

    def resolution_degree(self) -> int:
        return 1

    def sh_coefficients(self, lmax: int) -> np.ndarray:
        lmax = check_degree(lmax)
        l = np.arange(lmax + 1)
        b = np.zeros(lmax + 1)
        b[0] = 0.5 / math.sqrt(math.pi)
        if lmax >= 1:
            b[1] = 1.0 / math.sqrt(3 * math.pi)
        ev = l[(l >= 2) & (l % 2 == 0)].astype(np.float64)
        if ev.size:
            logmag = (_special().gammaln(ev - 1) - ev * math.log(2.0)
                      - _special().gammaln(ev / 2) - _special().gammaln(ev / 2 + 2))
            sign = np.where((ev / 2 + 1) % 2 == 0, 1.0, -1.0)
            b[ev.astype(int)] = sign * np.sqrt((2 * ev + 1) / math.pi) * np.exp(logmag)
        return b

    def hsh_coefficients(self, lmax: int) -> np.ndarray:
        lmax = check_degree(lmax)
        b = np.zeros(lmax + 1)
        b[0] = 1.0 / math.sqrt(2 * math.pi)
        if lmax >= 1:
            b[1] = 1.0 / math.sqrt(6 * math.pi)
        return b

    def hsh_degree(self) -> int:
        return 1

    def cdf(self, z):
        z = np.clip(np.asarray(z, dtype=np.float64), 0.0, 1.0)
        return z * z

    def morph(self, zprime):
        zp = np.asarray(zprime, dtype=np.float64)
        if np.any(~np.isfinite(zp)) or np.any(zp < 0.0) or np.any(zp > 1.0):
            raise TheoryParameterError("morph: z' must lie in [0, 1]")
        return np.sqrt(zp)



def _special():
    """scipy.special, imported on first use (it costs ~0.3 s, and most callers of this module
    only read its names)."""
    from scipy import special
    return special

@dataclass(frozen=True, repr=False)
class Glossy(WeightFunction):
    r"""Gaussian lobe :math:`p(z) = e^{n(z-1)}` about the mirror direction (Sec. 4.3, Eq. 25).

    Valid for 0 < n ≤ :data:`GLOSSY_MAX_SHININESS` (1e9).
    :math:`r_s = (1-e^{-n})/n`. SH coefficients exact by Gauss–Legendre quadrature of
    Eq. 26 (errata: :math:`b_l = \frac{1}{r_s}\sqrt{\frac{2l+1}{4\pi}}\int_0^1 e^{n(z-1)}P_l dz`)
    for n ≤ :data:`GLOSSY_CLOSED_FORM_N`, and above by the full-sphere Bessel form Eq. 27
    (:meth:`sh_coefficients_bessel`, exponentially scaled: no underflow), exact there; for
    n ≤ :data:`GLOSSY_SPLIT_N` by half-range Legendre products (:meth:`_sh_split`). HSH
    coefficients by the exact Bessel form Eq. 30 (= Eqs. 28/29). Morph Eq. 67 in the
    stable form :math:`z = 1 + \ln(z' + (1-z')e^{-n})/n`.

    >>> g = Glossy(30.0)
    >>> bool(abs(g.sh_coefficients(40) - g.sh_coefficients_bessel(40)).max() < 1e-12)
    True
    """

    shininess: float = PAPER_SHININESS
    name: str = field(default="glossy", compare=False)

    def __post_init__(self):
        n = self.shininess
        try:
            n = float(n)
        except (TypeError, ValueError):
            raise TheoryParameterError(f"shininess must be a number, got {n!r}") from None
        if not (np.isfinite(n) and n > 0):
            raise TheoryParameterError(f"shininess n must be > 0, got {n!r}")
        if n > GLOSSY_MAX_SHININESS:
            raise TheoryParameterError(
                f"shininess n must be <= {GLOSSY_MAX_SHININESS:.0e} (a lobe {1 / math.sqrt(n):.1e} "
                f"rad wide needs SH degrees beyond {int(6 * math.sqrt(GLOSSY_MAX_SHININESS))}), "
                f"got {n:g}")
        object.__setattr__(self, "shininess", n)

    def _cache_key(self):
        return ("Glossy", self.shininess)

    def _p_upper(self, z):
        return np.exp(self.shininess * (np.asarray(z, dtype=np.float64) - 1.0))

    @property
    def r_s(self) -> float:
        n = self.shininess
        return float(-np.expm1(-n) / n)

    def resolution_degree(self) -> int:
        r"""Polynomial degree D of :math:`e^{n(z-1)}` on [0, 1] to double precision.

        n ≤ :data:`GLOSSY_CLOSED_FORM_N`: the generic search (:meth:`WeightFunction.resolution_degree`).
        Above, its rounding plateau (≈ l·eps·n of ∫p) hides the decay, so D is read from the
        closed form of the shifted-Legendre moments,
        :math:`\int_0^1 e^{n(z-1)}P_l(2z-1)dz = \sqrt{\pi/n}\,e^{-n/2}I_{l+1/2}(n/2)` (the
        HSH integral of Eq. 30): the last l whose moment exceeds 1e-15·r_s (the generic
        search's D within ±2 for 30 ≤ n ≤ 1000). D ≈ 6√n.
        """
        n = self.shininess
        if n <= GLOSSY_CLOSED_FORM_N:
            return WeightFunction.resolution_degree(self)
        cache = self._cache()
        if "D" not in cache:
            top = int(12.0 * math.sqrt(n)) + 64
            nu = np.arange(top + 1) + 0.5
            with np.errstate(under="ignore"):
                rel = math.sqrt(math.pi * n) * _special().ive(nu, 0.5 * n) / (-math.expm1(-n))
            above = np.nonzero(rel > 1e-15)[0]
            cache["D"] = int(above[-1]) if above.size else 0
        return cache["D"]

    def sh_coefficients(self, lmax: int) -> np.ndarray:
        r"""Normalised SH coefficients :math:`b_l` (Eq. 26, errata), l = 0…lmax.

        n ≤ :data:`GLOSSY_CLOSED_FORM_N`: the generic Gauss–Legendre path (exact to rounding).
        Above, the full-sphere Bessel form Eq. 27 (:meth:`sh_coefficients_bessel`), whose only
        error is the lower-hemisphere part, :math:`|\Delta b_l| \le
        \sqrt{(2l+1)/4\pi}\,e^{-n}/(n r_s) < 10^{-400}`: exact in double precision, and never
        underflowing where the generic path does (every node's :math:`e^{n(z-1)}` is 0 for
        n = 1e6 on a 32-node rule).
        """
        if self.shininess <= GLOSSY_SPLIT_N:
            return self._coefficients("sh", lmax, self._sh_split)
        if self.shininess <= GLOSSY_CLOSED_FORM_N:
            return WeightFunction.sh_coefficients(self, lmax)
        return self._coefficients("sh", lmax, self.sh_coefficients_bessel)

    def _sh_split(self, lmax: int, block: int = 4096) -> np.ndarray:
        r"""b_l for a lobe with a jump at the horizon (n ≤ :data:`GLOSSY_SPLIT_N`) in O(K·lmax).

        :math:`e^{n(z-1)} = \sum_{k\le K} c_k P_k(z)` on [−1, 1] with
        :math:`c_k = (2k+1)\sqrt{\pi/2n}\,e^{-n}I_{k+1/2}(n)` (K where they underflow), and
        the half-range products from the Legendre equation,
        :math:`\int_0^1 P_kP_l\,dz = \frac{P_l(0)P_k'(0) - P_k(0)P_l'(0)}{k(k+1) - l(l+1)}`
        (k ≠ l; 1/(2l+1) for k = l), :math:`P_l(0) = -\frac{l-1}{l}P_{l-2}(0)`,
        :math:`P_l'(0) = lP_{l-1}(0)`. The generic quadrature needs ≈ lmax/2 nodes for the
        jump's slow decay (b_l ~ e^{-n}n\,l^{-3/2}): O(lmax²), 140 s to the embedding's
        65536 degrees at n = 1; this is 0.05 s and agrees with it to 3e-14.
        """
        n = self.shininess
        kmax = int(n + 12.0 * math.sqrt(n) + 40)
        k = np.arange(kmax + 1)
        with np.errstate(under="ignore"):
            c = (2 * k + 1) * math.sqrt(math.pi / (2.0 * n)) * _special().ive(k + 0.5, n)
        nz = np.nonzero(c > 0.0)[0]
        K = int(nz[-1]) if nz.size else 0
        c, k = c[:K + 1], k[:K + 1]
        top = max(lmax, K)
        A = np.zeros(top + 1)                     # P_l(0)
        A[0] = 1.0
        for l in range(2, top + 1, 2):
            A[l] = -(l - 1) / l * A[l - 2]
        B = np.zeros(top + 1)                     # P_l'(0) = l P_{l-1}(0)
        B[1:] = np.arange(1, top + 1) * A[:-1]
        kk = k * (k + 1.0)
        m = np.empty(lmax + 1)
        for s0 in range(0, lmax + 1, block):
            l = np.arange(s0, min(lmax + 1, s0 + block))
            den = kk[None, :] - (l * (l + 1.0))[:, None]
            num = A[l][:, None] * B[k][None, :] - A[k][None, :] * B[l][:, None]
            J = np.divide(num, den, out=np.zeros_like(num), where=den != 0.0)
            m[l] = J @ c
            d = l[l <= K]
            m[d] += c[d] / (2 * d + 1)
        ll = np.arange(lmax + 1)
        return np.sqrt((2 * ll + 1) / (4 * np.pi)) * m / self.r_s

    def sh_coefficients_bessel(self, lmax: int) -> np.ndarray:
        r"""Eq. 27: :math:`b_l \approx \frac{e^{-n}}{1-e^{-n}}\sqrt{n\nu}\,I_\nu(n)`, ν = l + ½.

        Extends the integral of Eq. 26 to [−1, 1]; the error is the lower-hemisphere part,
        bounded by :math:`\sqrt{(2l+1)/4\pi}\,e^{-n}/r_s`. Uses ``ive`` (= :math:`e^{-n}I_\nu(n)`),
        so it never overflows.
        """
        lmax = check_degree(lmax)
        n = self.shininess
        nu = np.arange(lmax + 1) + 0.5
        with np.errstate(under="ignore"):        # far beyond √n: 0, as it is
            return np.sqrt(n * nu) * _special().ive(nu, n) / (-np.expm1(-n))

    def hsh_coefficients(self, lmax: int) -> np.ndarray:
        r"""Eq. 30 (exact): :math:`\tilde b_l = \frac{e^{-n/2}}{1-e^{-n}}\sqrt{n\nu}\,I_\nu(n/2)`, ν = l + ½."""
        lmax = check_degree(lmax)
        n = self.shininess
        nu = np.arange(lmax + 1) + 0.5
        with np.errstate(under="ignore"):
            return np.sqrt(n * nu) * _special().ive(nu, 0.5 * n) / (-np.expm1(-n))

    def cdf(self, z):
        n = self.shininess
        z = np.clip(np.asarray(z, dtype=np.float64), 0.0, 1.0)
        return (np.exp(n * (z - 1.0)) - math.exp(-n)) / (-math.expm1(-n))

    def morph(self, zprime):
        r"""Eq. 67, stable form :math:`z = 1 + \ln(z' + (1 - z')e^{-n})/n`."""
        zp = np.asarray(zprime, dtype=np.float64)
        if np.any(~np.isfinite(zp)) or np.any(zp < 0.0) or np.any(zp > 1.0):
            raise TheoryParameterError("morph: z' must lie in [0, 1]")
        n = self.shininess
        # ln(z' + (1 - z') e^{-n}) as a log-sum-exp: no underflow of e^{-n}, exact ends
        with np.errstate(divide="ignore"):
            lse = np.logaddexp(np.log(zp), np.log1p(-zp) - n)
        return np.clip(1.0 + lse / n, 0.0, 1.0)

    def __repr__(self) -> str:
        return f"Glossy(shininess={self.shininess:g})"


@dataclass(frozen=True, repr=False)
class Phong(WeightFunction):
    r"""Phong lobe :math:`p(z) = z^n` (cos^n about the mirror direction), through the generic path.

    Closed forms, used only to test the generic path: :math:`r_s = 1/(n+1)`, morph
    :math:`z = z'^{1/(n+1)}`.

    >>> round(Phong(10).r_s, 12)
    0.090909090909
    """

    exponent: float = 10.0
    name: str = field(default="phong", compare=False)

    def __post_init__(self):
        try:
            n = float(self.exponent)
        except (TypeError, ValueError):
            raise TheoryParameterError(f"Phong exponent must be a number, got {self.exponent!r}") from None
        if not (np.isfinite(n) and n >= 0):
            raise TheoryParameterError(f"Phong exponent must be >= 0, got {self.exponent!r}")
        object.__setattr__(self, "exponent", n)

    def _cache_key(self):
        return ("Phong", self.exponent)

    def _p_upper(self, z):
        return np.power(np.asarray(z, dtype=np.float64), self.exponent)

    def __repr__(self) -> str:
        return f"Phong(exponent={self.exponent:g})"

r"""The paper's claims about Figs. 1–5 and the BNOT construction, checked on the figure data.

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 5.2, 7–8.

Each statement (:func:`figure_claims` collects them) is a :class:`Claim`: the numbers, an
explicit test with its threshold, and the verdict — so that front ends only print them. The
claims read the data types of :mod:`envfit.theory._figures` (which never imports this module):

* Fig. 1 (:func:`anisotropic_dominance_claim`): the anisotropic part E_A dominates E;
* Fig. 2 (:func:`osw_low_order_claim`): OSW reduce the low-order anisotropic power;
* Fig. 4 (:func:`random_slope_claims`, :func:`structured_beat_random_claims`): random points
  converge like N^-0.5 (equal) / N^-0.75 (OSW); structured sets beat random for N ≥ 256;
* Fig. 5(a) caption (:func:`caption_fig5a_claim`): E(3) ≈ 4.4e-3 (not reproducible, b_3 = 0);
* BNOT (:func:`bnot_capacity_claim`, :func:`bnot_blue_noise_claim`): capacity 1/N, blue noise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from envfit.theory._figures import (BNOTFigureData, ConvergenceData, LowOrderCloseup, SpectraData,
                                    TruncationFigureData, low_order_closeup)
from envfit.theory._figures import (bnot_figure_data, convergence_data, spectra_data,
                                    truncation_figure_data)
from envfit.theory._table1 import PAPER_FIG5A_CAPTION

__all__ = ["Claim", "anisotropic_dominance_claim", "osw_low_order_claim", "random_slope_claims",
           "structured_beat_random_claims", "caption_fig5a_claim", "bnot_capacity_claim",
           "bnot_blue_noise_claim", "figure_claims", "SLOPE_TOLERANCE", "BEATS_RANDOM_NMIN",
           "CAPACITY_TOLERANCE", "BLUE_NOISE_FACTOR", "CAPTION_RTOL"]

#: tolerance on a fitted convergence exponent (Fig. 4 claims): |k - k_paper| <= 0.1
SLOPE_TOLERANCE = 0.1
#: the smallest N of the "structured sets beat random" comparison (Fig. 4)
BEATS_RANDOM_NMIN = 256
#: a BNOT set meets its capacity constraint when every cell area is 1/N to this relative error
CAPACITY_TOLERANCE = 1e-4
#: blue noise: the mean low-band power of BNOT must be below this fraction of random's
BLUE_NOISE_FACTOR = 0.5
#: relative tolerance of the comparison with the Fig. 5(a) caption's E(3) = 4.4e-3
CAPTION_RTOL = 0.1


@dataclass(frozen=True)
class Claim:
    r"""One claim of the paper about Figs. 1–5, checked against computed numbers.

    Attributes
    ----------
    id : str
        Stable identifier, ``"<figure>.<what>[.<brdf>]"``, e.g. ``"fig4.random-slope-osw.diffuse"``.
    text : str
        The claim in words, with where the paper makes it.
    values : dict
        The numbers the verdict is computed from.
    test : str
        The explicit test applied to ``values``, e.g. ``"|slope + 0.75| <= 0.1"``.
    threshold : float
        The number that test compares with.
    holds : bool
        The verdict: whether the test passes.
    """

    id: str
    text: str
    values: dict
    test: str
    threshold: float
    holds: bool


def anisotropic_dominance_claim(data: SpectraData, brdf: str = "diffuse",
                                weights: str = "equal") -> Claim:
    r"""Sec. 5.2 / Fig. 1: the worst-case error of QMC rules is dominated by its anisotropic part.

    Test: :math:`E_Z / E_A < 1` (both summed to the spectra's lmax) for every point set;
    an :math:`E_A = 0` gives NaN, which fails.

    >>> d = spectra_data(n=32, lmax=16, pointsets=("sf",), brdfs=("diffuse",), weightings=("equal",))
    >>> anisotropic_dominance_claim(d).holds
    True
    """
    ratio = {}
    for ps in data.pointsets:
        r = data.get(brdf, weights, ps)
        ratio[ps] = r.wce_zonal / r.wce_anisotropic if r.wce_anisotropic > 0 else float("nan")
    return Claim(id=f"fig1.anisotropic-dominates.{brdf}",
                 text=f"Sec. 5.2, Fig. 1: the anisotropic part E_A dominates E ({brdf}, {weights} weights)",
                 values={"zonal_over_anisotropic": ratio, "lmax": data.lmax, "weights": weights},
                 test="E_Z / E_A < 1 for every point set", threshold=1.0,
                 holds=all(v < 1.0 for v in ratio.values()))


def osw_low_order_claim(closeup: LowOrderCloseup) -> Claim:
    r"""Fig. 2: the optimal sample weights reduce the low-order anisotropic power.

    Test: :math:`\sum_l C_l^2(\mathrm{OSW}) / \sum_l C_l^2(\mathrm{equal}) < 1` over the
    close-up's degrees, for every point set (:attr:`LowOrderCloseup.reduction`).

    >>> d = spectra_data(n=32, lmax=16, pointsets=("random",), brdfs=("diffuse",))
    >>> osw_low_order_claim(low_order_closeup(d, count=5)).holds
    True
    """
    eq = {ps: float(v.sum()) for ps, v in closeup.C2_equal.items()}
    op = {ps: float(v.sum()) for ps, v in closeup.C2_osw.items()}
    lo, hi = int(closeup.l[0]), int(closeup.l[-1])
    return Claim(id=f"fig2.osw-reduce-low-order.{closeup.brdf}",
                 text=f"Fig. 2: OSW reduce the anisotropic power C_l^2, l = {lo}..{hi} ({closeup.brdf})",
                 values={"sum_equal": eq, "sum_osw": op, "ratio": dict(closeup.reduction)},
                 test=f"sum_(l={lo}..{hi}) C_l^2 (OSW) / same (equal) < 1 for every point set",
                 threshold=1.0, holds=all(v < 1.0 for v in closeup.reduction.values()))


def random_slope_claims(data: ConvergenceData, tol: float = SLOPE_TOLERANCE) -> list[Claim]:
    r"""Sec. 7.2: random points converge like :math:`N^{-0.5}` with equal weights and like
    :math:`N^{-0.75}` with OSW — one claim per (weighting, brdf) present.

    Test: :math:`|k - k_\mathrm{paper}| \le` ``tol`` for the fitted slope k
    (:attr:`ConvergenceData.slopes`, fitted over :attr:`ConvergenceData.fit_range`).

    >>> c = convergence_data(64, pointsets=("random",), brdfs=("diffuse",), weightings=("equal",))
    >>> [(x.id, x.threshold) for x in random_slope_claims(c)]
    [('fig4.random-slope-equal.diffuse', 0.1)]
    """
    if "random" not in data.pointsets:
        return []
    expected = {"equal": -0.5, "osw": -0.75}
    out = []
    for wt in data.weightings:
        for b in data.brdfs:
            k, k0 = data.slopes[(b, wt, "random")], expected[wt]
            out.append(Claim(
                id=f"fig4.random-slope-{wt}.{b}",
                text=f"Sec. 7.2: random points with {wt} weights converge like N^{k0:g} ({b})",
                values={"slope": k, "expected": k0, "fit_range": tuple(data.fit_range)},
                test=f"|slope - ({k0:g})| <= {tol:g}", threshold=float(tol),
                holds=bool(abs(k - k0) <= tol)))
    return out


def structured_beat_random_claims(data: ConvergenceData,
                                  nmin: int = BEATS_RANDOM_NMIN) -> list[Claim]:
    r"""Fig. 4: with equal weights every structured set beats random points for N ≥ ``nmin``.

    One claim per brdf; ``values["per_pointset"][ps]`` is
    :meth:`ConvergenceData.beats_random` (``{"all", "ratio_max"}``). Test: E(set)/E(random)
    < 1 at every N ≥ nmin for every structured set. Empty when the data have no N ≥ nmin,
    no random set or no equal weights.
    """
    if data.ns.max() < nmin or "random" not in data.pointsets or "equal" not in data.weightings:
        return []
    out = []
    for b in data.brdfs:
        per = data.beats_random(b, "equal", nmin)
        out.append(Claim(
            id=f"fig4.structured-beat-random.{b}",
            text=f"Fig. 4: structured sets beat random at equal weights for every N >= {nmin} ({b})",
            values={"nmin": int(nmin), "per_pointset": per},
            test=f"E(set) / E(random) < 1 at every N >= {nmin}, for every structured set",
            threshold=1.0, holds=all(v["all"] for v in per.values())))
    return out


def caption_fig5a_claim(data: TruncationFigureData, rtol: float = CAPTION_RTOL) -> Claim | None:
    r"""Fig. 5(a) caption: diffuse SH truncated at L = 3 has E ≈ 4.4e-3 (≈ 930 QMC points).

    Test: :math:`|E(3)/4.4\times10^{-3} - 1| \le` ``rtol``. It fails with the paper's own
    formulas: :math:`b_3 = 0` for the diffuse lobe, so E(3) = E(2) (docs/ERRATA.md).
    None when the data stop before L = 3.

    >>> c = caption_fig5a_claim(truncation_figure_data(Lmax=4, qmc_nmax=64))
    >>> c.holds, c.values["b3_zero"]
    (False, True)
    """
    cap = PAPER_FIG5A_CAPTION
    E = data.wce[cap["case"]]
    L = int(cap["L"])
    if E.size <= L:
        return None
    q = data.qmc_points[cap["case"]][L]
    return Claim(id="fig5a.caption-E3",
                 text=f"Fig. 5(a) caption: L = {L} -> E = {cap['wce']:g}, ≈ {cap['qmc_points']} points",
                 values={"paper_wce": cap["wce"], "paper_qmc_points": cap["qmc_points"],
                         "wce_L3": float(E[L]), "wce_L2": float(E[L - 1]),
                         "b3_zero": bool(E[L] == E[L - 1]),
                         "qmc_points_L3": int(q) if math.isfinite(q) else None},
                 test=f"|E(3) / {cap['wce']:g} - 1| <= {rtol:g}", threshold=float(rtol),
                 holds=bool(abs(E[L] / cap["wce"] - 1.0) <= rtol))


def bnot_capacity_claim(data: BNOTFigureData, tol: float = CAPACITY_TOLERANCE) -> Claim:
    r"""BNOT (de Goes et al.): every power cell has the capacity 1/N.

    Test: max relative cell-area error ≤ ``tol``.

    >>> bnot_capacity_claim(bnot_figure_data(32)).holds
    True
    """
    err = data.diagnostics_bnot.max_relative_area_error
    return Claim(id="bnot.capacity", text="BNOT: every cell has area 1/N (capacity constraint)",
                 values={"max_relative_area_error": err, "n": data.n},
                 test=f"max_i |N |V_i| - 1| <= {tol:g}", threshold=float(tol),
                 holds=bool(err <= tol))


def bnot_blue_noise_claim(data: BNOTFigureData, factor: float = BLUE_NOISE_FACTOR) -> Claim:
    r"""BNOT is blue noise: little power at low frequencies, where random points have P ≈ 1.

    Test: mean power for :math:`|k| < \sqrt N/2` of BNOT < ``factor`` × that of random points.

    >>> bnot_blue_noise_claim(bnot_figure_data(32)).holds
    True
    """
    return Claim(id="bnot.blue-noise", text="BNOT: blue noise (low power at low frequencies)",
                 values={"low_band": data.low_band, "low_power_bnot": data.low_power_bnot,
                         "low_power_random": data.low_power_random},
                 test=f"mean P(|k| < sqrt(N)/2): BNOT < {factor:g} x random",
                 threshold=float(factor),
                 holds=bool(data.low_power_bnot < factor * data.low_power_random))


def figure_claims(spectra: SpectraData | None = None, convergence: ConvergenceData | None = None,
                  truncation: TruncationFigureData | None = None,
                  bnot: BNOTFigureData | None = None) -> list[Claim]:
    r"""Every claim that the given figure data can check, in figure order.

    Figs. 1–2 from ``spectra`` (diffuse; Fig. 2 needs both weightings and lmax ≥ 10),
    Fig. 4 from ``convergence``, Fig. 5(a) from ``truncation``, BNOT from ``bnot``; data
    left as None contribute nothing.

    >>> d = spectra_data(n=32, lmax=16, pointsets=("sf", "random"), brdfs=("diffuse",))
    >>> [c.id for c in figure_claims(spectra=d)]
    ['fig1.anisotropic-dominates.diffuse', 'fig2.osw-reduce-low-order.diffuse']
    """
    out: list[Claim] = []
    if spectra is not None and "diffuse" in spectra.brdfs:
        if "equal" in spectra.weightings:
            out.append(anisotropic_dominance_claim(spectra, "diffuse", "equal"))
        if "osw" in spectra.weightings and "equal" in spectra.weightings and spectra.lmax >= 10:
            out.append(osw_low_order_claim(low_order_closeup(spectra, "diffuse", 10)))
    if convergence is not None:
        out += random_slope_claims(convergence) + structured_beat_random_claims(convergence)
    if truncation is not None:
        c = caption_fig5a_claim(truncation)
        out += [c] if c is not None else []
    if bnot is not None:
        out += [bnot_capacity_claim(bnot), bnot_blue_noise_claim(bnot)]
    return out

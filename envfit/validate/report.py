r"""``report.md``: a short validation report written from the result of ``envfit validate``.

:func:`render_report` turns the JSON-ready dict of :func:`envfit.validate.pipeline.run_validation`
(or the JSON file it was saved to) into Markdown: what was run, the figures, the agreement
numbers (slopes, rank order, the shape fit (a) and the choice of s, the absolute
predictions (b) and (b'), the truncation curves) and a "what disagrees and why" section.

Every sentence that states a judgement (a verdict, a trend, a shape of a distribution, a
cause) is chosen by a named, pure predicate of numbers printed in the same report; the
predicates, their thresholds and the sentence each outcome prints are listed in
:data:`CONDITIONS`. So the text never claims what the data do not show: when a test fails
the report prints the sentence that is true of the numbers instead (e.g. "It does not rise
with l (0.17–0.92; …)"). :func:`write_report` writes the report atomically.

Example
-------
>>> md = render_report({"map": "m", "map_size": [8, 4], "channels": 1, "s": 1.5, "sigma": 1.0,
...                     "sigma_channels": [1.0], "scale": "linear", "scale_description": "linear",
...                     "fit": {"source": "given", "s_interval": None, "method": "given", "n": 10},
...                     "config": {"brdfs": ["diffuse"], "pointsets": [], "weights": [],
...                                "n_values": [], "shininess": 30.0, "truncation": False},
...                     "axes": 10, "seed": 0, "results": [], "truncation": [],
...                     "agreement": {"slopes": [], "rank": [], "shape_fit": {"constant": {},
...                                   "residual_dex": {}, "method": ""}, "s_choice": {},
...                                   "absolute": {}, "truncation": [], "acceptance": {},
...                                   "slope_range": [64, 4096]},
...                     "map_stats": {}, "timings": {"total": 1.0}, "notes": []})
>>> md.splitlines()[0]
'# Validation of predicted shading-integral errors: m'
>>> _rises_with_degree([0.17, 0.92, 0.4, 0.6]), _looks_gaussian(5.2)
(False, False)
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from envfit.base.atomic import atomic_write_text

__all__ = ["CONDITIONS", "Condition", "render_report", "write_report"]

# ----------------------------------------------------------------------------- thresholds

#: Spearman rank correlation of the power ratio against l needed to call it rising: a
#: monotone trend, not one high degree (ρ = 0.8 is the usual "strong" cut).
RISE_MIN_SPEARMAN = 0.8
#: ... and the last degree's ratio over the first's: a rise well beyond one map's scatter.
RISE_MIN_FACTOR = 1.5
#: At least this many degrees for a trend in l (two points always have ρ = ±1).
TREND_MIN_POINTS = 3
#: |kurtosis − 3| up to which the per-axis errors are called Gaussian (sampling scatter of
#: the kurtosis of a few hundred axes).
GAUSSIAN_MAX_EXCESS_KURTOSIS = 1.0
#: Excess kurtosis above which the errors are heavy-tailed (kurtosis 6: the squared error
#: is carried by a few axes).
HEAVY_MIN_EXCESS_KURTOSIS = 3.0
#: Relative band within which prediction (c) counts as agreeing everywhere (a few times the
#: Monte Carlo error of the axes).
SPECTRAL_TOLERANCE = 0.15
#: Median predicted/measured ratio below which the model under-predicts (−20 %) ...
LEVEL_LOW = 0.8
#: ... and above which it over-predicts (the reciprocal of LEVEL_LOW: symmetric in log).
LEVEL_HIGH = 1.25
#: Number of lowest degrees l ≥ 1 whose mean power ratio is the "low-degree" level.
LOW_DEGREES = 3
#: |low-degree ratio − 1| up to which the map's low degrees hold the model's power.
LOW_DEGREE_TOLERANCE = 0.3
#: Fraction of the steeper slopes (b') must fix to say the band limit accounts for them
#: (more than half: "most").
BAND_LIMIT_MAJORITY = 0.5
#: Two values of s closer than this are the same candidate.
S_SAME = 1e-3
#: Residuals (dex) closer than this are a tie between two values of s.
S_TIE_DEX = 0.005
#: Kendall τ within this of 1 is an identical order (floating point of scipy's τ).
TAU_ONE = 1e-9
#: Level differences up to this many relative standard errors are noise ("a few times").
RESOLUTION_FACTOR = 3.0
#: Measured residue of an exact truncation, relative to its L = 0 error, up to which it is
#: the ground truth's own accuracy (the SH ground truth is far better than 0.1 %).
TRUTH_RESIDUE_FRACTION = 1e-3


# ----------------------------------------------------------------------------- predicates

def _spearman(x: list[float], y: list[float]) -> float:
    """Spearman rank correlation of ``x`` and ``y`` (average ranks for ties; 0 if constant).

    >>> _spearman([1, 2, 3], [0.1, 0.5, 0.4])
    0.5
    """
    def ranks(v):
        order = sorted(range(len(v)), key=lambda i: v[i])
        rk = [0.0] * len(v)
        i = 0
        while i < len(v):
            j = i
            while j + 1 < len(v) and v[order[j + 1]] == v[order[i]]:
                j += 1
            for k in range(i, j + 1):
                rk[order[k]] = 0.5 * (i + j)
            i = j + 1
        return rk
    rx, ry = ranks(list(x)), ranks(list(y))
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    return 0.0 if sxx == 0 or syy == 0 else sxy / math.sqrt(sxx * syy)


def _rises_with_degree(ratios: list[float]) -> bool:
    """Whether ``ratios`` (ordered by degree l) rise with l.

    Needs :data:`TREND_MIN_POINTS` values, Spearman ρ(ratio, l) ≥ :data:`RISE_MIN_SPEARMAN`
    and last/first ≥ :data:`RISE_MIN_FACTOR`.
    """
    if len(ratios) < TREND_MIN_POINTS or ratios[0] <= 0:
        return False
    rho = _spearman(list(range(len(ratios))), ratios)
    return rho >= RISE_MIN_SPEARMAN and ratios[-1] / ratios[0] >= RISE_MIN_FACTOR


def _looks_gaussian(kurtosis: float) -> bool:
    """|kurtosis − 3| ≤ :data:`GAUSSIAN_MAX_EXCESS_KURTOSIS`."""
    return abs(kurtosis - 3.0) <= GAUSSIAN_MAX_EXCESS_KURTOSIS


def _heavy_tailed(kurtosis: float) -> bool:
    """kurtosis − 3 > :data:`HEAVY_MIN_EXCESS_KURTOSIS`."""
    return kurtosis - 3.0 > HEAVY_MIN_EXCESS_KURTOSIS


def _all_agree(differences: list[float], tolerance: float) -> bool:
    """Every |difference| ≤ ``tolerance`` (and there is at least one)."""
    return bool(differences) and all(abs(d) <= tolerance for d in differences)


def _within_tolerance(value: float | None, tolerance: float) -> bool:
    """``value`` is known and ≤ ``tolerance``."""
    return value is not None and value <= tolerance


def _all_counted(within: int | None, checked: int | None) -> bool:
    """``within`` of ``checked`` is all of them (and there is at least one)."""
    return bool(checked) and within == checked


def _all_within(fraction: float | None) -> bool:
    """The fraction of cells within the tolerance is 1."""
    return fraction is not None and fraction >= 1.0


def _rank_identical(taus: list[float]) -> bool:
    """Every Kendall τ is 1 (to :data:`TAU_ONE`), and there is at least one."""
    return bool(taus) and all(t >= 1.0 - TAU_ONE for t in taus)


def _swaps_within_resolution(gap: float, rel_se: float) -> bool:
    """A relative level difference ``gap`` ≤ :data:`RESOLUTION_FACTOR` × ``rel_se``."""
    return gap <= RESOLUTION_FACTOR * rel_se


def _band_limit_explains(fixed: int, steeper: int) -> bool:
    """(b') fixes more than :data:`BAND_LIMIT_MAJORITY` of the ``steeper`` slopes."""
    return steeper > 0 and fixed > BAND_LIMIT_MAJORITY * steeper


def _prefers_rougher_s(best_s: float, used_s: float) -> bool:
    """The shape fit's best s is smaller (rougher) than the fitted s by more than :data:`S_SAME`."""
    return best_s < used_s - S_SAME


def _spectral_agrees(min_ratio: float, max_ratio: float) -> bool:
    """All (c) ratios lie in 1 ± :data:`SPECTRAL_TOLERANCE`."""
    return 1.0 - SPECTRAL_TOLERANCE <= min_ratio and max_ratio <= 1.0 + SPECTRAL_TOLERANCE


def _map_departs_from_model(min_ratio: float, max_ratio: float, refined_fraction: float) -> bool:
    """(c) agrees everywhere (:func:`_spectral_agrees`) while (b') misses some cells."""
    return _spectral_agrees(min_ratio, max_ratio) and not _all_within(refined_fraction)


def _overpredicts(median_ratio: float) -> bool:
    """Median predicted/measured > :data:`LEVEL_HIGH`."""
    return median_ratio > LEVEL_HIGH


def _underpredicts(median_ratio: float) -> bool:
    """Median predicted/measured < :data:`LEVEL_LOW`."""
    return median_ratio < LEVEL_LOW


def _level_matches(median_ratio: float) -> bool:
    """:data:`LEVEL_LOW` ≤ median predicted/measured ≤ :data:`LEVEL_HIGH`."""
    return LEVEL_LOW <= median_ratio <= LEVEL_HIGH


def _low_degrees_match(low: float) -> bool:
    """|low-degree power ratio − 1| ≤ :data:`LOW_DEGREE_TOLERANCE`."""
    return abs(low - 1.0) <= LOW_DEGREE_TOLERANCE


def _display_clips(fraction: float) -> bool:
    """The display transform clips a positive fraction of the sphere."""
    return fraction > 0.0


def _fitted_s_is_best(best_s: float, used_s: float) -> bool:
    """The shape fit's best s is the fitted s (to :data:`S_SAME`)."""
    return abs(best_s - used_s) <= S_SAME


def _shapes_tie(residual_used: float, residual_best: float) -> bool:
    """The fitted s's residual exceeds the best one's by less than :data:`S_TIE_DEX`."""
    return residual_used - residual_best < S_TIE_DEX


def _truncation_exact(residue_fraction: float) -> bool:
    """The residue at L ≥ 1 is ≤ :data:`TRUTH_RESIDUE_FRACTION` of the L = 0 error."""
    return residue_fraction <= TRUTH_RESIDUE_FRACTION


# ----------------------------------------------------------------------------- the table

@dataclass(frozen=True)
class Condition:
    """A judgement of the report: the test, and what the report says either way.

    Attributes
    ----------
    predicate : callable
        Pure function of numbers printed in the report; returns ``bool``.
    when_true, when_false : str or None
        ``str.format`` template of the sentence (or table verdict) printed when the
        predicate holds / fails; ``None``: nothing is printed.
    """

    predicate: Callable[..., bool]
    when_true: str | None
    when_false: str | None


#: Condition name → :class:`Condition`. Every judgement :func:`render_report` prints comes
#: from one of these (through :func:`_say`).
CONDITIONS: dict[str, Condition] = {
    # acceptance table verdicts
    "slopes_verdict": Condition(_all_counted, "yes", "no"),
    "refined_slopes_verdict": Condition(_within_tolerance, "yes", "no"),
    "rank_verdict": Condition(_rank_identical, "yes", "no"),
    "absolute_verdict": Condition(_all_within, "yes", "no"),
    # slopes
    "slopes_agree": Condition(
        _all_agree,
        "All {n} fitted slopes agree within {tol} with the prediction.",
        "Slopes off by more than {tol}: {offenders}."),
    "band_limit_explains_slopes": Condition(
        _band_limit_explains,
        "The refined prediction (b′), which counts only the degrees l ≤ {band}, brings {fixed} "
        "of these {steeper} within {tol}: the band limit accounts for most of them.",
        "The refined prediction (b′), which counts only the degrees l ≤ {band}, brings only "
        "{fixed} of these {steeper} within {tol}: the band limit accounts for at most half of them."),
    "rougher_than_s": Condition(
        _prefers_rougher_s,
        "The shape fit of {brdf} prefers a rougher s ({best:.2f} < fitted {used:.3f}): the map "
        "is rougher than s says at the scales these N resolve, as an edge or a compact bright "
        "source would make it (more high-frequency power than the fitted l^(-2s) spectrum).",
        "The shape fit of {brdf} does not prefer a rougher s (best s = {best:.2f}, fitted "
        "{used:.3f}), so a uniformly rougher map does not explain them."),
    # rank
    "rank_identical": Condition(
        _rank_identical,
        "The rank order of the point sets is the predicted one for all {n} BRDF/weighting "
        "pairs (Kendall τ = 1).", None),
    "swaps_within_resolution": Condition(
        _swaps_within_resolution,
        "The swapped sets differ by at most {gap:.1%} in measured level ({pair}), within "
        "{factor:g}× the statistical resolution ({se:.1%}): noise can swap them.",
        "The swapped sets {pair} differ by {gap:.1%} in measured level, more than {factor:g}× "
        "the statistical resolution ({se:.1%}): the map's spectrum differs from the l^(-2s) "
        "model at the degrees those sets treat differently."),
    # absolute level
    "absolute_all_within": Condition(
        _all_within,
        "(b) σ·wce is within {tol:.0%} for every cell with N = {lo}…{hi} (ratio "
        "predicted/measured {min:.2f} … {max:.2f}, median {median:.2f}).",
        "(b) σ·wce is within {tol:.0%} for {fraction:.0%} of the cells with N = {lo}…{hi} "
        "(ratio predicted/measured {min:.2f} … {max:.2f}, median {median:.2f})."),
    "spectral_agrees": Condition(
        _spectral_agrees,
        "— within {band:.0%} everywhere: the error spectra and the measurement agree.",
        "— off by more than {band:.0%} somewhere: even the map's own spectrum does not predict "
        "the RMSE exactly (degrees above the grid's band limit under bilinear interpolation, "
        "or a few axes carrying the error, can do this)."),
    "map_departs_from_model": Condition(
        _map_departs_from_model,
        "As (c) agrees and (b′) misses {missed:.0%} of the cells, what (b′) misses is the map "
        "departing from the l^(-2s) model, not the error spectra or the measurement.", None),
    "model_overpredicts": Condition(
        _overpredicts,
        "The measured errors are smaller than σ̂·wce (median ratio {median:.2f} > {high:g}).",
        None),
    "band_limit_explains_level": Condition(
        _level_matches,
        "(b′), which counts only the degrees l ≤ {band} the map can hold, weighted by the "
        "bilinear lookup's transfer, has median ratio {median:.2f}: the band limit of the "
        "pixel grid and the smoothing of bilinear interpolation near it account for the difference.",
        "(b′), restricted to the degrees l ≤ {band} the map can hold, still has median ratio "
        "{median:.2f}, outside {low:g}…{high:g}: the band limit alone does not account for the "
        "difference."),
    "model_underpredicts": Condition(
        _underpredicts,
        "The measured errors are larger than σ̂·wce (median ratio {median:.2f} < {low:g}).", None),
    "few_features_explain_level": Condition(
        _heavy_tailed,
        "The per-axis errors are heavy-tailed (median kurtosis {kurtosis:.1f}): σ̂ is fitted to "
        "the map's typical variation, but the errors are dominated by a few features the GP "
        "model cannot describe.",
        "The per-axis errors are not heavy-tailed (median kurtosis {kurtosis:.1f}), so the "
        "excess is not carried by a few features: it points to more power at the degrees that "
        "dominate the quadrature error than σ̂ implies."),
    # distribution of the errors
    "errors_gaussian": Condition(
        _looks_gaussian,
        "The per-axis errors look Gaussian (median kurtosis {kurtosis:.1f}; 3 for a Gaussian "
        "field), as the GP reading assumes.",
        "The per-axis errors are not Gaussian: median kurtosis {kurtosis:.1f}, against 3 for a "
        "Gaussian field."),
    "heavy_tails": Condition(
        _heavy_tailed,
        "Tails that heavy mean the squared error is concentrated on a few axes, as when a lobe "
        "sees a small, very bright or sharp feature: such a feature is not a sample of a "
        "stationary Gaussian field, nor a Sobolev-smooth function of modest norm, so the RMSE "
        "over axes reflects it rather than the map's average roughness.", None),
    # the map
    "display_clips": Condition(
        _display_clips,
        "; the display transform clips {percent:.3g} % of the sphere at 1 (a clipped sun "
        "becomes a flat disc with a sharp edge, whose spectrum decays like an edge's rather "
        "than like the smooth sky's)",
        "; the display transform clips none of the sphere"),
    "power_rises": Condition(
        _rises_with_degree,
        "It rises with l (from {first:.2f} at l = {l_first} to {last:.2f} at l = {l_last}; "
        "Spearman ρ = {rho:.2f}): the map's spectrum decays more slowly than l^(-2s) at these "
        "degrees, as a compact, very bright source's would (its spectrum is nearly flat), "
        "which the likelihood fit, seeing few samples on it, does not capture in σ̂.",
        "It does not rise with l ({min:.2f}–{max:.2f}; Spearman ρ = {rho:.2f}, last/first "
        "{factor:.2f})."),
    "low_degrees_match": Condition(
        _low_degrees_match,
        "The lowest {n} degrees hold {low:.2f}× the model's power, within {tol:.0%} of it.",
        "The lowest {n} degrees hold {low:.2f}× the model's power: rules whose error lives "
        "there (random points with equal weights; the diffuse lobe at small N) follow this "
        "map's realised low-degree power rather than σ̂, which would put their "
        "predicted/measured ratio near 1/√{low:.2f} = {inverse:.2f}."),
    # the choice of s
    "fitted_s_best": Condition(
        _fitted_s_is_best,
        "{brdf} ({label}): the fitted s = {used:.3f} gives the best shape match among the "
        "candidates ({best_residual} dex).", None),
    "s_shapes_tie": Condition(
        _shapes_tie,
        "{brdf} ({label}): the fitted s = {used:.3f} and s = {best:.2f} match the measured "
        "shapes equally well ({used_residual:.3f} vs {best_residual:.3f} dex).",
        "{brdf} ({label}): the predicted shapes match best for s = {best:.2f} (residual "
        "{best_residual:.3f} dex) rather than the fitted s = {used:.3f} ({used_residual:.3f} "
        "dex) — the fit weighs all scales of the map, the quadrature error only those the lobe "
        "and N resolve."),
    # truncation
    "truncation_exact": Condition(
        _truncation_exact,
        "Exact for L ≥ 1 (b̃_l = 0 for l ≥ 2): the measured residue at L ≥ 1, {residue:.3g} "
        "({fraction:.2g} of the L = 0 error), is the ground truth's own accuracy.",
        "Exact for L ≥ 1 in theory (b̃_l = 0 for l ≥ 2), yet the measured residue at L ≥ 1 is "
        "{residue:.3g} ({fraction:.2g} of the L = 0 error): more than the ground truth's "
        "accuracy accounts for."),
}


def _say(name: str, args: tuple, **fields) -> str:
    """The sentence of condition ``name`` for ``predicate(*args)``, filled with ``fields``.

    Returns ``""`` when that outcome prints nothing.

    >>> _say("errors_gaussian", (5.2,), kurtosis=5.2)
    'The per-axis errors are not Gaussian: median kurtosis 5.2, against 3 for a Gaussian field.'
    """
    c = CONDITIONS[name]
    template = c.when_true if c.predicate(*args) else c.when_false
    return "" if template is None else template.format(**fields)


def _join(*parts: str) -> str:
    """The non-empty ``parts`` joined by single spaces."""
    return " ".join(p for p in parts if p)


# ----------------------------------------------------------------------------- formatting

def _f(v, fmt=".3g", none="–"):
    """``format(v, fmt)``, or ``none`` for a missing or non-finite value."""
    if v is None:
        return none
    try:
        if isinstance(v, float) and not math.isfinite(v):
            return none
        return format(v, fmt)
    except (TypeError, ValueError):
        return str(v)


def _table(header: list[str], rows: list[list]) -> list[str]:
    """Markdown table lines."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(x) for x in r) + " |")
    return out


def _brdf_name(result, b):
    """Display name of BRDF ``b`` (the glossy one with its shininess)."""
    return f"glossy (n = {result['config'].get('shininess', 30):g})" if b == "glossy" else b


def _band(r):
    """The band limit (highest degree) of the map, from the first cell that has it."""
    for e in r.get("results", []):
        if e.get("band_lmax") is not None:
            return e["band_lmax"]
    return "H − 1"


def _median(xs):
    """Median of the finite values of ``xs`` (``None`` if there are none)."""
    xs = sorted(x for x in xs if x is not None and math.isfinite(x))
    if not xs:
        return None
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def _median_of(r: dict, key: str):
    """Median over every cell of ``results`` of the list ``key``."""
    return _median([x for e in r.get("results", []) for x in (e.get(key) or [])])


def _abs_summary(ab: dict, key: str) -> str:
    """The acceptance-table cell of one absolute prediction (``ab[key]``)."""
    d = ab.get(key)
    if not d:
        return "–"
    return (f"median ratio {d['median_ratio']:.2f}, range {d['min_ratio']:.2f} … {d['max_ratio']:.2f}, "
            f"{d['fraction_within']:.0%} of {d['cells']} cells within → "
            + _say("absolute_verdict", (d["fraction_within"],)))


# ----------------------------------------------------------------------------- the report

def render_report(result: dict, figures: dict[str, str] | None = None) -> str:
    """Markdown text of the validation report for ``result`` (see the module docstring).

    Parameters
    ----------
    result : dict
        The JSON-ready dict of :func:`envfit.validate.pipeline.run_validation` (its
        ``to_json()``, or the saved ``validate.json``); an object with ``to_json`` is converted.
    figures : dict, optional
        Figure name → path; linked by file name (the report is written next to them).

    Returns
    -------
    str
        The Markdown text.
    """
    if hasattr(result, "to_json"):
        result = result.to_json()
    lines = [f"# Validation of predicted shading-integral errors: {result['map']}", ""]
    lines += _what_was_run(result)
    lines += _predictions_explained(result)
    lines += _figures_section(figures)
    lines += _agreement_section(result)
    lines += _disagreements_section(result)
    return "\n".join(lines)


def _what_was_run(r: dict) -> list[str]:
    """The "What was run" list: map, smoothness, scale, axes, quadrature, extras."""
    cfg, fit = r.get("config", {}), r.get("fit", {})
    size = r.get("map_size", ["?", "?"])
    out = ["## What was run", "",
           f"- **Map**: `{r['map']}`, {size[0]}x{size[1]}, {r.get('channels', '?')} channel(s); "
           f"value scale **{r['scale']}** ({r.get('scale_description', '')}). The integrand is "
           "the bilinear interpolant of the scaled pixels; the ground truth is its exact "
           "shading integral (`envfit.shading.ground_truth`, SH of the bilinear interpolant)."]
    if fit.get("source") == "fit":
        iv = fit.get("s_interval") or [None, None]
        out.append(f"- **Smoothness**: s = {r['s']:.3f} fitted by `envfit fit --method "
                   f"{fit.get('method', 'likelihood')}` from {fit.get('n')} samples "
                   f"(95 % interval {_f(iv[0], '.3f')} … {_f(iv[1], '.3f')}).")
    else:
        out.append(f"- **Smoothness**: s = {r['s']:.3f} given; σ̂ from the profiled likelihood "
                   f"at that s ({fit.get('n')} spherical Fibonacci samples).")
    out.append(f"- **Scale of the GP model**: σ̂ = {r['sigma']:.4g} (channels: "
               + ", ".join(f"{x:.4g}" for x in r.get("sigma_channels", [])) + "; combined as RMS).")
    out.append(f"- **Axes**: M = {r['axes']} uniform random axes (seed {r.get('seed', 0)}); each "
               "point set is morphed for the BRDF (importance sampling, Sec. 7.2) and rotated "
               "into every axis' frame with an independent random twist.")
    out.append(f"- **Quadrature** (Fig. 7): BRDFs {', '.join(_brdf_name(r, b) for b in cfg.get('brdfs', []))}; "
               f"point sets {', '.join(cfg.get('pointsets', []))}; weights "
               f"{', '.join(cfg.get('weights', []))} (OSW computed for s = {r['s']:.3f}); "
               f"N = {', '.join(str(n) for n in cfg.get('n_values', []))}. One realisation "
               "per N for the stochastic sets; its own worst-case error is the prediction.")
    return out + _run_extras(r)


def _run_extras(r: dict) -> list[str]:
    """Truncation setting, quick mode, timings, costs and notes of the run."""
    out = []
    if r.get("config", {}).get("truncation"):
        desc = "; ".join(f"{t['brdf']} {t['basis'].upper()} L = {t['L'][0]}…{t['L'][-1]} "
                         f"({t['axes']} axes, {t['map_height']} rows)" for t in r.get("truncation", []))
        out.append(f"- **Truncation** (Fig. 8): {desc}. HSH projections are a clipped "
                   "hemispherical quadrature per axis, hence the smaller setting; its ground "
                   "truth is computed on that same downscaled map.")
    if r.get("quick_description"):
        out.append(f"- **Quick mode**: {r['quick_description']}")
    t = r.get("timings", {})
    out.append("- **Time**: " + ", ".join(f"{k} {v:.0f} s" for k, v in t.items() if v is not None)
               + " (wall clock of this run; `compute` adds up the costs stored with every cell, "
                 "so a resumed run still shows what its result cost).")
    costs = r.get("costs") or {}
    if costs.get("by_pointset"):
        out.append("- **Cost of the quadrature cells** (point set generation, weights, lookups, "
                   "worst-case errors; seconds, as stored with each cell when it was computed): by point set "
                   + ", ".join(f"{k} {v:.0f}" for k, v in costs["by_pointset"].items())
                   + "; by weighting " + ", ".join(f"{k} {v:.0f}" for k, v in costs["by_weights"].items())
                   + "; by N " + ", ".join(f"{k}: {v:.0f}" for k, v in costs["by_n"].items()) + ".")
    out += [f"- note: {n}" for n in r.get("notes", [])]
    return out


def _transfer_numbers(r: dict) -> str:
    """τ_l at l = 0 and at the band limit, as measured on the map (or nothing)."""
    tau = r.get("lookup_transfer") or []
    return f": τ_0 = {tau[0]:.2f}, τ_{len(tau) - 1} = {tau[-1]:.2f}" if len(tau) >= 2 else ""


def _predictions_explained(r: dict) -> list[str]:
    """What the predictions (a), (b), (b′) and (c) are."""
    size = r.get("map_size", ["?", "?"])
    return [
        "", "Predictions of the RMSE:", "",
        "- **(a) shape only** (the paper, Sec. 9.2): c·wce(s), one factor c per BRDF, "
        "log c = mean over every point set, weighting and N of (log measured − log wce).",
        "- **(b) absolute**: σ̂·wce(s). Under the Gaussian-process reading of the Sobolev "
        "model, f ~ GP(0, σ² K_gd^(s)), the expected squared error of a linear rule is "
        "σ²·wce²; no measured error is used.",
        f"- **(b′) absolute, refined**: the same model made exact for a lat-long map of "
        f"{size[1]} rows read by bilinear lookups, with a non-zero mean m̄: "
        f"(σ̂′²·Σ_{{l≤{_band(r)}}} a_l(ŝ′) τ_l e_l + (Σw − 1)²·m̄²)^½ — the error spectrum "
        "(Eq. 42) summed only over the degrees the map can hold, each weighted by the "
        "bilinear lookup's transfer τ_l (the interpolant's power over the pixel values' "
        f"power, measured on the map{_transfer_numbers(r)}), plus the "
        "error a rule whose weights do not sum to 1 (OSW) makes on the map's mean (the GP "
        "model is zero-mean; the fit removes the mean); ŝ′ and σ̂′ come from the likelihood "
        "of the same band-limited model (kernel truncated at the band limit, samples at "
        f"pixel centres): ŝ′ = {_f(r.get('s_refined'), '.3f')}, σ̂′ = "
        f"{_f(r.get('sigma_refined'), '.4g')} (the paper's fit: ŝ = {_f(r.get('s'), '.3f')}). "
        "Beyond the paper; for the synthesized GP maps (band-limited at that degree) it is "
        "the exact model. "
        "One map is one realisation of the model: its power in the few low degrees scatters "
        "(χ² with 2l+1 degrees of freedom per channel), so its RMSE departs from (b′) by an "
        "expected relative standard deviation computed per cell (`model_scatter`).",
        "- **(c) spectral** (beyond the paper, no model): the map's own power per degree "
        "times the rule's error power per degree, (Σ_l P̂_l e_l)^½ — the exact mean over "
        "random rotations for this map. It checks the measurement and the error spectra; "
        "where (c) agrees and (b′) does not, the map is not the model.", ""]


def _figures_section(figures: dict[str, str] | None) -> list[str]:
    """Links to the figures (by file name), or nothing."""
    if not figures:
        return []
    out = ["## Figures", ""]
    for name in figures:
        out += [f"![{name}]({Path(figures[name]).name})", ""]
    return out


# ----------------------------------------------------------------------------- agreement

def _agreement_section(r: dict) -> list[str]:
    """The "Agreement" section: the acceptance table and the detailed tables."""
    return (["## Agreement", ""] + _acceptance_table(r) + _slopes_table(r) + _rank_table(r)
            + _shape_fit_table(r) + _absolute_tables(r) + _truncation_tables(r))


def _acceptance_table(r: dict) -> list[str]:
    """The check/result table; every verdict from :data:`CONDITIONS`."""
    agr = r.get("agreement", {})
    acc, ab = agr.get("acceptance", {}), agr.get("absolute", {})
    if not acc:
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    tol = acc.get("slope_tolerance", 0.1)
    within, checked = acc.get("slopes_within"), acc.get("slopes_checked")
    d_ref = acc.get("max_abs_slope_difference_refined")
    tau = acc.get("min_kendall_tau")
    scatter = (ab.get("slope_range_refined") or {}).get("fraction_within_expected_scatter")
    rows = [
        [f"slopes of sf/random within {tol} (N = {lo}…{hi})",
         f"{within}/{checked} (max abs difference {_f(acc.get('max_abs_slope_difference'), '.3f')}) → "
         + _say("slopes_verdict", (within, checked))],
        ["same, against the refined prediction (b′)",
         f"max abs difference {_f(d_ref, '.3f')} → " + _say("refined_slopes_verdict", (d_ref, tol))],
        ["rank order of the point sets identical (Kendall τ = 1)",
         f"min τ = {_f(tau, '.3f')} → " + _say("rank_verdict", ([] if tau is None else [tau],))],
        [f"(b) σ·wce within {ab.get('tolerance', 0.2):.0%} of the measured "
         f"RMSE at every N in {lo}…{hi}", _abs_summary(ab, "slope_range")],
        ["(b′) refined, same check", _abs_summary(ab, "slope_range_refined")],
        ["(b′) within the tolerance or 2 expected standard deviations (one map's realisation + "
         "the axes' Monte Carlo error)", _f(scatter, ".0%")],
        ["(c) spectral (the map's own power spectrum; checks the machinery)",
         _abs_summary(ab, "slope_range_spectral")],
    ]
    return _table(["check", "result"], rows) + [""]


def _slopes_table(r: dict) -> list[str]:
    """Measured and predicted convergence slopes per rule."""
    agr = r.get("agreement", {})
    if not agr.get("slopes"):
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    rows = [[_brdf_name(r, s["brdf"]), s["pointset"], s["weights"], _f(s["measured"], ".3f"),
             _f(s["predicted"], ".3f"), _f(s["difference"], "+.3f"),
             _f(s.get("predicted_refined"), ".3f"), _f(s.get("difference_refined"), "+.3f")]
            for s in agr["slopes"]]
    return ([f"### Convergence slopes (least squares in log-log, N = {lo}…{hi})", ""]
            + _table(["BRDF", "point set", "weights", "measured", "predicted", "Δ",
                      "predicted (b′)", "Δ (b′)"], rows) + [""])


def _rank_table(r: dict) -> list[str]:
    """Measured and predicted rank order of the point sets."""
    agr = r.get("agreement", {})
    if not agr.get("rank"):
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    rows = [[_brdf_name(r, k["brdf"]), k["weights"], " < ".join(k["measured_order"]),
             " < ".join(k["predicted_order"]), _f(k["kendall_tau"], ".3f")] for k in agr["rank"]]
    return ([f"### Rank order of the point sets (geometric mean over N = {lo}…{hi}; best first)", ""]
            + _table(["BRDF", "weights", "measured", "predicted", "Kendall τ"], rows) + [""])


def _shape_fit_rows(r: dict, s_keys: list[str]) -> list[list]:
    """Rows of the shape-fit table: per BRDF the wce and the band-limited wce residuals."""
    agr = r.get("agreement", {})
    sf, choice = agr.get("shape_fit", {}), agr.get("s_choice", {})
    rows = []
    for b, c in sf["constant"].items():
        ch = choice.get(b, {})
        for suffix, label in (("", "wce"), ("_bandlimited", f"wce, l ≤ {_band(r)}")):
            res = ch.get("residual_by_s" + suffix)
            if not res:
                continue
            row = [_brdf_name(r, b), label, _f(c, ".4g") if not suffix else "",
                   _f(sf["residual_dex"].get(b), ".3f") if not suffix else ""]
            row += [_f(res.get(k, {}).get("residual_dex"), ".3f") for k in s_keys]
            rows.append(row + [_f(ch.get("best_s" + suffix), ".2f")])
    return rows


def _shape_fit_table(r: dict) -> list[str]:
    """The shape fit (a): constants, residuals per candidate s, the best s."""
    agr = r.get("agreement", {})
    sf = agr.get("shape_fit", {})
    if not sf.get("constant"):
        return []
    s_keys = sorted({k for v in agr.get("s_choice", {}).values() for k in v["residual_by_s"]},
                    key=float)
    header = (["BRDF", "prediction", "c", "residual (dex)"]
              + [f"res. s={float(k):.2f}" for k in s_keys] + ["best s"])
    return (["### Shape fit (a) and the choice of s", "", f"{sf.get('method', '')}.", ""]
            + _table(header, _shape_fit_rows(r, s_keys))
            + ["", "The residual is the RMS (in decades) of log10 measured − log10 predicted − "
                   "log10 c with c refitted for each s; the band-limited row uses the worst-case "
                   "error summed over the degrees the map holds (the shape part of (b′)).", ""])


def _absolute_group(r: dict, b: str, w: str) -> list[str]:
    """The (b) / (b′) ± sd / (c) ratio table of one BRDF and weighting."""
    ab = r["agreement"]["absolute"]
    prb = {(e["brdf"], e["pointset"], e["weights"]): e for e in ab.get("per_rule_refined", [])}
    prc = {(e["brdf"], e["pointset"], e["weights"]): e for e in ab.get("per_rule_spectral", [])}
    es = [e for e in ab["per_rule"] if e["brdf"] == b and e["weights"] == w]
    ns = es[0]["n"]
    none = {"predicted_over_measured": [None] * len(ns), "expected_relative_sd": [None] * len(ns)}
    rows = []
    for e in es:
        eb = prb.get((b, e["pointset"], w), none)
        ec = prc.get((b, e["pointset"], w), none)
        sd = eb.get("expected_relative_sd") or [None] * len(ns)
        rows.append([e["pointset"]] + [f"{_f(x, '.2f')} / {_f(y, '.2f')} ±{_f(d, '.2f')} / {_f(z, '.2f')}"
                                       for x, y, d, z in zip(e["predicted_over_measured"],
                                                             eb["predicted_over_measured"], sd,
                                                             ec["predicted_over_measured"])])
    return ([f"**{_brdf_name(r, b)}, {w}** (cells: (b) / (b′) ± sd / (c))", ""]
            + _table(["point set"] + [f"N={n}" for n in ns], rows) + [""])


def _absolute_tables(r: dict) -> list[str]:
    """Predicted/measured RMSE of every cell, one table per BRDF and weighting."""
    ab = r.get("agreement", {}).get("absolute", {})
    if not ab.get("per_rule"):
        return []
    out = ["### Absolute predictions: predicted / measured RMSE, (b) σ·wce, (b′) refined "
           "± its expected relative spread for one map, (c) spectral", ""]
    for b, w in dict.fromkeys((e["brdf"], e["weights"]) for e in ab["per_rule"]):
        out += _absolute_group(r, b, w)
    return out


def _truncation_rows(tcur: dict) -> list[list]:
    """Rows of one truncation table: L, measured, (a), (b), (b)/measured, equivalent N."""
    n = len(tcur["L"])
    shape = tcur.get("predicted_shape") or [None] * n
    meas_n = tcur.get("measured_qmc_equivalent_n") or [None] * n
    rows = []
    for i, L in enumerate(tcur["L"]):
        m, pb = tcur["measured_rmse"][i], tcur["predicted_rmse"][i]
        ratio = None if (pb is None or not m or pb <= 0) else pb / m
        rows.append([L, _f(m), _f(shape[i]), _f(pb), _f(ratio, ".2f"),
                     _f(tcur["qmc_equivalent_n"][i], "d"), _f(meas_n[i], ".0f")])
    return rows


def _truncation_tables(r: dict) -> list[str]:
    """The truncation curves (Fig. 8), one table per BRDF and basis."""
    if not r.get("truncation"):
        return []
    out = ["### Truncation (Fig. 8)", "",
           "Measured RMSE, predictions (a) c·wce (c of the quadrature fit of the same BRDF) and "
           "(b) σ·wce, and the QMC-equivalent N (morphed spherical Fibonacci, equal weights): "
           "theory (`envfit.theory.truncation.equivalent_qmc_points` on the predicted wce) and measured "
           "(where the measured SF/equal RMSE curve reaches the measured truncation RMSE).", ""]
    for tcur in r["truncation"]:
        out += [f"**{_brdf_name(r, tcur['brdf'])}, {tcur['basis'].upper()}** "
                f"({tcur['axes']} axes, {tcur['map_height']} rows)", ""]
        out += _table(["L", "measured", "(a) c·wce", "(b) σ·wce", "(b)/measured",
                       "equiv. N (theory)", "equiv. N (measured)"], _truncation_rows(tcur)) + [""]
    return out


# ----------------------------------------------------------------------------- what disagrees

def _disagreements_section(r: dict) -> list[str]:
    """The "What disagrees and why" section."""
    return ["## What disagrees and why", ""] + [f"- {x}" for x in _disagreements(r)] + [""]


def _disagreements(r: dict) -> list[str]:
    """Statements of the "what disagrees and why" section, each chosen by :data:`CONDITIONS`."""
    se = _median_of(r, "measured_rel_se")
    kurt = _median_of(r, "error_kurtosis")
    out = [] if se is None else [_resolution_statement(r, se)]
    out += _slope_statements(r)
    out += _rank_statements(r, se)
    out += _absolute_statements(r, kurt)
    out += _kurtosis_statements(kurt)
    out += _map_statements(r)
    out += _s_choice_statements(r)
    out += _truncation_statements(r)
    return [x for x in out if x]


def _resolution_statement(r: dict, se: float) -> str:
    """The median relative standard error of a measured RMSE (no judgement)."""
    return (f"Statistical resolution: the median relative standard error of a measured RMSE "
            f"over the {r['axes']} axes is {se:.1%} (from the spread of the per-axis squared "
            "errors; neighbouring axes are correlated, so treat it as a lower bound). "
            "Differences below a few times this are noise.")


def _rule(s: dict) -> str:
    """``brdf/pointset/weights`` of a slope entry."""
    return f"{s['brdf']}/{s['pointset']}/{s['weights']}"


def _slope_statements(r: dict) -> list[str]:
    """Slopes against the prediction; the faster and the slower ones and what explains them."""
    agr = r.get("agreement", {})
    tol = agr.get("acceptance", {}).get("slope_tolerance", 0.1)
    slopes = [s for s in agr.get("slopes", []) if s["difference"] is not None]
    if not slopes:
        return []
    bad = [s for s in slopes if abs(s["difference"]) > tol]
    offenders = ", ".join(f"{_rule(s)} ({s['difference']:+.2f})" for s in bad)
    out = [_say("slopes_agree", ([s["difference"] for s in slopes], tol),
                n=len(slopes), tol=tol, offenders=offenders)]
    steeper = [s for s in bad if s["difference"] < 0]
    if steeper:
        fixed = sum(1 for s in steeper if s.get("difference_refined") is not None
                    and abs(s["difference_refined"]) <= tol)
        band = _band(r)
        out.append(_join(
            f"{len(steeper)} of them converge *faster* than predicted. The theory's wce counts the "
            f"error from every degree l, but a {r['map_size'][1]}-row map holds none above l ≈ "
            f"{band}: once N is large enough that a good point set's error spectrum lives mostly "
            "above that degree, the measured error drops faster than the N^(-s/2)-type rate.",
            _say("band_limit_explains_slopes", (fixed, len(steeper)),
                 band=band, fixed=fixed, steeper=len(steeper), tol=tol)))
    shallower = [s for s in bad if s["difference"] > 0]
    if shallower:
        out.append(_join(f"{len(shallower)} converge *slower* than predicted: "
                         + ", ".join(_rule(s) for s in shallower) + ".",
                         *_rougher_statements(r, shallower)))
    return out


def _rougher_statements(r: dict, shallower: list[dict]) -> list[str]:
    """Per BRDF of the slower slopes: whether its shape fit prefers a rougher s."""
    choice = r.get("agreement", {}).get("s_choice", {})
    out = []
    for b in dict.fromkeys(s["brdf"] for s in shallower):
        best, used = choice.get(b, {}).get("best_s"), choice.get(b, {}).get("used_s")
        if best is not None and used is not None:
            out.append(_say("rougher_than_s", (best, used), brdf=b, best=best, used=used))
    return out


def _swapped_gap(k: dict) -> tuple[float, str] | None:
    """Largest relative measured-level difference among the pairs the two orders swap."""
    levels = dict(zip(k.get("pointsets") or [], k.get("measured_level") or []))
    pm = {p: i for i, p in enumerate(k["measured_order"])}
    pp = {p: i for i, p in enumerate(k["predicted_order"])}
    best = None
    for a, ia in pm.items():
        for b, ib in pm.items():
            la, lb = levels.get(a), levels.get(b)
            if (a >= b or b not in pp or a not in pp or not la or not lb
                    or (ia - ib) * (pp[a] - pp[b]) >= 0):
                continue
            gap = max(la, lb) / min(la, lb) - 1.0
            if best is None or gap > best[0]:
                best = (gap, f"{a}/{b}")
    return best


def _rank_statements(r: dict, se: float | None) -> list[str]:
    """Rank order identical, or per differing order whether the swap is within the noise."""
    ranks = [k for k in r.get("agreement", {}).get("rank", []) if k["kendall_tau"] is not None]
    if not ranks:
        return []
    out = [_say("rank_identical", ([k["kendall_tau"] for k in ranks],), n=len(ranks))]
    for k in ranks:
        if _rank_identical([k["kendall_tau"]]):
            continue
        gap = _swapped_gap(k)
        why = "" if (gap is None or se is None) else _say(
            "swaps_within_resolution", (gap[0], se), gap=gap[0], pair=gap[1],
            factor=RESOLUTION_FACTOR, se=se)
        out.append(_join(f"Rank order differs for {k['brdf']}/{k['weights']} (τ = "
                         f"{k['kendall_tau']:.2f}): measured {' < '.join(k['measured_order'])}, "
                         f"predicted {' < '.join(k['predicted_order'])}.", why))
    return out


def _absolute_statements(r: dict, kurt: float | None) -> list[str]:
    """(b), (b′) and (c) over the slope range, and what explains a level off by a factor."""
    agr = r.get("agreement", {})
    ab = agr.get("absolute", {})
    d, db, dc = ab.get("slope_range"), ab.get("slope_range_refined"), ab.get("slope_range_spectral")
    if not d:
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    out = [_say("absolute_all_within", (d["fraction_within"],), tol=ab.get("tolerance", 0.2),
                fraction=d["fraction_within"], lo=lo, hi=hi, min=d["min_ratio"],
                max=d["max_ratio"], median=d["median_ratio"])]
    if db:
        out.append(f"(b′) refined: {db['fraction_within']:.0%} within (ratio {db['min_ratio']:.2f} … "
                   f"{db['max_ratio']:.2f}, median {db['median_ratio']:.2f}); "
                   f"{db.get('fraction_within_expected_scatter', 0):.0%} within the tolerance or "
                   "2 expected standard deviations of one map's realisation.")
    if dc:
        out.append(_join(f"(c) spectral, from the map's own power spectrum: ratio {dc['min_ratio']:.2f} … "
                         f"{dc['max_ratio']:.2f}, median {dc['median_ratio']:.2f}",
                         _say("spectral_agrees", (dc["min_ratio"], dc["max_ratio"]),
                              band=SPECTRAL_TOLERANCE)))
        if db:
            out.append(_say("map_departs_from_model",
                            (dc["min_ratio"], dc["max_ratio"], db["fraction_within"]),
                            missed=1.0 - db["fraction_within"]))
    return out + _level_statements(r, d["median_ratio"], db, kurt)


def _level_statements(r: dict, median: float, db: dict | None, kurt: float | None) -> list[str]:
    """(b) too high or too low on the median, and the test of the explanation."""
    out = [_say("model_overpredicts", (median,), median=median, high=LEVEL_HIGH),
           _say("model_underpredicts", (median,), median=median, low=LEVEL_LOW)]
    if _overpredicts(median) and db:
        out.append(_say("band_limit_explains_level", (db["median_ratio"],), band=_band(r),
                        median=db["median_ratio"], low=LEVEL_LOW, high=LEVEL_HIGH))
    if _underpredicts(median) and kurt is not None:
        out.append(_say("few_features_explain_level", (kurt,), kurtosis=kurt))
    return out


def _kurtosis_statements(kurt: float | None) -> list[str]:
    """Whether the per-axis errors look Gaussian, and what heavy tails mean."""
    if kurt is None:
        return []
    return [_join(_say("errors_gaussian", (kurt,), kurtosis=kurt), _say("heavy_tails", (kurt,)))]


def _map_statements(r: dict) -> list[str]:
    """The map's dynamic range and clipping, and its power per degree against the model."""
    stats = r.get("map_stats", {}) or {}
    out = []
    if stats.get("peak_over_mean") is not None:
        txt = (f"Map dynamic range: peak/mean luminance {stats['peak_over_mean']:.3g}; half of the "
               f"linear energy lies in {100 * (stats.get('solid_angle_fraction_half_energy') or 0):.3g} % "
               "of the sphere")
        clipped = stats.get("display_clipped_fraction")
        if clipped is not None:
            txt += _say("display_clips", (clipped,), percent=100 * clipped)
        out.append(txt + ".")
    pr = stats.get("power_ratio_low_degrees") or {}
    if pr:
        out.append(_power_ratio_statement(pr, r.get("channels", 1)))
    return out


def _power_ratio_statement(pr: dict, channels: int) -> str:
    """The power ratio per degree; whether it rises with l; the lowest degrees' level."""
    ls = sorted(pr, key=int)
    rho = [pr[k] for k in ls]
    vals = ", ".join(f"l={k}: {pr[k]:.2f}" for k in ls)
    txt = (f"The map's own power per degree against the model's σ̂²·a_l (1 = as the GP "
           f"model expects; one map scatters by √(2/((2l+1)C)), ≈ "
           f"{math.sqrt(2 / (3 * max(1, channels))):.0%} at l = 1): {vals}.")
    rise = ""
    if len(rho) >= TREND_MIN_POINTS:
        sp = _spearman(list(range(len(rho))), rho)
        rise = _say("power_rises", (rho,), first=rho[0], last=rho[-1], l_first=ls[0],
                    l_last=ls[-1], rho=sp, min=min(rho), max=max(rho),
                    factor=rho[-1] / rho[0] if rho[0] > 0 else float("inf"))
    n = min(LOW_DEGREES, len(rho))
    low = sum(rho[:n]) / n
    level = _say("low_degrees_match", (low,), n=n, low=low, tol=LOW_DEGREE_TOLERANCE,
                 inverse=1 / math.sqrt(low) if low > 0 else float("inf"))
    return _join(txt, rise, level)


def _s_choice_statement(b: str, label: str, used: float, best: float, res: dict) -> str:
    """Whether the fitted s gives the best shape match for one BRDF and wce variant."""
    rb = res.get(f"{best:.4f}", {}).get("residual_dex")
    ru = res.get(f"{used:.4f}", {}).get("residual_dex")
    if _fitted_s_is_best(best, used):
        return _say("fitted_s_best", (best, used), brdf=b, label=label, used=used,
                    best_residual=_f(rb, ".3f"))
    if rb is None:
        return ""
    if ru is None:
        return (f"{b} ({label}): the predicted shapes match best for s = {best:.2f} (residual "
                f"{rb:.3f} dex) among the candidates; the fitted s = {used:.3f} is not among them.")
    return _say("s_shapes_tie", (ru, rb), brdf=b, label=label, used=used, best=best,
                used_residual=ru, best_residual=rb)


def _s_choice_statements(r: dict) -> list[str]:
    """The choice of s per BRDF, for the wce and the band-limited wce."""
    out = []
    for b, v in r.get("agreement", {}).get("s_choice", {}).items():
        for suffix, label in (("", "wce"), ("_bandlimited", "band-limited wce")):
            best, used = v.get("best_s" + suffix), v.get("used_s")
            if best is not None and used is not None:
                out.append(_s_choice_statement(b, label, used, best, v.get("residual_by_s" + suffix) or {}))
    return out


def _exact_truncation_statement(r: dict, t: dict) -> str:
    """For diffuse HSH (exact from L = 1): whether the residue is the ground truth's accuracy."""
    cur = next((c for c in r.get("truncation", []) if c["brdf"] == t["brdf"]
                and c["basis"] == t["basis"]), None)
    meas = [] if cur is None else cur.get("measured_rmse") or []
    rest = [m for L, m in zip(t["L"], meas) if L >= 1 and m is not None]
    if not rest or not meas or not meas[0]:
        return ""
    residue = max(rest)
    return _say("truncation_exact", (residue / meas[0],), residue=residue, fraction=residue / meas[0])


def _truncation_statements(r: dict) -> list[str]:
    """The range of σ·wce / measured over L for every truncation curve."""
    out = []
    for t in r.get("agreement", {}).get("truncation", []):
        ratios = [x for x in t.get("predicted_over_measured", []) if x is not None]
        if not ratios:
            continue
        exact = (_exact_truncation_statement(r, t)
                 if t["brdf"] == "diffuse" and t["basis"] == "hsh" else "")
        out.append(_join(f"Truncation {t['brdf']}/{t['basis'].upper()}: σ·wce / measured ranges "
                         f"{min(ratios):.2f} … {max(ratios):.2f} over L = {t['L'][0]}…{t['L'][-1]} "
                         f"(shape residual {_f(t.get('shape_residual_dex'), '.3f')} dex).", exact))
    return out


def write_report(result: dict, path: str | Path, figures: dict[str, str] | None = None) -> Path:
    """Write :func:`render_report` to ``path`` atomically.

    Parameters
    ----------
    result : dict
        What :func:`envfit.validate.pipeline.run_validation` returns.
    path : str or Path
        Where to write ``report.md``.
    figures : dict, optional
        Figure name → path (see :func:`render_report`).

    Returns
    -------
    Path
        ``path``.
    """
    return atomic_write_text(path, render_report(result, figures))

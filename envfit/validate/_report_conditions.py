r"""The judgements of ``report.md``: named thresholds, pure predicates and the :data:`CONDITIONS` table.

Every sentence of the validation report (:mod:`envfit.validate._report`) that states a
judgement (a verdict, a trend, a shape of a distribution, a cause) is chosen by a named, pure
predicate of numbers printed in the same report. The predicates, their thresholds and the
sentence each outcome prints are listed in :data:`CONDITIONS`; :func:`_say` picks and fills
the sentence of the outcome the numbers satisfy. So the text never claims what the data do
not show: when a test fails the report prints the sentence that is true of the numbers
instead (e.g. "It does not rise with l (0.17–0.92; …)").

Example
-------
>>> _rises_with_degree([0.17, 0.92, 0.4, 0.6]), _looks_gaussian(5.2)
(False, False)
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from scipy import stats

__all__ = ["CONDITIONS", "RENDERER_CONDITIONS", "Condition"]

# ----------------------------------------------------------------------------- thresholds

#: Spearman rank correlation of the power ratio against l needed to call it rising: a
#: monotone trend, not one high degree (ρ = 0.8 is the usual "strong" cut).
RISE_MIN_SPEARMAN = 0.8
#: rounding of scipy's ρ (Pearson's r of the ranks): ρ = 1 − 6Σd²/(n(n²−1)) is exactly 0.8
#: for some rankings (n = 5, Σd² = 4), which spearmanr returns as 0.7999999999999999; ρ's
#: distinct values are ≥ 1/n³ apart, so this tolerance only restores the exact comparison
SPEARMAN_ROUNDING = 1e-12
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
#: ``--renderer``: the range of a rule's median predicted/measured ratio called accurate
#: (±10 %: the measured interval's own target half-width).
RENDERER_RATIO_LOW = 0.9
RENDERER_RATIO_HIGH = 1.1


# ----------------------------------------------------------------------------- predicates

def _spearman(x: list[float], y: list[float]) -> float:
    """Spearman rank correlation of ``x`` and ``y``: ``scipy.stats.spearmanr`` (Pearson's r of
    the average ranks, so ties share a rank); 0 if either is constant (where scipy warns and
    gives NaN); a NaN value gives NaN (no trend is then claimed: NaN ≥ ρ_min is false).

    >>> _spearman([1, 2, 3], [0.1, 0.5, 0.4])
    0.5
    """
    if len(set(x)) < 2 or len(set(y)) < 2:
        return 0.0
    return float(stats.spearmanr(x, y).statistic)


def _rises_with_degree(ratios: list[float]) -> bool:
    """Whether ``ratios`` (ordered by degree l) rise with l.

    Needs :data:`TREND_MIN_POINTS` values, Spearman ρ(ratio, l) ≥ :data:`RISE_MIN_SPEARMAN`
    and last/first ≥ :data:`RISE_MIN_FACTOR`.
    """
    if len(ratios) < TREND_MIN_POINTS or ratios[0] <= 0:
        return False
    rho = _spearman(list(range(len(ratios))), ratios)
    return (rho >= RISE_MIN_SPEARMAN - SPEARMAN_ROUNDING
            and ratios[-1] / ratios[0] >= RISE_MIN_FACTOR)


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


def _ratios_in_range(medians: list[float | None]) -> bool:
    """Every median ratio is known and in [:data:`RENDERER_RATIO_LOW`,
    :data:`RENDERER_RATIO_HIGH`] (and there is at least one)."""
    return bool(medians) and all(m is not None and RENDERER_RATIO_LOW <= m <= RENDERER_RATIO_HIGH
                                 for m in medians)


def _interval_below(high: float, other_low: float) -> bool:
    """The upper end of one 95 % interval lies below the lower end of the other."""
    return high < other_low


def _any_found(count: int) -> bool:
    """At least one."""
    return count > 0


def _all_below(pairs: list[tuple[float, float]]) -> bool:
    """Every first value is below its second (and there is at least one pair)."""
    return bool(pairs) and all(a < b for a, b in pairs)


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


#: Condition name → :class:`Condition`. Every judgement
#: :func:`envfit.validate._report.render_report` prints comes from one of these (through :func:`_say`).
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


#: Condition name → :class:`Condition` of the "Renderer rules" section (``--renderer``,
#: :mod:`envfit.validate._report_renderer`, through :func:`_say_renderer`).
RENDERER_CONDITIONS: dict[str, Condition] = {
    "renderer_ratios_within": Condition(
        _ratios_in_range,
        "For every rule ({n}) the median predicted/measured ratio is within {lo:g}–{hi:g} "
        "({min}–{max}).",
        "The median predicted/measured ratio is outside {lo:g}–{hi:g} for {k} of the {n} "
        "rules: {offenders}."),
    "renderer_lobe_agrees": Condition(
        _all_within,
        "{lobe}: all {n} cells agree (within {band:.0%} or inside the 95 % interval); median "
        "ratio {median}, worst {worst} ({rule}, N = {worst_n}).",
        "{lobe}: {agree} of {n} cells agree (within {band:.0%} or inside the 95 % interval); "
        "median ratio {median}, worst {worst} ({rule}, N = {worst_n})."),
    "renderer_lowest_resolved": Condition(
        _interval_below,
        "{lobe}, N = {n}: `{strategy}` ({pointset}) has the lowest measured RMSE, {rmse} "
        "[{low}, {high}], its interval below that of the next strategy, `{next}` "
        "({next_pointset}, {next_rmse} [{next_low}, {next_high}]).",
        "{lobe}, N = {n}: `{strategy}` ({pointset}) has the lowest measured RMSE, {rmse} "
        "[{low}, {high}], but its interval overlaps that of the next strategy, `{next}` "
        "({next_pointset}, {next_rmse} [{next_low}, {next_high}]): the two are not resolved."),
    "renderer_sources": Condition(
        _any_found,
        "Split off by `split` ({count} bright source(s), integrated exactly): {sources}.",
        "No bright source was found on this map ({scale} scale): `split` is MIS on the whole "
        "map."),
    "renderer_split_helps": Condition(
        _all_below,
        "`split` measures below `mis` in all {n} cells with the same lobe, point set and N "
        "(ratio split/mis {min}–{max}).",
        "`split` does not measure below `mis` in {k} of the {n} cells with the same lobe, "
        "point set and N: {offenders}."),
    "renderer_targets_met": Condition(
        _all_counted,
        "Every measured interval reached ±{target:.0%} ({lo}–{hi} axes).",
        "{k} of {n} cells stopped at max_axes = {max_axes} before their interval reached "
        "±{target:.0%} ({offenders}); their intervals are wider."),
}


def _say_in(table: dict[str, Condition], name: str, args: tuple, **fields) -> str:
    """The sentence of condition ``name`` of ``table`` for ``predicate(*args)``, filled with
    ``fields`` (``""`` when that outcome prints nothing)."""
    c = table[name]
    template = c.when_true if c.predicate(*args) else c.when_false
    return "" if template is None else template.format(**fields)


def _say_renderer(name: str, args: tuple, **fields) -> str:
    """:func:`_say_in` of :data:`RENDERER_CONDITIONS`."""
    return _say_in(RENDERER_CONDITIONS, name, args, **fields)


def _say(name: str, args: tuple, **fields) -> str:
    """The sentence of condition ``name`` for ``predicate(*args)``, filled with ``fields``.

    Returns ``""`` when that outcome prints nothing.

    >>> _say("errors_gaussian", (5.2,), kurtosis=5.2)
    'The per-axis errors are not Gaussian: median kurtosis 5.2, against 3 for a Gaussian field.'
    """
    return _say_in(CONDITIONS, name, args, **fields)


def _join(*parts: str) -> str:
    """The non-empty ``parts`` joined by single spaces."""
    return " ".join(p for p in parts if p)

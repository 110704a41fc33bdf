r"""The judgements of ``report.md``: named thresholds, pure predicates and :class:`Verdict`.

Every statement of the validation report (:mod:`envfit.validate._report`) is one
:class:`Verdict` (built by :mod:`envfit.validate._report_verdicts`): which statement (a name
of :mod:`envfit.validate._report_template`'s tables), the numbers it prints (``values``) and,
for a judgement (a verdict, a trend, a shape of a distribution, a cause), whether its
predicate holds for the numbers printed beside it (``holds``; ``inputs`` are the predicate's
arguments, so ``CONDITIONS[statement](*inputs) == holds``). A fact (what was measured, no
judgement) has ``holds = None``. The predicates are pure functions of numbers, named by
:data:`CONDITIONS` and :data:`RENDERER_CONDITIONS`, their thresholds named constants. So the
text never claims what the data do not show: when a test fails the report prints the
sentence that is true of the numbers instead (e.g. "It does not rise with l (0.17–0.92; …)").

Example
-------
>>> rises_with_degree([0.17, 0.92, 0.4, 0.6]), looks_gaussian(5.2)
(False, False)
>>> v = judge("errors_gaussian", (5.2,), kurtosis=5.2)
>>> v.holds, v.values
(False, {'kurtosis': 5.2})
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from scipy import stats


__all__ = ["Verdict", "CONDITIONS", "RENDERER_CONDITIONS", "judge", "fact"]

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

def spearman(x: list[float], y: list[float]) -> float:
    """Spearman rank correlation of ``x`` and ``y``: ``scipy.stats.spearmanr`` (Pearson's r of
    the average ranks, so ties share a rank); 0 if either is constant (where scipy warns and
    gives NaN); a NaN value gives NaN (no trend is then claimed: NaN ≥ ρ_min is false).

    >>> spearman([1, 2, 3], [0.1, 0.5, 0.4])
    0.5
    """
    if len(set(x)) < 2 or len(set(y)) < 2:
        return 0.0
    return float(stats.spearmanr(x, y).statistic)


def rises_with_degree(ratios: list[float]) -> bool:
    """Whether ``ratios`` (ordered by degree l) rise with l: at least
    :data:`TREND_MIN_POINTS` values, Spearman ρ(ratio, l) ≥ :data:`RISE_MIN_SPEARMAN` and
    last/first ≥ :data:`RISE_MIN_FACTOR`."""
    if len(ratios) < TREND_MIN_POINTS or ratios[0] <= 0:
        return False
    rho = spearman(list(range(len(ratios))), ratios)
    return (rho >= RISE_MIN_SPEARMAN - SPEARMAN_ROUNDING
            and ratios[-1] / ratios[0] >= RISE_MIN_FACTOR)


def looks_gaussian(kurtosis: float) -> bool:
    """|kurtosis − 3| ≤ :data:`GAUSSIAN_MAX_EXCESS_KURTOSIS`."""
    return abs(kurtosis - 3.0) <= GAUSSIAN_MAX_EXCESS_KURTOSIS


def heavy_tailed(kurtosis: float) -> bool:
    """kurtosis − 3 > :data:`HEAVY_MIN_EXCESS_KURTOSIS`."""
    return kurtosis - 3.0 > HEAVY_MIN_EXCESS_KURTOSIS


def all_agree(differences: list[float], tolerance: float) -> bool:
    """Every |difference| ≤ ``tolerance`` (and there is at least one)."""
    return bool(differences) and all(abs(d) <= tolerance for d in differences)


def within_tolerance(value: float | None, tolerance: float) -> bool:
    """``value`` is known and ≤ ``tolerance``."""
    return value is not None and value <= tolerance


def all_counted(within: int | None, checked: int | None) -> bool:
    """``within`` of ``checked`` is all of them (and there is at least one)."""
    return bool(checked) and within == checked


def all_within(fraction: float | None) -> bool:
    """The fraction of cells within the tolerance is 1."""
    return fraction is not None and fraction >= 1.0


def rank_identical(taus: list[float]) -> bool:
    """Every Kendall τ is 1 (to :data:`TAU_ONE`), and there is at least one."""
    return bool(taus) and all(t >= 1.0 - TAU_ONE for t in taus)


def swaps_within_resolution(gap: float, rel_se: float) -> bool:
    """A relative level difference ``gap`` ≤ :data:`RESOLUTION_FACTOR` × ``rel_se``."""
    return gap <= RESOLUTION_FACTOR * rel_se


def band_limit_explains(fixed: int, steeper: int) -> bool:
    """(b') fixes more than :data:`BAND_LIMIT_MAJORITY` of the ``steeper`` slopes."""
    return steeper > 0 and fixed > BAND_LIMIT_MAJORITY * steeper


def prefers_rougher_s(best_s: float, used_s: float) -> bool:
    """The shape fit's best s is smaller (rougher) than the fitted s by more than :data:`S_SAME`."""
    return best_s < used_s - S_SAME


def spectral_agrees(min_ratio: float, max_ratio: float) -> bool:
    """All (c) ratios lie in 1 ± :data:`SPECTRAL_TOLERANCE`."""
    return 1.0 - SPECTRAL_TOLERANCE <= min_ratio and max_ratio <= 1.0 + SPECTRAL_TOLERANCE


def map_departs_from_model(min_ratio: float, max_ratio: float, refined_fraction: float) -> bool:
    """(c) agrees everywhere (:func:`spectral_agrees`) while (b') misses some cells."""
    return spectral_agrees(min_ratio, max_ratio) and not all_within(refined_fraction)


def overpredicts(median_ratio: float) -> bool:
    """Median predicted/measured > :data:`LEVEL_HIGH`."""
    return median_ratio > LEVEL_HIGH


def underpredicts(median_ratio: float) -> bool:
    """Median predicted/measured < :data:`LEVEL_LOW`."""
    return median_ratio < LEVEL_LOW


def level_matches(median_ratio: float) -> bool:
    """:data:`LEVEL_LOW` ≤ median predicted/measured ≤ :data:`LEVEL_HIGH`."""
    return LEVEL_LOW <= median_ratio <= LEVEL_HIGH


def low_degrees_match(low: float) -> bool:
    """|low-degree power ratio − 1| ≤ :data:`LOW_DEGREE_TOLERANCE`."""
    return abs(low - 1.0) <= LOW_DEGREE_TOLERANCE


def display_clips(fraction: float) -> bool:
    """The display transform clips a positive fraction of the sphere."""
    return fraction > 0.0


def fitted_s_is_best(best_s: float, used_s: float) -> bool:
    """The shape fit's best s is the fitted s (to :data:`S_SAME`)."""
    return abs(best_s - used_s) <= S_SAME


def shapes_tie(residual_used: float, residual_best: float) -> bool:
    """The fitted s's residual exceeds the best one's by less than :data:`S_TIE_DEX`."""
    return residual_used - residual_best < S_TIE_DEX


def truncation_exact(residue_fraction: float) -> bool:
    """The residue at L ≥ 1 is ≤ :data:`TRUTH_RESIDUE_FRACTION` of the L = 0 error."""
    return residue_fraction <= TRUTH_RESIDUE_FRACTION


def ratios_in_range(medians: list[float | None]) -> bool:
    """Every median ratio is known and in [:data:`RENDERER_RATIO_LOW`,
    :data:`RENDERER_RATIO_HIGH`] (and there is at least one)."""
    return bool(medians) and all(m is not None and RENDERER_RATIO_LOW <= m <= RENDERER_RATIO_HIGH
                                 for m in medians)


def interval_below(high: float, other_low: float) -> bool:
    """The upper end of one 95 % interval lies below the lower end of the other."""
    return high < other_low


def any_found(count: int) -> bool:
    """At least one."""
    return count > 0


def all_below(pairs: list[tuple[float, float]]) -> bool:
    """Every first value is below its second (and there is at least one pair)."""
    return bool(pairs) and all(a < b for a, b in pairs)


#: Judgement → its predicate; every judgement of the report's validation part is one of these
#: (the sentence each outcome prints: :data:`envfit.validate._report_template.JUDGED`).
CONDITIONS: dict[str, Callable[..., bool]] = {
    "slopes_verdict": all_counted, "refined_slopes_verdict": within_tolerance,
    "rank_verdict": rank_identical, "absolute_verdict": all_within,
    "slopes_agree": all_agree, "band_limit_explains_slopes": band_limit_explains,
    "rougher_than_s": prefers_rougher_s, "rank_identical": rank_identical,
    "swaps_within_resolution": swaps_within_resolution, "absolute_all_within": all_within,
    "spectral_agrees": spectral_agrees, "map_departs_from_model": map_departs_from_model,
    "model_overpredicts": overpredicts, "band_limit_explains_level": level_matches,
    "model_underpredicts": underpredicts, "few_features_explain_level": heavy_tailed,
    "errors_gaussian": looks_gaussian, "heavy_tails": heavy_tailed,
    "display_clips": display_clips, "power_rises": rises_with_degree,
    "low_degrees_match": low_degrees_match, "fitted_s_best": fitted_s_is_best,
    "s_shapes_tie": shapes_tie, "truncation_exact": truncation_exact,
}

#: The judgements of the "Renderer rules" section (``--renderer``).
RENDERER_CONDITIONS: dict[str, Callable[..., bool]] = {
    "renderer_ratios_within": ratios_in_range, "renderer_lobe_agrees": all_within,
    "renderer_lowest_resolved": interval_below, "renderer_sources": any_found,
    "renderer_split_helps": all_below, "renderer_targets_met": all_counted,
}


# ----------------------------------------------------------------------------- verdicts

@dataclass(frozen=True)
class Verdict:
    """One statement of ``report.md``.

    Attributes
    ----------
    statement : str
        Its name (a key of :data:`CONDITIONS` / :data:`RENDERER_CONDITIONS` for a judgement,
        of :data:`envfit.validate._report_template.FACTS` for a fact).
    holds : bool or None
        The predicate's outcome on ``inputs``; None for a fact.
    values : dict
        The numbers (and names) the sentence prints.
    inputs : tuple
        The predicate's arguments.
    section, bullet : str, int
        Where it prints: ``"acceptance"`` (a cell of the acceptance table),
        ``"disagreements"`` or ``"renderer"``; the statements of one bullet print as one
        paragraph.
    """

    statement: str
    holds: bool | None
    values: dict = field(default_factory=dict)
    inputs: tuple = ()
    section: str = ""
    bullet: int = 0

    def to_json(self) -> dict:
        """The JSON-ready dict (``validate.json``'s ``verdicts`` entries)."""
        return {"section": self.section, "bullet": self.bullet, "statement": self.statement,
                "holds": self.holds, "values": self.values, "inputs": list(self.inputs)}


def judge(name: str, inputs: tuple, **values) -> Verdict:
    """The verdict of judgement ``name``: its predicate applied to ``inputs``."""
    table = RENDERER_CONDITIONS if name.startswith("renderer_") else CONDITIONS
    return Verdict(name, bool(table[name](*inputs)), values, tuple(inputs))


def fact(name: str, **values) -> Verdict:
    """A statement without a judgement (``holds`` None)."""
    return Verdict(name, None, values)

r"""The text of ``report.md``'s judgements and tables: every sentence a
:class:`~envfit.validate._report_predicates.Verdict` can print, and the Markdown tables.

A verdict prints :data:`JUDGED`\ ``[statement][0]`` when its predicate holds,
``[1]`` when it fails (``None``: nothing), or :data:`FACTS`\ ``[statement]`` for a fact;
the template is filled with the verdict's ``values`` by :func:`sentence`. Two conventions
of the templates, beyond :meth:`str.format`: a field with the conversion ``!m`` prints "–"
for a missing or non-finite number (and the number itself, unformatted, when the format does
not apply); a list value is joined as :data:`ITEMS` says (one item's template, the
separator). The statements of one bullet are joined by single spaces (:func:`bullets`).

Example
-------
>>> from envfit.validate._report_predicates import judge
>>> sentence(judge("errors_gaussian", (5.2,), kurtosis=5.2))
'The per-axis errors are not Gaussian: median kurtosis 5.2, against 3 for a Gaussian field.'
>>> table(["a", "b"], [[1, 2]])
['| a | b |', '|---|---|', '| 1 | 2 |']
"""
from __future__ import annotations

import math
import string

from envfit.defaults import DEFAULT_SHININESS

from envfit.validate._report_predicates import Verdict
from envfit.validate._report_verdicts import band_limit, brdf_label

__all__ = ["JUDGED", "FACTS", "ITEMS", "sentence", "bullets", "table", "fmt", "agreement_tables",
           "rule_table"]

_RANGE = ("Map dynamic range: peak/mean luminance {peak:.3g}; half of the linear energy lies in "
          "{half:.3g} % of the sphere")
_SPECTRAL = ("(c) spectral, from the map's own power spectrum: ratio {min:.2f} … {max:.2f}, "
             "median {median:.2f} — ")
_LOWEST = ("{lobe}, N = {n}: `{strategy}` ({pointset}) has the lowest measured RMSE, "
           "{rmse!m:.3g} [{low!m:.3g}, {high!m:.3g}]")
_NEXT = "`{next}` ({next_pointset}, {next_rmse!m:.3g} [{next_low!m:.3g}, {next_high!m:.3g}])"


def _yes_no(numbers: str) -> tuple[str, str]:
    """The two cells of an acceptance-table verdict: ``numbers → yes`` / ``numbers → no``."""
    return numbers + " → yes", numbers + " → no"


#: Judgement → (sentence when its predicate holds, sentence when it fails); None: nothing.
JUDGED: dict[str, tuple[str | None, str | None]] = {
    # acceptance table cells: the numbers → yes / no
    "slopes_verdict": _yes_no("{within}/{checked} (max abs difference {difference!m:.3f})"),
    "refined_slopes_verdict": _yes_no("max abs difference {difference!m:.3f}"),
    "rank_verdict": _yes_no("min τ = {tau!m:.3f}"),
    "absolute_verdict": _yes_no("median ratio {median:.2f}, range {min:.2f} … {max:.2f}, "
                                "{fraction:.0%} of {cells} cells within"),
    # slopes
    "slopes_agree": ("All {n} fitted slopes agree within {tol} with the prediction.",
                     "Slopes off by more than {tol}: {offenders}."),
    "band_limit_explains_slopes": (
        "The refined prediction (b′), which counts only the degrees l ≤ {band}, brings {fixed} "
        "of these {steeper} within {tol}: the band limit accounts for most of them.",
        "The refined prediction (b′), which counts only the degrees l ≤ {band}, brings only "
        "{fixed} of these {steeper} within {tol}: the band limit accounts for at most half of them."),
    "rougher_than_s": (
        "The shape fit of {brdf} prefers a rougher s ({best:.2f} < fitted {used:.3f}): the map "
        "is rougher than s says at the scales these N resolve, as an edge or a compact bright "
        "source would make it (more high-frequency power than the fitted l^(-2s) spectrum).",
        "The shape fit of {brdf} does not prefer a rougher s (best s = {best:.2f}, fitted "
        "{used:.3f}), so a uniformly rougher map does not explain them."),
    # rank
    "rank_identical": (
        "The rank order of the point sets is the predicted one for all {n} BRDF/weighting "
        "pairs (Kendall τ = 1).", None),
    "swaps_within_resolution": (
        "The swapped sets differ by at most {gap:.1%} in measured level ({pair}), within "
        "{factor:g}× the statistical resolution ({se:.1%}): noise can swap them.",
        "The swapped sets {pair} differ by {gap:.1%} in measured level, more than {factor:g}× "
        "the statistical resolution ({se:.1%}): the map's spectrum differs from the l^(-2s) "
        "model at the degrees those sets treat differently."),
    # absolute level
    "absolute_all_within": (
        "(b) σ·wce is within {tol:.0%} for every cell with N = {lo}…{hi} (ratio "
        "predicted/measured {min:.2f} … {max:.2f}, median {median:.2f}).",
        "(b) σ·wce is within {tol:.0%} for {fraction:.0%} of the cells with N = {lo}…{hi} "
        "(ratio predicted/measured {min:.2f} … {max:.2f}, median {median:.2f})."),
    "spectral_agrees": (
        _SPECTRAL + "within {band:.0%} everywhere: the error spectra and the measurement agree.",
        _SPECTRAL + "off by more than {band:.0%} somewhere: even the map's own spectrum does not "
        "predict the RMSE exactly (degrees above the grid's band limit under bilinear "
        "interpolation, or a few axes carrying the error, can do this)."),
    "map_departs_from_model": (
        "As (c) agrees and (b′) misses {missed:.0%} of the cells, what (b′) misses is the map "
        "departing from the l^(-2s) model, not the error spectra or the measurement.", None),
    "model_overpredicts": (
        "The measured errors are smaller than σ̂·wce (median ratio {median:.2f} > {high:g}).",
        None),
    "band_limit_explains_level": (
        "(b′), which counts only the degrees l ≤ {band} the map can hold, weighted by the "
        "bilinear lookup's transfer, has median ratio {median:.2f}: the band limit of the "
        "pixel grid and the smoothing of bilinear interpolation near it account for the difference.",
        "(b′), restricted to the degrees l ≤ {band} the map can hold, still has median ratio "
        "{median:.2f}, outside {low:g}…{high:g}: the band limit alone does not account for the "
        "difference."),
    "model_underpredicts": (
        "The measured errors are larger than σ̂·wce (median ratio {median:.2f} < {low:g}).", None),
    "few_features_explain_level": (
        "The per-axis errors are heavy-tailed (median kurtosis {kurtosis:.1f}): σ̂ is fitted to "
        "the map's typical variation, but the errors are dominated by a few features the GP "
        "model cannot describe.",
        "The per-axis errors are not heavy-tailed (median kurtosis {kurtosis:.1f}), so the "
        "excess is not carried by a few features: it points to more power at the degrees that "
        "dominate the quadrature error than σ̂ implies."),
    # distribution of the errors
    "errors_gaussian": (
        "The per-axis errors look Gaussian (median kurtosis {kurtosis:.1f}; 3 for a Gaussian "
        "field), as the GP reading assumes.",
        "The per-axis errors are not Gaussian: median kurtosis {kurtosis:.1f}, against 3 for a "
        "Gaussian field."),
    "heavy_tails": (
        "Tails that heavy mean the squared error is concentrated on a few axes, as when a lobe "
        "sees a small, very bright or sharp feature: such a feature is not a sample of a "
        "stationary Gaussian field, nor a Sobolev-smooth function of modest norm, so the RMSE "
        "over axes reflects it rather than the map's average roughness.", None),
    # the map
    "display_clips": (
        _RANGE + "; the display transform clips {percent:.3g} % of the sphere at 1 (a clipped "
        "sun becomes a flat disc with a sharp edge, whose spectrum decays like an edge's rather "
        "than like the smooth sky's).",
        _RANGE + "; the display transform clips none of the sphere."),
    "power_rises": (
        "It rises with l (from {first:.2f} at l = {l_first} to {last:.2f} at l = {l_last}; "
        "Spearman ρ = {rho:.2f}): the map's spectrum decays more slowly than l^(-2s) at these "
        "degrees, as a compact, very bright source's would (its spectrum is nearly flat), "
        "which the likelihood fit, seeing few samples on it, does not capture in σ̂.",
        "It does not rise with l ({min:.2f}–{max:.2f}; Spearman ρ = {rho:.2f}, last/first "
        "{factor:.2f})."),
    "low_degrees_match": (
        "The lowest {n} degrees hold {low:.2f}× the model's power, within {tol:.0%} of it.",
        "The lowest {n} degrees hold {low:.2f}× the model's power: rules whose error lives "
        "there (random points with equal weights; the diffuse lobe at small N) follow this "
        "map's realised low-degree power rather than σ̂, which would put their "
        "predicted/measured ratio near 1/√{low:.2f} = {inverse:.2f}."),
    # the choice of s
    "fitted_s_best": (
        "{brdf} ({label}): the fitted s = {used:.3f} gives the best shape match among the "
        "candidates ({best_residual!m:.3f} dex).", None),
    "s_shapes_tie": (
        "{brdf} ({label}): the fitted s = {used:.3f} and s = {best:.2f} match the measured "
        "shapes equally well ({used_residual:.3f} vs {best_residual:.3f} dex).",
        "{brdf} ({label}): the predicted shapes match best for s = {best:.2f} (residual "
        "{best_residual:.3f} dex) rather than the fitted s = {used:.3f} ({used_residual:.3f} "
        "dex) — the fit weighs all scales of the map, the quadrature error only those the lobe "
        "and N resolve."),
    # truncation
    "truncation_exact": (
        "Exact for L ≥ 1 (b̃_l = 0 for l ≥ 2): the measured residue at L ≥ 1, {residue:.3g} "
        "({fraction:.2g} of the L = 0 error), is the ground truth's own accuracy.",
        "Exact for L ≥ 1 in theory (b̃_l = 0 for l ≥ 2), yet the measured residue at L ≥ 1 is "
        "{residue:.3g} ({fraction:.2g} of the L = 0 error): more than the ground truth's "
        "accuracy accounts for."),
    # renderer rules (--renderer)
    "renderer_ratios_within": (
        "For every rule ({n}) the median predicted/measured ratio is within {lo:g}–{hi:g} "
        "({min!m:.2f}–{max!m:.2f}).",
        "The median predicted/measured ratio is outside {lo:g}–{hi:g} for {k} of the {n} "
        "rules: {offenders}."),
    "renderer_lobe_agrees": (
        "{lobe}: all {n} cells agree (within {band:.0%} or inside the 95 % interval); median "
        "ratio {median!m:.2f}, worst {worst!m:.2f} ({rule}, N = {worst_n!m:d}).",
        "{lobe}: {agree} of {n} cells agree (within {band:.0%} or inside the 95 % interval); "
        "median ratio {median!m:.2f}, worst {worst!m:.2f} ({rule}, N = {worst_n!m:d})."),
    "renderer_lowest_resolved": (
        _LOWEST + ", its interval below that of the next strategy, " + _NEXT + ".",
        _LOWEST + ", but its interval overlaps that of the next strategy, " + _NEXT
        + ": the two are not resolved."),
    "renderer_sources": (
        "Split off by `split` ({count} bright source(s), integrated exactly): {sources}.",
        "No bright source was found on this map ({scale} scale): `split` is MIS on the whole "
        "map."),
    "renderer_split_helps": (
        "`split` measures below `mis` in all {n} cells with the same lobe, point set and N "
        "(ratio split/mis {min!m:.2f}–{max!m:.2f}).",
        "`split` does not measure below `mis` in {k} of the {n} cells with the same lobe, "
        "point set and N: {offenders}."),
    "renderer_targets_met": (
        "Every measured interval reached ±{target:.0%} ({lo}–{hi} axes).",
        "{k} of {n} cells stopped at max_axes = {max_axes} before their interval reached "
        "±{target:.0%} ({offenders}); their intervals are wider."),
}

#: Fact → its sentence (what was measured; no judgement).
FACTS: dict[str, str] = {
    "resolution": (
        "Statistical resolution: the median relative standard error of a measured RMSE over the "
        "{axes} axes is {se:.1%} (from the spread of the per-axis squared errors; neighbouring "
        "axes are correlated, so treat it as a lower bound). Differences below a few times this "
        "are noise."),
    "slopes_faster": (
        "{steeper} of them converge *faster* than predicted. The theory's wce counts the error "
        "from every degree l, but a {rows}-row map holds none above l ≈ {band}: once N is large "
        "enough that a good point set's error spectrum lives mostly above that degree, the "
        "measured error drops faster than the N^(-s/2)-type rate."),
    "slopes_slower": "{count} converge *slower* than predicted: {rules}.",
    "rank_differs": ("Rank order differs for {brdf}/{weights} (τ = {tau:.2f}): measured "
                     "{measured}, predicted {predicted}."),
    "refined_range": (
        "(b′) refined: {fraction:.0%} within (ratio {min:.2f} … {max:.2f}, median {median:.2f}); "
        "{scatter:.0%} within the tolerance or 2 expected standard deviations of one map's "
        "realisation."),
    "map_range": _RANGE + ".",
    "power_per_degree": (
        "The map's own power per degree against the model's σ̂²·a_l (1 = as the GP model "
        "expects; one map scatters by √(2/((2l+1)C)), ≈ {scatter:.0%} at l = 1): {ratios}."),
    "s_not_candidate": (
        "{brdf} ({label}): the predicted shapes match best for s = {best:.2f} (residual "
        "{best_residual:.3f} dex) among the candidates; the fitted s = {used:.3f} is not among "
        "them."),
    "truncation_range": (
        "Truncation {brdf}/{basis}: σ·wce / measured ranges {min:.2f} … {max:.2f} over L = "
        "{first_L}…{last_L} (shape residual {residual!m:.3f} dex)."),
    "renderer_only_strategy": ("{lobe}, N = {n}: only `{strategy}` was measured ({pointset} "
                               "lowest, {rmse!m:.3g} [{low!m:.3g}, {high!m:.3g}])."),
}

#: (statement, field) → (template of one item, separator) of a list value.
ITEMS: dict[tuple[str, str], tuple[str, str]] = {
    ("slopes_agree", "offenders"): ("{rule} ({difference:+.2f})", ", "),
    ("slopes_slower", "rules"): ("{0}", ", "),
    ("rank_differs", "measured"): ("{0}", " < "),
    ("rank_differs", "predicted"): ("{0}", " < "),
    ("power_per_degree", "ratios"): ("l={l}: {ratio:.2f}", ", "),
    ("renderer_ratios_within", "offenders"): ("{rule} ({ratio!m:.2f})", ", "),
    ("renderer_sources", "sources"): (
        "direction ({x:+.3f}, {y:+.3f}, {z:+.3f}), solid angle {solid_angle:.3g} sr ({pixels} "
        "pixels), {share:.1%} of the map's power", "; "),
    ("renderer_split_helps", "offenders"): ("{lobe} {pointset} N = {n} ({split!m:.3g} vs "
                                            "{mis!m:.3g})", ", "),
    ("renderer_targets_met", "offenders"): ("{rule} N = {n} ±{half_width:.1%}", ", "),
}


# ----------------------------------------------------------------------------- filling

class _Number:
    """A value under ``!m``: "–" when missing or non-finite, else formatted (or as it is when
    the format does not apply)."""

    def __init__(self, value):
        self.value = value

    def __format__(self, spec: str) -> str:
        v = self.value
        if v is None or (isinstance(v, float) and not math.isfinite(v)):
            return "–"
        try:
            return format(v, spec)
        except (TypeError, ValueError):
            return str(v)


class _Formatter(string.Formatter):
    """:meth:`str.format` with the ``!m`` conversion (see the module docstring)."""

    def convert_field(self, value, conversion):
        return _Number(value) if conversion == "m" else super().convert_field(value, conversion)


_FORMATTER = _Formatter()


def fmt(v, spec: str = ".3g") -> str:
    """``format(v, spec)``, or "–" for a missing or non-finite value (``!m`` of a template).

    >>> fmt(None), fmt(float("nan")), fmt(0.12345), fmt(3, "d"), fmt(2.5, "d")
    ('–', '–', '0.123', '3', '2.5')
    """
    return _FORMATTER.format("{0!m:" + spec + "}", v)


def sentence(v: Verdict) -> str:
    """The sentence of verdict ``v`` ("" when its outcome prints nothing)."""
    template = FACTS[v.statement] if v.holds is None else JUDGED[v.statement][0 if v.holds else 1]
    if template is None:
        return ""
    values = dict(v.values)
    for name, value in v.values.items():
        if (v.statement, name) in ITEMS:
            item, sep = ITEMS[(v.statement, name)]
            values[name] = sep.join(_FORMATTER.vformat(item, (x,), x if isinstance(x, dict) else {})
                                    for x in value)
    return _FORMATTER.vformat(template, (), values)


def bullets(verdicts: list[Verdict], section: str) -> list[str]:
    """The bullets of ``section``: per bullet, its non-empty sentences joined by spaces."""
    groups: dict[int, list[str]] = {}
    for v in verdicts:
        if v.section == section:
            groups.setdefault(v.bullet, []).append(sentence(v))
    texts = (" ".join(s for s in g if s) for g in groups.values())
    return [t for t in texts if t]


# ----------------------------------------------------------------------------- tables

def table(header: list[str], rows: list[list]) -> list[str]:
    """Markdown table lines."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(x) for x in r) + " |")
    return out


def _name(r: dict, b: str) -> str:
    """Display name of BRDF ``b`` of result ``r``."""
    return brdf_label(b, r["config"].get("shininess", DEFAULT_SHININESS))


def agreement_tables(r: dict, verdicts: list[Verdict]) -> list[str]:
    """The tables of the "Agreement" section: the acceptance table (its verdict cells from
    ``verdicts``), slopes, rank order, shape fit, absolute predictions, truncation curves."""
    return (_acceptance_table(r, verdicts) + _slopes_table(r) + _rank_table(r)
            + _shape_fit_table(r) + _absolute_tables(r) + _truncation_tables(r))


def _acceptance_table(r: dict, verdicts: list[Verdict]) -> list[str]:
    """The check/result table; every verdict cell is a verdict's sentence."""
    agr = r.get("agreement", {})
    acc, ab = agr.get("acceptance", {}), agr.get("absolute", {})
    if not acc:
        return []
    cell = {(v.statement, v.values.get("prediction")): sentence(v)
            for v in verdicts if v.section == "acceptance"}
    lo, hi = agr.get("slope_range", [64, 4096])
    scatter = (ab.get("slope_range_refined") or {}).get("fraction_within_expected_scatter")
    rows = [
        [f"slopes of sf/random within {acc.get('slope_tolerance', 0.1)} (N = {lo}…{hi})",
         cell[("slopes_verdict", None)]],
        ["same, against the refined prediction (b′)", cell[("refined_slopes_verdict", None)]],
        ["rank order of the point sets identical (Kendall τ = 1)", cell[("rank_verdict", None)]],
        [f"(b) σ·wce within {ab.get('tolerance', 0.2):.0%} of the measured "
         f"RMSE at every N in {lo}…{hi}", cell.get(("absolute_verdict", "slope_range"), "–")],
        ["(b′) refined, same check", cell.get(("absolute_verdict", "slope_range_refined"), "–")],
        ["(b′) within the tolerance or 2 expected standard deviations (one map's realisation + "
         "the axes' Monte Carlo error)", fmt(scatter, ".0%")],
        ["(c) spectral (the map's own power spectrum; checks the machinery)",
         cell.get(("absolute_verdict", "slope_range_spectral"), "–")],
    ]
    return table(["check", "result"], rows) + [""]


def _slopes_table(r: dict) -> list[str]:
    """Measured and predicted convergence slopes per rule."""
    agr = r.get("agreement", {})
    if not agr.get("slopes"):
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    rows = [[_name(r, s["brdf"]), s["pointset"], s["weights"], fmt(s["measured"], ".3f"),
             fmt(s["predicted"], ".3f"), fmt(s["difference"], "+.3f"),
             fmt(s.get("predicted_refined"), ".3f"), fmt(s.get("difference_refined"), "+.3f")]
            for s in agr["slopes"]]
    return ([f"### Convergence slopes (least squares in log-log, N = {lo}…{hi})", ""]
            + table(["BRDF", "point set", "weights", "measured", "predicted", "Δ",
                     "predicted (b′)", "Δ (b′)"], rows) + [""])


def _rank_table(r: dict) -> list[str]:
    """Measured and predicted rank order of the point sets."""
    agr = r.get("agreement", {})
    if not agr.get("rank"):
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    rows = [[_name(r, k["brdf"]), k["weights"], " < ".join(k["measured_order"]),
             " < ".join(k["predicted_order"]), fmt(k["kendall_tau"], ".3f")] for k in agr["rank"]]
    return ([f"### Rank order of the point sets (geometric mean over N = {lo}…{hi}; best first)", ""]
            + table(["BRDF", "weights", "measured", "predicted", "Kendall τ"], rows) + [""])


def _shape_fit_rows(r: dict, s_keys: list[str]) -> list[list]:
    """Rows of the shape-fit table: per BRDF the wce and the band-limited wce residuals."""
    agr = r.get("agreement", {})
    sf, choice = agr.get("shape_fit", {}), agr.get("s_choice", {})
    rows = []
    for b, c in sf["constant"].items():
        ch = choice.get(b, {})
        for suffix, label in (("", "wce"), ("_bandlimited", f"wce, l ≤ {band_limit(r)}")):
            res = ch.get("residual_by_s" + suffix)
            if not res:
                continue
            row = [_name(r, b), label, fmt(c, ".4g") if not suffix else "",
                   fmt(sf["residual_dex"].get(b), ".3f") if not suffix else ""]
            row += [fmt(res.get(k, {}).get("residual_dex"), ".3f") for k in s_keys]
            rows.append(row + [fmt(ch.get("best_s" + suffix), ".2f")])
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
            + table(header, _shape_fit_rows(r, s_keys))
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
        rows.append([e["pointset"]] + [f"{fmt(x, '.2f')} / {fmt(y, '.2f')} ±{fmt(d, '.2f')} / "
                                       f"{fmt(z, '.2f')}"
                                       for x, y, d, z in zip(e["predicted_over_measured"],
                                                             eb["predicted_over_measured"], sd,
                                                             ec["predicted_over_measured"])])
    return ([f"**{_name(r, b)}, {w}** (cells: (b) / (b′) ± sd / (c))", ""]
            + table(["point set"] + [f"N={n}" for n in ns], rows) + [""])


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
        rows.append([L, fmt(m), fmt(shape[i]), fmt(pb), fmt(ratio, ".2f"),
                     fmt(tcur["qmc_equivalent_n"][i], "d"), fmt(meas_n[i], ".0f")])
    return rows


def _truncation_tables(r: dict) -> list[str]:
    """The truncation curves (Fig. 8), one table per BRDF and basis."""
    if not r.get("truncation"):
        return []
    out = ["### Truncation (Fig. 8)", "",
           "Measured RMSE, predictions (a) c·wce (c of the quadrature fit of the same BRDF) and "
           "(b) σ·wce, and the QMC-equivalent N (morphed spherical Fibonacci, equal weights): "
           "theory (`envfit.theory.equivalent_qmc_points` on the predicted wce) and "
           "measured (where the measured SF/equal RMSE curve reaches the measured truncation RMSE).",
           ""]
    for tcur in r["truncation"]:
        out += [f"**{_name(r, tcur['brdf'])}, {tcur['basis'].upper()}** "
                f"({tcur['axes']} axes, {tcur['map_height']} rows)", ""]
        out += table(["L", "measured", "(a) c·wce", "(b) σ·wce", "(b)/measured",
                      "equiv. N (theory)", "equiv. N (measured)"], _truncation_rows(tcur)) + [""]
    return out


def rule_table(rd: dict) -> list[str]:
    """The renderer rules: per rule, median ratio, cells that agree, worst ratio (at N)."""
    rows = [[f"{x['lobe']} {x['strategy']}/{x['pointset']}", fmt(x["median_ratio"], ".2f"),
             f"{x['fraction_agree']:.0%}", f"{fmt(x['worst_ratio'], '.2f')} (N = "
             f"{fmt(x['worst_n'], 'd')})"] for x in rd["rules"]]
    return table(["rule", "median predicted/measured", "cells that agree", "worst ratio"], rows)

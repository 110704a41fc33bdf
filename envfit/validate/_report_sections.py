"""The descriptive sections and the agreement tables of ``report.md``.

One function per part of the report :func:`envfit.validate._report.render_report` assembles:
"What was run" (:func:`_what_was_run`), the predictions (a), (b), (b′), (c)
(:func:`_predictions_explained`), the figures (:func:`_figures_section`) and the "Agreement"
section (:func:`_agreement_section`: the acceptance table, slopes, rank order, shape fit,
absolute predictions and truncation curves). Each takes the JSON-ready result dict and returns
Markdown lines; every verdict comes from
:data:`envfit.validate._report_conditions.CONDITIONS`.

Example
-------
>>> _figures_section({"errors": "/tmp/out/errors.png"})
['## Figures', '', '![errors](errors.png)', '']
"""
from __future__ import annotations

from pathlib import Path

from envfit.validate._report_conditions import _say
from envfit.validate._report_format import _band, _brdf_name, _f, _table


# ----------------------------------------------------------------------------- what was run

def _what_was_run(r: dict) -> list[str]:
    """The "What was run" list: map, smoothness, scale, axes, quadrature, extras."""
    cfg, fit = r.get("config", {}), r.get("fit", {})
    size = r.get("map_size", ["?", "?"])
    out = ["## What was run", "",
           f"- **Map**: `{r['map']}`, {size[0]}x{size[1]}, {r.get('channels', '?')} channel(s); "
           f"value scale **{r['scale']}** ({r.get('scale_description', '')}). The integrand is "
           "the bilinear interpolant of the scaled pixels; the ground truth is its exact "
           "shading integral (`envfit.shading._ground_truth`, SH of the bilinear interpolant)."]
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



def _abs_summary(ab: dict, key: str) -> str:
    """The acceptance-table cell of one absolute prediction (``ab[key]``)."""
    d = ab.get(key)
    if not d:
        return "–"
    return (f"median ratio {d['median_ratio']:.2f}, range {d['min_ratio']:.2f} … {d['max_ratio']:.2f}, "
            f"{d['fraction_within']:.0%} of {d['cells']} cells within → "
            + _say("absolute_verdict", (d["fraction_within"],)))


def _acceptance_table(r: dict) -> list[str]:
    """The check/result table; every verdict from :data:`~.report_conditions.CONDITIONS`."""
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
           "theory (`envfit.theory._truncation.equivalent_qmc_points` on the predicted wce) and measured "
           "(where the measured SF/equal RMSE curve reaches the measured truncation RMSE).", ""]
    for tcur in r["truncation"]:
        out += [f"**{_brdf_name(r, tcur['brdf'])}, {tcur['basis'].upper()}** "
                f"({tcur['axes']} axes, {tcur['map_height']} rows)", ""]
        out += _table(["L", "measured", "(a) c·wce", "(b) σ·wce", "(b)/measured",
                       "equiv. N (theory)", "equiv. N (measured)"], _truncation_rows(tcur)) + [""]
    return out

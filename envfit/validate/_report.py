r"""``report.md``: a short validation report written from the result of ``envfit validate``.

:func:`render_report` turns the JSON-ready dict of :func:`envfit.validate._pipeline.run_validation`
(or the JSON file it was saved to) into Markdown: what was run, the figures, the agreement
numbers (slopes, rank order, the shape fit (a) and the choice of s, the absolute
predictions (b) and (b'), the truncation curves), a "what disagrees and why" section and,
with ``--renderer``, a "Renderer rules" section. :func:`write_report` writes it atomically.

Three parts, one concern each: :mod:`~envfit.validate._report_predicates` (named thresholds
and pure predicates), :mod:`~envfit.validate._report_verdicts` (:func:`report_verdicts`:
every statement of the report as a :class:`~envfit.validate._report_predicates.Verdict` —
which statement, its numbers, whether its predicate holds — the list ``validate.json``
carries as ``verdicts``) and :mod:`~envfit.validate._report_template` (the sentence of each
verdict and the tables). Every sentence that states a judgement (a verdict, a trend, a shape
of a distribution, a cause) is a verdict whose predicate was applied to numbers printed in
the same report: when a test fails the report prints the sentence that is true of the
numbers instead (e.g. "It does not rise with l (0.17–0.92; …)"). This module adds the
descriptive parts (what was run, what the predictions are, the figures) and assembles the
sections.

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
"""
from __future__ import annotations

from pathlib import Path

from envfit.base import atomic_write_text
from envfit.defaults import DEFAULT_SHININESS

from envfit.validate._report_predicates import Verdict
from envfit.validate._report_template import agreement_tables, bullets, fmt, rule_table
from envfit.validate._report_verdicts import band_limit, brdf_label, report_verdicts

__all__ = ["render_report", "write_report", "report_verdicts"]


def render_report(result: dict, figures: dict[str, str] | None = None) -> str:
    """Markdown text of the validation report for ``result`` (see the module docstring).

    Parameters
    ----------
    result : dict
        The JSON-ready dict of :func:`envfit.validate._pipeline.run_validation` (its
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
    verdicts = report_verdicts(result)
    lines = [f"# Validation of predicted shading-integral errors: {result['map']}", ""]
    lines += _what_was_run(result)
    lines += _predictions_explained(result)
    lines += _figures_section(figures)
    lines += ["## Agreement", ""] + agreement_tables(result, verdicts)
    lines += (["## What disagrees and why", ""]
              + [f"- {x}" for x in bullets(verdicts, "disagreements")] + [""])
    lines += renderer_section(result.get("renderer"), verdicts)
    return "\n".join(lines)


def write_report(result: dict, path: str | Path, figures: dict[str, str] | None = None) -> Path:
    """Write :func:`render_report` to ``path`` atomically.

    Parameters
    ----------
    result : dict
        What :func:`envfit.validate._pipeline.run_validation` returns.
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


def _name(r: dict, b: str) -> str:
    """Display name of BRDF ``b`` of result ``r``."""
    return brdf_label(b, r["config"].get("shininess", DEFAULT_SHININESS))


# ----------------------------------------------------------------------------- what was run

def _what_was_run(r: dict) -> list[str]:
    """The "What was run" list: map, smoothness, scale, axes, quadrature, extras."""
    cfg, fit = r.get("config", {}), r.get("fit", {})
    size = r.get("map_size", ["?", "?"])
    out = ["## What was run", "",
           f"- **Map**: `{r['map']}`, {size[0]}x{size[1]}, {r.get('channels', '?')} channel(s); "
           f"value scale **{r['scale']}** ({r.get('scale_description', '')}). The integrand is "
           "the bilinear interpolant of the scaled pixels; the ground truth is its exact "
           "shading integral (`envfit.shading.shading_integral`, SH of the bilinear interpolant)."]
    if fit.get("source") == "fit":
        iv = fit.get("s_interval") or [None, None]
        out.append(f"- **Smoothness**: s = {r['s']:.3f} fitted by `envfit fit --method "
                   f"{fit.get('method', 'likelihood')}` from {fit.get('n')} samples "
                   f"(95 % interval {fmt(iv[0], '.3f')} … {fmt(iv[1], '.3f')}).")
    else:
        out.append(f"- **Smoothness**: s = {r['s']:.3f} given; σ̂ from the profiled likelihood "
                   f"at that s ({fit.get('n')} spherical Fibonacci samples).")
    out.append(f"- **Scale of the GP model**: σ̂ = {r['sigma']:.4g} (channels: "
               + ", ".join(f"{x:.4g}" for x in r.get("sigma_channels", [])) + "; combined as RMS).")
    out.append(f"- **Axes**: M = {r['axes']} uniform random axes (seed {r.get('seed', 0)}); each "
               "point set is morphed for the BRDF (importance sampling, Sec. 7.2) and rotated "
               "into every axis' frame with an independent random twist.")
    out.append(f"- **Quadrature** (Fig. 7): BRDFs {', '.join(_name(r, b) for b in cfg.get('brdfs', []))}; "
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
        f"(σ̂′²·Σ_{{l≤{band_limit(r)}}} a_l(ŝ′) τ_l e_l + (Σw − 1)²·m̄²)^½ — the error spectrum "
        "(Eq. 42) summed only over the degrees the map can hold, each weighted by the "
        "bilinear lookup's transfer τ_l (the interpolant's power over the pixel values' "
        f"power, measured on the map{_transfer_numbers(r)}), plus the "
        "error a rule whose weights do not sum to 1 (OSW) makes on the map's mean (the GP "
        "model is zero-mean; the fit removes the mean); ŝ′ and σ̂′ come from the likelihood "
        "of the same band-limited model (kernel truncated at the band limit, samples at "
        f"pixel centres): ŝ′ = {fmt(r.get('s_refined'), '.3f')}, σ̂′ = "
        f"{fmt(r.get('sigma_refined'), '.4g')} (the paper's fit: ŝ = {fmt(r.get('s'), '.3f')}). "
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


# ----------------------------------------------------------------------------- renderer rules

def renderer_section(rd: dict | None, verdicts: list[Verdict]) -> list[str]:
    """The "Renderer rules" section (``--renderer``): what was run, the per-rule table and the
    renderer verdicts' bullets; nothing when the run had no ``renderer`` part."""
    if not rd:
        return []
    return (["## Renderer rules (`--renderer`)", ""] + _renderer_run(rd) + [""]
            + rule_table(rd) + [""] + [f"- {x}" for x in bullets(verdicts, "renderer")] + [""])


def _measured_axes(config: dict) -> str:
    """How the measurement drew its axes, from the configuration (older runs: uniform)."""
    if config.get("axis_sampling", "uniform") == "importance":
        return ("the RMSE over uniform axes, estimated on axes importance-sampled from the "
                "map's axis proposal (each axis's squared error weighted by u/q, at most 3)")
    return "the RMSE over uniform random axes"


def _renderer_run(rd: dict) -> list[str]:
    """What was run (no judgement)."""
    c = rd["config"]
    t = rd.get("timings", {})
    lobes = ", ".join(brdf_label(b, c.get("shininess", DEFAULT_SHININESS)) for b in c["lobes"])
    return [
        f"Strategies {', '.join(c['strategies'])} with point sets {', '.join(c['pointsets'])} "
        f"at N = {', '.join(str(n) for n in c['n_values'])}, lobes "
        f"{lobes}, on the {rd['scale']} scale "
        f"({rd['map_size'][0]}x{rd['map_size'][1]}). Predicted: the warped-integrand spectra "
        f"(grid {c['grid']}, {c['spectrum_axes']} axes; `random` points: the Monte Carlo "
        f"variance). Measured: {_measured_axes(c)} with its BCa bootstrap 95 % "
        f"interval, from {c['axes_start']} axes doubling to at most {c['max_axes']} until the "
        f"interval is within ±{c['target_relative']:.0%}. A cell agrees when the ratio "
        f"predicted/measured is within {c['band']:.0%} of 1 or the prediction lies inside the "
        f"interval. Seconds: spectra {fmt(t.get('spectra'), '.1f')}, measurements "
        f"{fmt(t.get('measure'), '.1f')}, in all {fmt(t.get('total'), '.1f')} "
        f"({rd.get('resumed_cells', 0)} cell(s) resumed)."]

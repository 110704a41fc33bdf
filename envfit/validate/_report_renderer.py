"""The "Renderer rules" section of ``report.md`` (``envfit validate --renderer``).

:func:`_renderer_section` reads the ``renderer`` part of the result
(:meth:`envfit.validate._renderer.RendererValidation.to_json`) and prints what was run, the
per-rule table and statements on the median ratios, the agreement per lobe, the strategy
with the lowest measured RMSE at each N, what was split off, whether split beats MIS and
whether every interval reached its target. Every judgement is chosen by a condition of
:data:`envfit.validate._report_conditions.RENDERER_CONDITIONS` (through
:func:`~envfit.validate._report_conditions._say_renderer`).

Example
-------
>>> _renderer_section({})
[]
"""
from __future__ import annotations

from envfit.defaults import DEFAULT_SHININESS
from envfit.validate._report_conditions import RENDERER_RATIO_HIGH, RENDERER_RATIO_LOW
from envfit.validate._report_conditions import _say_renderer as _say
from envfit.validate._report_format import _f, _table

__all__: list[str] = []


def _lobe_name(rd: dict, lobe: str) -> str:
    shin = rd.get("config", {}).get("shininess", DEFAULT_SHININESS)
    return f"glossy (n = {shin:g})" if lobe == "glossy" else lobe


def _rule_name(x: dict) -> str:
    return f"{x['lobe']} {x['strategy']}/{x['pointset']}"


def _renderer_section(r: dict) -> list[str]:
    """The section, or nothing when the run had no ``renderer`` part."""
    rd = r.get("renderer")
    if not rd:
        return []
    statements = [_ratio_statement(rd), *_lobe_statements(rd), *_lowest_statements(rd),
                  _source_statement(rd), _split_statement(rd), _target_statement(rd)]
    return (["## Renderer rules (`--renderer`)", ""] + _renderer_run(rd) + [""]
            + _rule_table(rd) + [""] + [f"- {x}" for x in statements if x] + [""])


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
    return [
        f"Strategies {', '.join(c['strategies'])} with point sets {', '.join(c['pointsets'])} "
        f"at N = {', '.join(str(n) for n in c['n_values'])}, lobes "
        f"{', '.join(_lobe_name(rd, b) for b in c['lobes'])}, on the {rd['scale']} scale "
        f"({rd['map_size'][0]}x{rd['map_size'][1]}). Predicted: the warped-integrand spectra "
        f"(grid {c['grid']}, {c['spectrum_axes']} axes; `random` points: the Monte Carlo "
        f"variance). Measured: {_measured_axes(c)} with its BCa bootstrap 95 % "
        f"interval, from {c['axes_start']} axes doubling to at most {c['max_axes']} until the "
        f"interval is within ±{c['target_relative']:.0%}. A cell agrees when the ratio "
        f"predicted/measured is within {c['band']:.0%} of 1 or the prediction lies inside the "
        f"interval. Seconds: spectra {_f(t.get('spectra'), '.1f')}, measurements "
        f"{_f(t.get('measure'), '.1f')}, in all {_f(t.get('total'), '.1f')} "
        f"({rd.get('resumed_cells', 0)} cell(s) resumed)."]


def _rule_table(rd: dict) -> list[str]:
    """Per rule: median ratio, cells that agree, worst ratio (at N) — numbers only."""
    rows = [[_rule_name(x), _f(x["median_ratio"], ".2f"), f"{x['fraction_agree']:.0%}",
             f"{_f(x['worst_ratio'], '.2f')} (N = {_f(x['worst_n'], 'd')})"] for x in rd["rules"]]
    return _table(["rule", "median predicted/measured", "cells that agree", "worst ratio"], rows)


def _ratio_statement(rd: dict) -> str:
    """Whether every rule's median ratio is within 0.9–1.1, else which rules are not."""
    meds = [x["median_ratio"] for x in rd["rules"]]
    bad = [x for x in rd["rules"] if x["median_ratio"] is None
           or not RENDERER_RATIO_LOW <= x["median_ratio"] <= RENDERER_RATIO_HIGH]
    known = [m for m in meds if m is not None]
    return _say("renderer_ratios_within", (meds,), n=len(meds), lo=RENDERER_RATIO_LOW,
                hi=RENDERER_RATIO_HIGH, min=_f(min(known, default=None), ".2f"),
                max=_f(max(known, default=None), ".2f"), k=len(bad),
                offenders=", ".join(f"{_rule_name(x)} ({_f(x['median_ratio'], '.2f')})"
                                    for x in bad))


def _lobe_statements(rd: dict) -> list[str]:
    """Per lobe: whether all its cells agree; median and worst ratio."""
    band = rd["config"]["band"]
    return [_say("renderer_lobe_agrees", (x["fraction_agree"],), lobe=_lobe_name(rd, x["lobe"]),
                 n=x["cells"], agree=round(x["fraction_agree"] * x["cells"]), band=band,
                 median=_f(x["median_ratio"], ".2f"), worst=_f(x["worst_ratio"], ".2f"),
                 rule=x["worst_rule"], worst_n=_f(x["worst_n"], "d")) for x in rd["lobes"]]


def _lowest_statements(rd: dict) -> list[str]:
    """Per lobe and N: the strategy with the lowest measured RMSE, resolved from the next one
    or not."""
    out = []
    for x in rd["lobes"]:
        for e in x["lowest_by_n"]:
            b, nxt = e["lowest"], e["runner_up"]
            fields = dict(lobe=_lobe_name(rd, x["lobe"]), n=e["n"], strategy=b["strategy"],
                          pointset=b["pointset"], rmse=_f(b["measured_rmse"], ".3g"),
                          low=_f(b["measured_low"], ".3g"), high=_f(b["measured_high"], ".3g"))
            if nxt is None:                 # one strategy: nothing to compare (a fact)
                out.append("{lobe}, N = {n}: only `{strategy}` was measured ({pointset} lowest, "
                           "{rmse} [{low}, {high}]).".format(**fields))
                continue
            out.append(_say("renderer_lowest_resolved", (b["measured_high"], nxt["measured_low"]),
                            next=nxt["strategy"], next_pointset=nxt["pointset"],
                            next_rmse=_f(nxt["measured_rmse"], ".3g"),
                            next_low=_f(nxt["measured_low"], ".3g"),
                            next_high=_f(nxt["measured_high"], ".3g"), **fields))
    return out


def _source_statement(rd: dict) -> str:
    """What was split off (direction, solid angle, share of the power), or that nothing was."""
    src = rd.get("sources", [])
    desc = "; ".join(
        f"direction ({', '.join(f'{v:+.3f}' for v in s['direction'])}), solid angle "
        f"{s['solid_angle']:.3g} sr ({s['pixels']} pixels), {s['share']:.1%} of the map's power"
        for s in src)
    return _say("renderer_sources", (len(src),), count=len(src), sources=desc, scale=rd["scale"])


def _split_statement(rd: dict) -> str:
    """Whether ``split`` measures below ``mis`` in every comparable cell (both measured)."""
    cells = {(c["lobe"], c["strategy"], c["pointset"], c["n"]): c for c in rd["cells"]}
    pairs = [(c, cells[(c["lobe"], "mis", c["pointset"], c["n"])]) for c in rd["cells"]
             if c["strategy"] == "split" and (c["lobe"], "mis", c["pointset"], c["n"]) in cells]
    if not pairs:
        return ""
    vals = [(s["measured_rmse"], m["measured_rmse"]) for s, m in pairs]
    ratios = [a / b for a, b in vals if b > 0]
    bad = [s for s, m in pairs if not s["measured_rmse"] < m["measured_rmse"]]
    return _say("renderer_split_helps", (vals,), n=len(pairs), k=len(bad),
                min=_f(min(ratios, default=None), ".2f"), max=_f(max(ratios, default=None), ".2f"),
                offenders=", ".join(f"{s['lobe']} {s['pointset']} N = {s['n']} "
                                    f"({_f(s['measured_rmse'], '.3g')} vs "
                                    f"{_f(m['measured_rmse'], '.3g')})"
                                    for s, m in pairs if s in bad))


def _target_statement(rd: dict) -> str:
    """Whether every adaptive measurement reached its target half-width."""
    cells, c = rd["cells"], rd["config"]
    if not cells:
        return ""
    short = [x for x in cells if not x["target_met"]]
    axes = [x["axes"] for x in cells]
    return _say("renderer_targets_met", (len(cells) - len(short), len(cells)),
                target=c["target_relative"], lo=min(axes), hi=max(axes), k=len(short),
                n=len(cells), max_axes=c["max_axes"],
                offenders=", ".join(f"{_rule_name(x)} N = {x['n']} "
                                    f"±{x['relative_half_width']:.1%}" for x in short))

r"""The verdicts of a validation result: every statement ``report.md`` makes, as data.

:func:`report_verdicts` reads the JSON-ready result of
:func:`envfit.validate._pipeline.run_validation` and returns one
:class:`~envfit.validate._report_predicates.Verdict` per statement, in print order: the
acceptance table's verdicts, the "What disagrees and why" statements (the resolution, the
slopes, the rank order, the absolute level, the distribution of the errors, the map, the
choice of s, the truncation curves) and, with ``--renderer``, the renderer rules'
(:func:`renderer_verdicts`). Each judgement is a predicate of
:mod:`envfit.validate._report_predicates` applied to numbers the same statement prints; the
sentences are :mod:`envfit.validate._report_template`'s. ``validate.json`` carries the list
(``verdicts``).

Example
-------
>>> [(v.statement, v.holds) for v in report_verdicts({"results": [{"error_kurtosis": [3.2]}]})]
[('errors_gaussian', True), ('heavy_tails', False)]
"""
from __future__ import annotations

import math
from dataclasses import replace

from envfit.base import s_key
from envfit.defaults import DEFAULT_SHININESS

from envfit.validate._report_predicates import (LEVEL_HIGH, LEVEL_LOW, LOW_DEGREE_TOLERANCE,
                                                LOW_DEGREES, RENDERER_RATIO_HIGH,
                                                RENDERER_RATIO_LOW, RESOLUTION_FACTOR,
                                                SPECTRAL_TOLERANCE, TREND_MIN_POINTS, Verdict,
                                                fact, judge, rank_identical, spearman)

__all__ = ["report_verdicts", "renderer_verdicts", "band_limit", "brdf_label", "median"]


def report_verdicts(r: dict) -> list[Verdict]:
    """Every statement of the report of result ``r``, in print order (see the module
    docstring); an object with ``to_json`` is converted."""
    if hasattr(r, "to_json"):
        r = r.to_json()
    se = median_of(r, "measured_rel_se")
    kurt = median_of(r, "error_kurtosis")
    bullets = [] if se is None else [[fact("resolution", axes=r.get("axes"), se=se)]]
    bullets += (_slopes(r) + _ranks(r, se) + _absolute(r, kurt) + _kurtosis(kurt) + _map(r)
                + _s_choice(r) + _truncation(r))
    return (_placed("acceptance", _acceptance(r)) + _placed("disagreements", bullets)
            + renderer_verdicts(r.get("renderer")))


def _placed(section: str, bullets: list[list[Verdict]]) -> list[Verdict]:
    """The verdicts of ``bullets`` with their section and bullet number."""
    return [replace(v, section=section, bullet=i) for i, b in enumerate(bullets) for v in b]


# ----------------------------------------------------------------------------- shared numbers

def brdf_label(name: str, shininess: float) -> str:
    """Display name of a BRDF / lobe (the glossy one with its shininess).

    >>> brdf_label("glossy", 30.0), brdf_label("diffuse", 30.0)
    ('glossy (n = 30)', 'diffuse')
    """
    return f"glossy (n = {shininess:g})" if name == "glossy" else name


def band_limit(r: dict):
    """The band limit (highest degree) of the map, from the first cell that has it."""
    for e in r.get("results", []):
        if e.get("band_lmax") is not None:
            return e["band_lmax"]
    return "H − 1"


def median(xs):
    """Median of the finite values of ``xs`` (``None`` if there are none).

    >>> median([3.0, None, 1.0, float("nan"), 2.0, 4.0])
    2.5
    """
    xs = sorted(x for x in xs if x is not None and math.isfinite(x))
    if not xs:
        return None
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def median_of(r: dict, key: str):
    """Median over every cell of ``results`` of the list ``key``."""
    return median([x for e in r.get("results", []) for x in (e.get(key) or [])])


# ----------------------------------------------------------------------------- acceptance

def _acceptance(r: dict) -> list[list[Verdict]]:
    """The verdicts of the acceptance table (each a cell; ``absolute_verdict`` once per
    prediction, its ``values["prediction"]`` the key of ``agreement["absolute"]``)."""
    agr = r.get("agreement", {})
    acc, ab = agr.get("acceptance", {}), agr.get("absolute", {})
    if not acc:
        return []
    tol = acc.get("slope_tolerance", 0.1)
    within, checked = acc.get("slopes_within"), acc.get("slopes_checked")
    d_ref, tau = acc.get("max_abs_slope_difference_refined"), acc.get("min_kendall_tau")
    out = [judge("slopes_verdict", (within, checked), within=within, checked=checked,
                 difference=acc.get("max_abs_slope_difference")),
           judge("refined_slopes_verdict", (d_ref, tol), difference=d_ref),
           judge("rank_verdict", ([] if tau is None else [tau],), tau=tau)]
    for key in ("slope_range", "slope_range_refined", "slope_range_spectral"):
        d = ab.get(key)
        if d:
            out.append(judge("absolute_verdict", (d["fraction_within"],), prediction=key,
                             median=d["median_ratio"], min=d["min_ratio"], max=d["max_ratio"],
                             fraction=d["fraction_within"], cells=d["cells"]))
    return [[v] for v in out]


# ----------------------------------------------------------------------------- what disagrees

def _rule(s: dict) -> str:
    """``brdf/pointset/weights`` of a slope entry."""
    return f"{s['brdf']}/{s['pointset']}/{s['weights']}"


def _slopes(r: dict) -> list[list[Verdict]]:
    """Slopes against the prediction; the faster and the slower ones and what explains them."""
    agr = r.get("agreement", {})
    tol = agr.get("acceptance", {}).get("slope_tolerance", 0.1)
    slopes = [s for s in agr.get("slopes", []) if s["difference"] is not None]
    if not slopes:
        return []
    bad = [s for s in slopes if abs(s["difference"]) > tol]
    out = [[judge("slopes_agree", ([s["difference"] for s in slopes], tol), n=len(slopes), tol=tol,
                  offenders=[{"rule": _rule(s), "difference": s["difference"]} for s in bad])]]
    steeper = [s for s in bad if s["difference"] < 0]
    if steeper:
        fixed = sum(1 for s in steeper if s.get("difference_refined") is not None
                    and abs(s["difference_refined"]) <= tol)
        band = band_limit(r)
        out.append([fact("slopes_faster", steeper=len(steeper), rows=r["map_size"][1], band=band),
                    judge("band_limit_explains_slopes", (fixed, len(steeper)), band=band,
                          fixed=fixed, steeper=len(steeper), tol=tol)])
    shallower = [s for s in bad if s["difference"] > 0]
    if shallower:
        choice = agr.get("s_choice", {})
        bullet = [fact("slopes_slower", count=len(shallower), rules=[_rule(s) for s in shallower])]
        for b in dict.fromkeys(s["brdf"] for s in shallower):
            best, used = choice.get(b, {}).get("best_s"), choice.get(b, {}).get("used_s")
            if best is not None and used is not None:
                bullet.append(judge("rougher_than_s", (best, used), brdf=b, best=best, used=used))
        out.append(bullet)
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


def _ranks(r: dict, se: float | None) -> list[list[Verdict]]:
    """Rank order identical, or per differing order whether the swap is within the noise."""
    ranks = [k for k in r.get("agreement", {}).get("rank", []) if k["kendall_tau"] is not None]
    if not ranks:
        return []
    out = [[judge("rank_identical", ([k["kendall_tau"] for k in ranks],), n=len(ranks))]]
    for k in ranks:
        if rank_identical([k["kendall_tau"]]):
            continue
        bullet = [fact("rank_differs", brdf=k["brdf"], weights=k["weights"], tau=k["kendall_tau"],
                       measured=k["measured_order"], predicted=k["predicted_order"])]
        gap = _swapped_gap(k)
        if gap is not None and se is not None:
            bullet.append(judge("swaps_within_resolution", (gap[0], se), gap=gap[0], pair=gap[1],
                                factor=RESOLUTION_FACTOR, se=se))
        out.append(bullet)
    return out


def _ratios(d: dict) -> dict:
    """The range of the ratios predicted/measured of one absolute prediction."""
    return {"min": d["min_ratio"], "max": d["max_ratio"], "median": d["median_ratio"]}


def _absolute(r: dict, kurt: float | None) -> list[list[Verdict]]:
    """(b), (b′) and (c) over the slope range, and what explains a level off by a factor."""
    agr = r.get("agreement", {})
    ab = agr.get("absolute", {})
    d, db, dc = ab.get("slope_range"), ab.get("slope_range_refined"), ab.get("slope_range_spectral")
    if not d:
        return []
    lo, hi = agr.get("slope_range", [64, 4096])
    out = [[judge("absolute_all_within", (d["fraction_within"],), tol=ab.get("tolerance", 0.2),
                  fraction=d["fraction_within"], lo=lo, hi=hi, **_ratios(d))]]
    if db:
        out.append([fact("refined_range", fraction=db["fraction_within"], **_ratios(db),
                         scatter=db.get("fraction_within_expected_scatter", 0))])
    if dc:
        out.append([judge("spectral_agrees", (dc["min_ratio"], dc["max_ratio"]), **_ratios(dc),
                          band=SPECTRAL_TOLERANCE)])
        if db:
            out.append([judge("map_departs_from_model",
                              (dc["min_ratio"], dc["max_ratio"], db["fraction_within"]),
                              missed=1.0 - db["fraction_within"])])
    m = d["median_ratio"]
    over = judge("model_overpredicts", (m,), median=m, high=LEVEL_HIGH)
    under = judge("model_underpredicts", (m,), median=m, low=LEVEL_LOW)
    out += [[over], [under]]
    if over.holds and db:
        out.append([judge("band_limit_explains_level", (db["median_ratio"],), band=band_limit(r),
                          median=db["median_ratio"], low=LEVEL_LOW, high=LEVEL_HIGH)])
    if under.holds and kurt is not None:
        out.append([judge("few_features_explain_level", (kurt,), kurtosis=kurt)])
    return out


def _kurtosis(kurt: float | None) -> list[list[Verdict]]:
    """Whether the per-axis errors look Gaussian, and what heavy tails mean."""
    if kurt is None:
        return []
    return [[judge("errors_gaussian", (kurt,), kurtosis=kurt), judge("heavy_tails", (kurt,))]]


def _map(r: dict) -> list[list[Verdict]]:
    """The map's dynamic range and clipping, and its power per degree against the model."""
    st = r.get("map_stats", {}) or {}
    out = []
    if st.get("peak_over_mean") is not None:
        rng = {"peak": st["peak_over_mean"],
               "half": 100 * (st.get("solid_angle_fraction_half_energy") or 0)}
        clipped = st.get("display_clipped_fraction")
        out.append([fact("map_range", **rng) if clipped is None else
                    judge("display_clips", (clipped,), percent=100 * clipped, **rng)])
    pr = st.get("power_ratio_low_degrees") or {}
    if pr:
        out.append(_power_ratio(pr, r.get("channels", 1)))
    return out


def _power_ratio(pr: dict, channels: int) -> list[Verdict]:
    """The power ratio per degree; whether it rises with l; the lowest degrees' level."""
    ls = sorted(pr, key=int)
    rho = [pr[k] for k in ls]
    out = [fact("power_per_degree", scatter=math.sqrt(2 / (3 * max(1, channels))),
                ratios=[{"l": k, "ratio": pr[k]} for k in ls])]
    if len(rho) >= TREND_MIN_POINTS:
        out.append(judge("power_rises", (rho,), first=rho[0], last=rho[-1], l_first=ls[0],
                         l_last=ls[-1], rho=spearman(list(range(len(rho))), rho), min=min(rho),
                         max=max(rho), factor=rho[-1] / rho[0] if rho[0] > 0 else float("inf")))
    n = min(LOW_DEGREES, len(rho))
    low = sum(rho[:n]) / n
    out.append(judge("low_degrees_match", (low,), n=n, low=low, tol=LOW_DEGREE_TOLERANCE,
                     inverse=1 / math.sqrt(low) if low > 0 else float("inf")))
    return out


def _s_choice_one(b: str, label: str, used: float, best: float, res: dict) -> list[Verdict]:
    """Whether the fitted s gives the best shape match for one BRDF and wce variant; if not,
    whether its shapes tie with the best s's."""
    rb = res.get(s_key(best), {}).get("residual_dex")
    ru = res.get(s_key(used), {}).get("residual_dex")
    best_fit = judge("fitted_s_best", (best, used), brdf=b, label=label, used=used, best=best,
                     best_residual=rb)
    if best_fit.holds or rb is None:
        return [best_fit]
    if ru is None:
        return [best_fit, fact("s_not_candidate", brdf=b, label=label, used=used, best=best,
                               best_residual=rb)]
    return [best_fit, judge("s_shapes_tie", (ru, rb), brdf=b, label=label, used=used, best=best,
                            used_residual=ru, best_residual=rb)]


def _s_choice(r: dict) -> list[list[Verdict]]:
    """The choice of s per BRDF, for the wce and the band-limited wce."""
    out = []
    for b, v in r.get("agreement", {}).get("s_choice", {}).items():
        for suffix, label in (("", "wce"), ("_bandlimited", "band-limited wce")):
            best, used = v.get("best_s" + suffix), v.get("used_s")
            if best is not None and used is not None:
                out.append(_s_choice_one(b, label, used, best, v.get("residual_by_s" + suffix) or {}))
    return out


def _exact_truncation(r: dict, t: dict) -> list[Verdict]:
    """For diffuse HSH (exact from L = 1): whether the residue is the ground truth's accuracy."""
    cur = next((c for c in r.get("truncation", []) if c["brdf"] == t["brdf"]
                and c["basis"] == t["basis"]), None)
    meas = [] if cur is None else cur.get("measured_rmse") or []
    rest = [m for L, m in zip(t["L"], meas) if L >= 1 and m is not None]
    if not rest or not meas or not meas[0]:
        return []
    residue = max(rest)
    return [judge("truncation_exact", (residue / meas[0],), residue=residue,
                  fraction=residue / meas[0])]


def _truncation(r: dict) -> list[list[Verdict]]:
    """The range of σ·wce / measured over L for every truncation curve."""
    out = []
    for t in r.get("agreement", {}).get("truncation", []):
        ratios = [x for x in t.get("predicted_over_measured", []) if x is not None]
        if not ratios:
            continue
        bullet = [fact("truncation_range", brdf=t["brdf"], basis=t["basis"].upper(),
                       min=min(ratios), max=max(ratios), first_L=t["L"][0], last_L=t["L"][-1],
                       residual=t.get("shape_residual_dex"))]
        if t["brdf"] == "diffuse" and t["basis"] == "hsh":
            bullet += _exact_truncation(r, t)
        out.append(bullet)
    return out


# ----------------------------------------------------------------------------- renderer rules

def renderer_verdicts(rd: dict | None) -> list[Verdict]:
    """The statements of the "Renderer rules" section (``--renderer``; none without it): the
    median ratios, the agreement per lobe, the strategy with the lowest measured RMSE at each
    N, what was split off, whether split beats MIS and whether every interval reached its
    target."""
    if not rd:
        return []
    bullets = [_renderer_ratios(rd), *([v] for v in _renderer_lobes(rd)),
               *([v] for v in _renderer_lowest(rd)), _renderer_sources(rd), _renderer_split(rd),
               _renderer_targets(rd)]
    return _placed("renderer", [b for b in bullets if b])


def _rule_name(x: dict) -> str:
    return f"{x['lobe']} {x['strategy']}/{x['pointset']}"


def _lobe(rd: dict, lobe: str) -> str:
    return brdf_label(lobe, rd.get("config", {}).get("shininess", DEFAULT_SHININESS))


def _renderer_ratios(rd: dict) -> list[Verdict]:
    """Whether every rule's median ratio is within 0.9–1.1, else which rules are not."""
    meds = [x["median_ratio"] for x in rd["rules"]]
    bad = [x for x in rd["rules"] if x["median_ratio"] is None
           or not RENDERER_RATIO_LOW <= x["median_ratio"] <= RENDERER_RATIO_HIGH]
    known = [m for m in meds if m is not None]
    return [judge("renderer_ratios_within", (meds,), n=len(meds), lo=RENDERER_RATIO_LOW,
                  hi=RENDERER_RATIO_HIGH, min=min(known, default=None),
                  max=max(known, default=None), k=len(bad),
                  offenders=[{"rule": _rule_name(x), "ratio": x["median_ratio"]} for x in bad])]


def _renderer_lobes(rd: dict) -> list[Verdict]:
    """Per lobe: whether all its cells agree; median and worst ratio."""
    band = rd["config"]["band"]
    return [judge("renderer_lobe_agrees", (x["fraction_agree"],), lobe=_lobe(rd, x["lobe"]),
                  n=x["cells"], agree=round(x["fraction_agree"] * x["cells"]), band=band,
                  median=x["median_ratio"], worst=x["worst_ratio"], rule=x["worst_rule"],
                  worst_n=x["worst_n"]) for x in rd["lobes"]]


def _renderer_lowest(rd: dict) -> list[Verdict]:
    """Per lobe and N: the strategy with the lowest measured RMSE, resolved from the next one
    or not (a fact when only one strategy was measured)."""
    out = []
    for x in rd["lobes"]:
        for e in x["lowest_by_n"]:
            b, nxt = e["lowest"], e["runner_up"]
            values = dict(lobe=_lobe(rd, x["lobe"]), n=e["n"], strategy=b["strategy"],
                          pointset=b["pointset"], rmse=b["measured_rmse"],
                          low=b["measured_low"], high=b["measured_high"])
            if nxt is None:
                out.append(fact("renderer_only_strategy", **values))
                continue
            out.append(judge("renderer_lowest_resolved", (b["measured_high"], nxt["measured_low"]),
                             next=nxt["strategy"], next_pointset=nxt["pointset"],
                             next_rmse=nxt["measured_rmse"], next_low=nxt["measured_low"],
                             next_high=nxt["measured_high"], **values))
    return out


def _renderer_sources(rd: dict) -> list[Verdict]:
    """What was split off (direction, solid angle, share of the power), or that nothing was."""
    src = rd.get("sources", [])
    sources = [{"x": s["direction"][0], "y": s["direction"][1], "z": s["direction"][2],
                "solid_angle": s["solid_angle"], "pixels": s["pixels"], "share": s["share"]}
               for s in src]
    return [judge("renderer_sources", (len(src),), count=len(src), sources=sources,
                  scale=rd["scale"])]


def _renderer_split(rd: dict) -> list[Verdict]:
    """Whether ``split`` measures below ``mis`` in every comparable cell (both measured)."""
    cells = {(c["lobe"], c["strategy"], c["pointset"], c["n"]): c for c in rd["cells"]}
    pairs = [(c, cells[(c["lobe"], "mis", c["pointset"], c["n"])]) for c in rd["cells"]
             if c["strategy"] == "split" and (c["lobe"], "mis", c["pointset"], c["n"]) in cells]
    if not pairs:
        return []
    vals = [(s["measured_rmse"], m["measured_rmse"]) for s, m in pairs]
    ratios = [a / b for a, b in vals if b > 0]
    bad = [(s, m) for s, m in pairs if not s["measured_rmse"] < m["measured_rmse"]]
    return [judge("renderer_split_helps", (vals,), n=len(pairs), k=len(bad),
                  min=min(ratios, default=None), max=max(ratios, default=None),
                  offenders=[{"lobe": s["lobe"], "pointset": s["pointset"], "n": s["n"],
                              "split": s["measured_rmse"], "mis": m["measured_rmse"]}
                             for s, m in bad])]


def _renderer_targets(rd: dict) -> list[Verdict]:
    """Whether every adaptive measurement reached its target half-width."""
    cells, c = rd["cells"], rd["config"]
    if not cells:
        return []
    short = [x for x in cells if not x["target_met"]]
    axes = [x["axes"] for x in cells]
    return [judge("renderer_targets_met", (len(cells) - len(short), len(cells)),
                  target=c["target_relative"], lo=min(axes), hi=max(axes), k=len(short),
                  n=len(cells), max_axes=c["max_axes"],
                  offenders=[{"rule": _rule_name(x), "n": x["n"],
                              "half_width": x["relative_half_width"]} for x in short])]

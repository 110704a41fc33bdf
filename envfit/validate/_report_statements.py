"""The "What disagrees and why" section of ``report.md``.

:func:`_disagreements_section` lists statements about the resolution, the slopes, the rank
order, the absolute level, the distribution of the errors, the map, the choice of s and the
truncation curves; every judgement in them is chosen by a condition of
:data:`envfit.validate._report_conditions.CONDITIONS` (through
:func:`~envfit.validate._report_conditions._say`).

Example
-------
>>> _kurtosis_statements(3.2)
['The per-axis errors look Gaussian (median kurtosis 3.2; 3 for a Gaussian field), as the GP reading assumes.']
"""
from __future__ import annotations

import math

from envfit.base._keys import s_key

from envfit.validate._report_conditions import (LEVEL_HIGH, LEVEL_LOW, LOW_DEGREE_TOLERANCE,
                                                LOW_DEGREES, RESOLUTION_FACTOR, SPECTRAL_TOLERANCE,
                                                TREND_MIN_POINTS, _fitted_s_is_best, _join,
                                                _overpredicts, _rank_identical, _say, _spearman,
                                                _underpredicts)
from envfit.validate._report_format import _band, _f, _median_of


# ----------------------------------------------------------------------------- what disagrees

def _disagreements_section(r: dict) -> list[str]:
    """The "What disagrees and why" section."""
    return ["## What disagrees and why", ""] + [f"- {x}" for x in _disagreements(r)] + [""]


def _disagreements(r: dict) -> list[str]:
    """Statements of the "what disagrees and why" section, each chosen by
    :data:`~.report_conditions.CONDITIONS`."""
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
    rb = res.get(s_key(best), {}).get("residual_dex")
    ru = res.get(s_key(used), {}).get("residual_dex")
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

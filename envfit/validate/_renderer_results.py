r"""What ``envfit validate --renderer`` returns and prints: the cells (:class:`RendererCell`,
one lobe × strategy × point set × N, predicted against measured), their summaries per rule
(:func:`summarize_rules`) and per lobe (:func:`summarize_lobes`), the whole section
(:class:`RendererValidation`, the ``renderer`` JSON section) and its compact table
(:func:`summary_lines`). Computed by :func:`envfit.validate._renderer.run_renderer_validation`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Sequence

__all__ = ["RendererCell", "RendererRuleSummary", "RendererLobeSummary", "RendererValidation",
           "summarize_rules", "summarize_lobes", "worst_ratio", "summary_lines"]


@dataclass
class RendererCell:
    """One lobe × strategy × point set × N: predicted and measured RMSE, their agreement.

    ``measured_low``/``measured_high`` the 95 % interval, ``axes`` how many were measured,
    ``target_met`` whether the interval reached ±``target_relative``; ``ratio`` =
    predicted/measured (None if undefined); ``within_band``, ``inside_interval``, ``agrees``
    (either) as :class:`envfit.measure._adaptive_rmse.Agreement`; ``settings``
    (:meth:`envfit.validate._renderer.RendererValidationConfig.cell_settings`); seconds of
    the prediction and the measurement; ``resumed`` whether it was read from the store; ``axis_sampling`` how its
    axes were drawn ("importance" or "uniform"; records older than the field: "uniform").
    """

    lobe: str
    strategy: str
    pointset: str
    n: int
    predictor: str
    predicted_rmse: float
    measured_rmse: float
    measured_low: float
    measured_high: float
    relative_half_width: float
    axes: int
    target_met: bool
    interval_method: str
    ratio: float | None
    within_band: bool
    inside_interval: bool
    agrees: bool
    settings: dict
    seconds_predict: float = 0.0
    seconds_measure: float = 0.0
    resumed: bool = False
    axis_sampling: str = "uniform"

    @property
    def rule_label(self) -> str:
        """``strategy/pointset``."""
        return f"{self.strategy}/{self.pointset}"

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_json(cls, d: dict) -> "RendererCell":
        return cls(**{f.name: d[f.name] for f in fields(cls) if f.name in d})


@dataclass
class RendererRuleSummary:
    """One lobe × strategy × point set over its N: median ratio, fraction of cells that
    agree, the worst ratio (farthest from 1 in log) and the N where it occurs."""

    lobe: str
    strategy: str
    pointset: str
    cells: int
    median_ratio: float | None
    fraction_agree: float
    worst_ratio: float | None
    worst_n: int | None

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class RendererLobeSummary:
    """All cells of one lobe: median ratio, fraction that agree, worst ratio and its rule;
    ``lowest_by_n``: per N the strategy with the lowest measured RMSE (at its best point set)
    and the runner-up strategy (None when only one strategy was measured)."""

    lobe: str
    cells: int
    median_ratio: float | None
    fraction_agree: float
    worst_ratio: float | None
    worst_rule: str | None
    worst_n: int | None
    lowest_by_n: list[dict] = field(default_factory=list)

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class RendererValidation:
    """What :func:`envfit.validate._renderer.run_renderer_validation` returns; ``to_json()``
    is the ``renderer`` section of ``envfit validate``'s JSON, :meth:`from_json` reads it
    back."""

    map: str
    map_size: list[int]
    scale: str
    config: dict
    sources: list[dict]
    cells: list[RendererCell]
    rules: list[RendererRuleSummary]
    lobes: list[RendererLobeSummary]
    timings: dict
    resumed_cells: int = 0

    def to_json(self) -> dict:
        return {"map": self.map, "map_size": list(self.map_size), "scale": self.scale,
                "config": self.config, "sources": self.sources,
                "cells": [c.to_json() for c in self.cells],
                "rules": [r.to_json() for r in self.rules],
                "lobes": [x.to_json() for x in self.lobes], "timings": self.timings,
                "resumed_cells": self.resumed_cells}

    @classmethod
    def from_json(cls, d: dict) -> "RendererValidation":
        return cls(map=d["map"], map_size=list(d["map_size"]), scale=d["scale"],
                   config=d["config"], sources=d["sources"],
                   cells=[RendererCell.from_json(c) for c in d["cells"]],
                   rules=[RendererRuleSummary(**r) for r in d["rules"]],
                   lobes=[RendererLobeSummary(**x) for x in d["lobes"]], timings=d["timings"],
                   resumed_cells=int(d.get("resumed_cells", 0)))

    def cell(self, lobe: str, strategy: str, pointset: str, n: int) -> RendererCell:
        """The cell of one rule and N; KeyError if none."""
        for c in self.cells:
            if (c.lobe, c.strategy, c.pointset, c.n) == (lobe, strategy, pointset, int(n)):
                return c
        raise KeyError(f"no renderer cell {lobe}/{strategy}/{pointset}/{n}")


# ----------------------------------------------------------------------------- summaries

def _median(xs: list[float]) -> float | None:
    xs = sorted(x for x in xs if x is not None)
    if not xs:
        return None
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def worst_ratio(cells: Sequence[RendererCell]) -> RendererCell | None:
    """The cell whose ratio is farthest from 1 in log (a ratio of 0 is the farthest; cells
    without a ratio are skipped).

    >>> cs = [RendererCell("diffuse", "map", "sf", n, "warped-spectrum", r, 1.0, 0.9, 1.1, 0.1,
    ...                    100, True, "bca", r, True, True, True, {}) for n, r in ((16, 1.3), (64, 0.7))]
    >>> worst_ratio(cs).n
    64
    """
    ok = [c for c in cells if c.ratio is not None]
    if not ok:
        return None
    return max(ok, key=lambda c: math.inf if c.ratio <= 0 else abs(math.log(c.ratio)))


def summarize_rules(cells: Sequence[RendererCell]) -> list[RendererRuleSummary]:
    """One :class:`RendererRuleSummary` per lobe × strategy × point set, in the cells' order."""
    groups: dict[tuple, list[RendererCell]] = {}
    for c in cells:
        groups.setdefault((c.lobe, c.strategy, c.pointset), []).append(c)
    out = []
    for (lobe, strategy, pointset), cs in groups.items():
        w = worst_ratio(cs)
        out.append(RendererRuleSummary(
            lobe, strategy, pointset, len(cs), _median([c.ratio for c in cs]),
            sum(c.agrees for c in cs) / len(cs), None if w is None else w.ratio,
            None if w is None else w.n))
    return out


def _lowest_by_n(cells: Sequence[RendererCell]) -> list[dict]:
    """Per N: the strategy with the lowest measured RMSE (its best point set) and the runner-up."""
    out = []
    for n in sorted({c.n for c in cells}):
        best: dict[str, RendererCell] = {}
        for c in cells:
            if c.n == n and (c.strategy not in best or c.measured_rmse < best[c.strategy].measured_rmse):
                best[c.strategy] = c
        ranked = sorted(best.values(), key=lambda c: c.measured_rmse)
        out.append({"n": n, "lowest": _lowest_entry(ranked[0]),
                    "runner_up": _lowest_entry(ranked[1] if len(ranked) > 1 else None)})
    return out


def _lowest_entry(c: RendererCell | None) -> dict | None:
    return None if c is None else {
        "strategy": c.strategy, "pointset": c.pointset, "measured_rmse": c.measured_rmse,
        "measured_low": c.measured_low, "measured_high": c.measured_high}


def summarize_lobes(cells: Sequence[RendererCell]) -> list[RendererLobeSummary]:
    """One :class:`RendererLobeSummary` per lobe, in the cells' order."""
    out = []
    for lobe in dict.fromkeys(c.lobe for c in cells):
        cs = [c for c in cells if c.lobe == lobe]
        w = worst_ratio(cs)
        out.append(RendererLobeSummary(
            lobe, len(cs), _median([c.ratio for c in cs]), sum(c.agrees for c in cs) / len(cs),
            None if w is None else w.ratio, None if w is None else w.rule_label,
            None if w is None else w.n, _lowest_by_n(cs)))
    return out


# ----------------------------------------------------------------------------- printing

def _g(v, fmt=".4g"):
    return "–" if v is None else format(v, fmt)


def summary_lines(renderer: dict) -> list[str]:
    """The compact table (rule, N, predicted, measured [low, high], ratio, agrees) and the
    per-rule summary of a ``renderer`` JSON section, as printed by ``envfit validate``."""
    lines = [f"renderer rules on {renderer['map']} ({renderer['scale']} scale): predicted vs "
             "measured RMSE (95 % interval)",
             f"  {'rule':22s} {'N':>5s} {'predicted':>10s} {'measured [low, high]':>32s} "
             f"{'ratio':>6s} agrees"]
    for c in renderer["cells"]:
        rule = f"{c['lobe']} {c['strategy']}/{c['pointset']}"
        meas = f"{_g(c['measured_rmse'])} [{_g(c['measured_low'])}, {_g(c['measured_high'])}]"
        flag = "yes" if c["agrees"] else "NO"
        if not c["target_met"]:
            flag += " (interval > target)"
        lines.append(f"  {rule:22s} {c['n']:5d} {_g(c['predicted_rmse']):>10s} {meas:>32s} "
                     f"{_g(c['ratio'], '.2f'):>6s} {flag}")
    lines.append("per rule: median ratio, cells that agree, worst ratio (at N)")
    for r in renderer["rules"]:
        lines.append(f"  {r['lobe'] + ' ' + r['strategy'] + '/' + r['pointset']:22s} "
                     f"{_g(r['median_ratio'], '.2f'):>6s} {r['fraction_agree']:5.0%} "
                     f"{_g(r['worst_ratio'], '.2f'):>6s} (N = {_g(r['worst_n'], 'd')})")
    for s in renderer["sources"]:
        d = ", ".join(f"{x:+.2f}" for x in s["direction"])
        lines.append(f"split off: source at ({d}), {s['solid_angle']:.3g} sr, "
                     f"{s['share']:.0%} of the power")
    return lines

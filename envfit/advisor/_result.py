r"""What the advisor answers: :class:`Advice`, its rows (:class:`AdviceRow`, one rule each),
their order, the recommended row and the recommendation line.

A row is reached when the search found an N (quadrature) or an L (SH/HSH truncation) whose
prediction — by the row's ``predictor``, (b′) "bandlimited" or (c) "spectral"
(:mod:`envfit.advisor._choice`) — is at most the target; its cost is N samples per shading
point, or (L+1)² coefficients. The rows are sorted by cost, unreached rows last
(:func:`sort_rows`); the recommendation is the first reached row that is recommendable
(:meth:`Advice.best`).

Example
-------
>>> rows = sort_rows([AdviceRow("sh", L=3, cost=16, predicted_rmse=0.01),
...                   AdviceRow("quadrature", "sf", "equal", n=40, cost=40, predicted_rmse=0.02),
...                   AdviceRow("hsh", searched_max=64, predicted_rmse=0.3, recommendable=False)])
>>> [(r.label, r.setting) for r in rows]
[('SH', 'L = 3'), ('sf/equal', 'N = 40'), ('HSH', 'L > 64')]
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

__all__ = ["Advice", "AdviceRow", "sort_rows", "recommendation_text"]


@dataclass
class AdviceRow:
    """One rule of the table.

    ``method`` is "quadrature" (``pointset``/``weights``, ``n`` samples) or "sh"/"hsh" (degree
    ``L``). ``cost`` = N or (L+1)²; None when the target is not reached (then ``n``/``L`` are
    None and ``predicted_rmse`` is the prediction at the largest N/L searched, ``searched_max``).
    ``predicted_rmse`` is the refined prediction (b') (``wce_bandlimited`` = E', with τ for
    quadrature and SH), ``predicted_rmse_spectral`` prediction (c) with its tail (the map's
    own power per degree to ``spectral_lmax`` = 2H − 1 times the rule's error power;
    ``predicted_rmse_spectral_band`` the same summed to H − 1, ``envfit validate``'s (c);
    None for HSH), both at the chosen N/L; ``predictor`` names the one that chose N/L
    ("bandlimited" or "spectral", :attr:`predicted`), ``spectral_ratio`` is (c)/(b′) at the
    chosen N/L and ``warning`` the line printed when they disagree
    (:mod:`envfit.advisor._choice`). ``predicted_rmse_plain`` is σ'·wce (Eq. 41) or σ'·E(L)
    (Eqs. 51–52) without the band limit and τ, at the band-limited fit's s' and σ'.
    ``measured_rmse`` and ``measured_over_predicted`` (over :attr:`predicted`) are filled by
    ``check=True``.
    """

    method: str
    pointset: str | None = None
    weights: str | None = None
    n: int | None = None
    L: int | None = None
    cost: int | None = None
    predicted_rmse: float | None = None
    predicted_rmse_plain: float | None = None
    predictor: str = "bandlimited"
    predicted_rmse_spectral: float | None = None
    predicted_rmse_spectral_band: float | None = None
    spectral_lmax: int | None = None
    spectral_ratio: float | None = None
    warning: str = ""
    wce_bandlimited: float | None = None
    wce: float | None = None
    weight_sum: float | None = None
    realisations: int = 1
    searched_max: int | None = None
    evaluations: int = 0
    recommendable: bool = True
    note: str = ""
    measured_rmse: float | None = None
    measured_over_predicted: float | None = None
    measured_over_target: float | None = None
    check_note: str = ""

    @property
    def predicted(self) -> float | None:
        """The prediction of the row's ``predictor``: (c) for "spectral", else (b′)."""
        return self.predicted_rmse_spectral if self.predictor == "spectral" else \
            self.predicted_rmse

    @property
    def predictor_short(self) -> str:
        """"(c)" or "(b')": the table's ``pred`` column."""
        return "(c)" if self.predictor == "spectral" else "(b')"

    @property
    def reached(self) -> bool:
        """Whether the target is reached in the searched range (a cost is known)."""
        return self.cost is not None

    @property
    def label(self) -> str:
        """"pointset/weights" for quadrature, "SH" or "HSH" for a truncation."""
        if self.method == "quadrature":
            return f"{self.pointset}/{self.weights}"
        return self.method.upper()

    @property
    def setting(self) -> str:
        """"N = …" / "L = …", or "N > max" / "L > max" when not reached."""
        if self.method == "quadrature":
            return f"N = {self.n}" if self.n is not None else f"N > {self.searched_max}"
        return f"L = {self.L}" if self.L is not None else f"L > {self.searched_max}"


@dataclass
class Advice:
    """What :func:`envfit.advisor._advise.advise` found: the map's fit, the target, and the rows sorted by cost.

    ``s``, ``sigma`` are the band-limited fit's s' and σ' (``fit_kernel`` "bandlimited",
    kernel truncated at degree ``fit_band_lmax`` = H − 1, ``fit_samples`` distinct pixel
    centres); ``lookup_transfer`` is τ_l, l = 0…H − 1; ``map_power`` the mean over channels
    of the interpolant's realised power per degree :math:`\\hat P_l`, l = 0…``spectral_lmax``
    (prediction (c)); ``warnings`` the rows' disagreement lines; ``renderer`` the renderer
    rows (:class:`envfit.advisor._rule_rows.RuleRowsAdvice`) or None.
    """

    map: str
    map_size: list[int]
    channels: int
    brdf: str
    shininess: float | None
    scale: str
    scale_description: str
    target_rmse: float
    target_relative: float | None
    mean_shading: float
    s: float
    s_interval: list[float] | None
    sigma: float
    sigma_channels: list[float]
    fit_source: str
    fit_cached: bool
    fit_kernel: str
    fit_band_lmax: int | None
    fit_samples: int | None
    band_lmax: int
    mean_rms: float
    rows: list[AdviceRow]
    recommendation: str
    settings: dict = field(default_factory=dict)
    cache: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    check: dict | None = None
    lookup_transfer: list[float] = field(default_factory=list)
    spectral_lmax: int | None = None
    map_power: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    renderer: object = None

    def __post_init__(self) -> None:
        """A reached row predicted 0 (or not finite) is never recommended: on a map that is
        not constant (the advisor refuses constant ones) 0 only says that the rule errs
        nowhere in the degrees the prediction holds (SH at L ≥ H − 1 for (b′), ≥ 2H − 1 for
        (c)), not that it is exact. Such rows get a note and a warning line."""
        for r in self.rows:
            p = r.predicted
            if r.reached and r.recommendable and not (p is not None and math.isfinite(p)
                                                      and p > 0.0):
                r.recommendable = False
                why = (f"predicted {p!r} by {r.predictor_short}: no error within the degrees "
                       f"that prediction holds, not an exact rule; not recommended")
                r.note = "; ".join(x for x in (r.note, why) if x)
                self.warnings.append(f"rule {r.label}: {why}")

    def to_dict(self) -> dict:
        """Every field, the rows with their ``reached``, ``label`` and ``predicted_rmse_used``
        (the prediction of their ``predictor``; what ``--json`` writes), and the renderer
        section (:meth:`envfit.advisor._rule_rows.RuleRowsAdvice.to_dict`; None without it)."""
        ren, self.renderer = self.renderer, None
        try:
            d = asdict(self)
        finally:
            self.renderer = ren
        d["rows"] = [{**asdict(r), "reached": r.reached, "label": r.label,
                      "predicted_rmse_used": r.predicted} for r in self.rows]
        d["renderer"] = None if ren is None else ren.to_dict()
        return d

    def _repr_html_(self) -> str:
        """Jupyter: the fit, the target, the rows sorted by cost and the recommendation."""
        from envfit.base import html_result
        w, h = self.map_size[:2]
        return html_result(f"Advice: {self.map} ({w}x{h}), {self.brdf}", [
            ("target RMSE", self.target_rmse), ("s, sigma", (self.s, self.sigma)),
            ("scale", self.scale), ("recommendation", self.recommendation)],
            (["rule", "N / L", "cost", "pred", "predicted RMSE", "measured RMSE"],
             [[r.label, r.setting, r.cost, r.predictor_short, r.predicted, r.measured_rmse]
              for r in self.rows]))

    def best(self) -> AdviceRow | None:
        """The recommended row (cheapest reached, recommendable), or None."""
        ok = [r for r in self.rows if r.reached and r.recommendable]
        return ok[0] if ok else None

    def table_lines(self) -> list[str]:
        """The table as text lines (what the CLI prints)."""
        chk = self.check is not None
        bp = "(b')"
        head = (f"  {'rule':<14s} {'N / L':>10s} {'cost':>7s} {'pred':>4s} {bp:>10s} "
                f"{'(c)':>10s} {'sigma*wce':>10s}")
        if chk:
            head += f" {'measured':>10s} {'meas/pred':>9s} {'meas/target':>11s}"
        lines = [head + "  note"]

        def f(v, w=10):
            return f"{'–':>{w}s}" if v is None else f"{v:>{w}.3e}"

        def g(v, w):
            return f"{'–':>{w}s}" if v is None else f"{v:>{w}.2f}"

        for r in self.rows:
            line = (f"  {r.label:<14s} {r.setting:>10s} "
                    f"{('–' if r.cost is None else str(r.cost)):>7s} {r.predictor_short:>4s} "
                    f"{f(r.predicted_rmse)} {f(r.predicted_rmse_spectral)} "
                    f"{f(r.predicted_rmse_plain)}")
            if chk:
                line += (f" {f(r.measured_rmse)} {g(r.measured_over_predicted, 9)} "
                         f"{g(r.measured_over_target, 11)}")
            notes = "; ".join(x for x in (r.note, r.check_note) if x)
            lines.append(line + (f"  {notes}" if notes else ""))
        return lines


def recommendation_text(adv: Advice) -> str:
    """The recommendation line: the cheapest reached, recommendable row of ``adv`` (and the
    cheapest quadrature rule beside a truncation), or what to raise when none is reached."""
    best = adv.best()
    if best is None:
        return (f"no rule reaches the target RMSE {adv.target_rmse:.3g} in the searched range: "
                f"raise --nmax / --osw-nmax or relax the target")
    what = {"quadrature": f"{best.label} (point set / weights) with N = {best.n} samples per "
                          f"shading point",
            "sh": f"SH truncation at L = {best.L} ({best.cost} coefficients)",
            "hsh": f"HSH truncation at L = {best.L} ({best.cost} coefficients)"}[best.method]
    text = (f"recommendation: {what} (predicted RMSE {best.predicted:.3g} by "
            f"{best.predictor_short} <= target {adv.target_rmse:.3g})")
    if best.method != "quadrature":
        q = next((r for r in adv.rows if r.method == "quadrature" and r.reached
                  and r.recommendable), None)
        if q is not None:
            text += f"; by sampling: {q.pointset}/{q.weights} N = {q.n}"
    return text


def sort_rows(rows: list[AdviceRow]) -> list[AdviceRow]:
    """The rows by cost (reached first), then the prediction used, then label."""
    return sorted(rows, key=lambda r: (r.cost is None, r.cost if r.cost is not None else 0,
                                       r.predicted if r.predicted is not None
                                       else math.inf, r.label))

r"""``envfit sh``'s whole result: the exported coefficients, their predicted (and measured)
error and negativity, the ringing table over degrees and windows, and the choice for a target
(:func:`sh_report` with :class:`SHReportOptions`, :class:`SHReport`); its documents (JSON,
CSV, GLSL: :func:`document`), its files for ``--out`` (:func:`sh_outputs`) and the preview
images of ``sh.png`` (:func:`preview_images`).

The map is first put on its value scale (``linear``: radiance as is; ``display``: the
display-referred values of :mod:`envfit.maps._scales`); then the exact local coefficients
of its bilinear interpolant are computed once to :math:`L_P = 2H-1`
(:func:`envfit.shading._bilinear_sh.bilinear_sh_coefficients`), giving the export
(:func:`envfit.sh._sh_export.sh_coefficients`), the power per degree of the predictions
and the ringing table (:mod:`envfit.sh._ringing`).

Example
-------
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.maps._latlong import pixel_directions
>>> d = pixel_directions(16, up="y")
>>> env = EnvMap(1.0 + 0.5 * d[..., 1:2], up="y", name="sky")      # 1 + y/2: degree 1
>>> opts = SHReportOptions(irradiance=True, table_lmax=2, check_axes=256, dense_height=32)
>>> r = sh_report(env, 1, opts)
>>> r.predicted_relative_rmse < 1e-3, r.negative_fraction, r.choice.L
(True, 0.0, 1)
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from envfit.base import atomic_write_csv, atomic_write_json, atomic_write_text, to_jsonable
from envfit.base import check_int, check_positive
from envfit.base import progress
from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.maps import SCALES, fit_scale
from envfit.sh._plan import check_sh_plan
from envfit.sh._ringing import (CHECK_AXES, DENSE_HEIGHT, TABLE_LMAX, RingingRow, check_lmax,
                                    choose, dense_negative_fractions, measured_rmse,
                                    negative_fraction, ringing_rows, signal_mean, truncation_rmse)
from envfit.shading import bilinear_sh_coefficients
from envfit.sh._sh_export import (NORMALISATION, ORDERING, RH_CONSTANTS, WINDOWS,
                                      SHCoefficients, clamped_cosine_sh, pixel_synthesis,
                                      sh_coefficients, shading_factors, truncate_alm)
from envfit.sh._sh_format import signed_coefficients, to_csv, to_glsl
from envfit.shading import power_by_degree   # the alm are computed here once

__all__ = ["FORMATS", "SHReport", "SHReportOptions", "sh_report", "plan", "default_table_lmax", "document",
           "sh_outputs", "preview_images"]

#: the documents ``--format`` names
FORMATS = ("json", "csv", "glsl")


@dataclass(frozen=True)
class SHReport:
    """The result of :func:`sh_report` (relative = over the exported signal's mean)."""

    export: SHCoefficients
    map_name: str
    width: int
    height: int
    convention: str
    scale: str
    mean: float
    predicted_relative_rmse: float
    negative_fraction: float
    rows: tuple
    target_relative: float
    choice: RingingRow | None
    choice_sentence: str
    power_lmax: int
    measured_relative_rmse: float | None = None
    dense_negative_fraction: float | None = None
    check_axes: int | None = None
    dense_height: int | None = None
    measured_on: str | None = None
    notes: tuple = ()
    scaled: EnvMap | None = field(default=None, repr=False, compare=False)

    @property
    def signal(self) -> str:
        return "irradiance" if self.export.irradiance else "radiance"

    def to_dict(self) -> dict:
        """The JSON document (metadata, coefficients, predictions, ringing table, choice)."""
        e = self.export
        c = signed_coefficients(e)
        return {
            "map": self.map_name, "size": f"{self.width}x{self.height}",
            "width": self.width, "height": self.height, "convention": self.convention,
            "up": e.up, "normalisation": NORMALISATION + (
                "; Condon-Shortley phase applied (odd m negated)" if e.condon_shortley else ""),
            "ordering": ORDERING, "scale": self.scale, "lmax": e.lmax, "signal": self.signal,
            "irradiance_factors": clamped_cosine_sh(e.lmax).tolist() if e.irradiance else None,
            "rh_constants": RH_CONSTANTS, "window": e.window,
            "window_weights": list(e.window_weights), "window_lambda": e.window_lambda,
            "channels": list(e.channels),
            "coefficients": [{"index": i, "l": int(l), "m": int(m), "values": c[i].tolist()}
                             for i, (l, m) in enumerate(zip(e.degrees, e.orders))],
            "mean": self.mean, "power_lmax": self.power_lmax,
            "predicted_relative_rmse": self.predicted_relative_rmse,
            "measured_relative_rmse": self.measured_relative_rmse, "check_axes": self.check_axes,
            "measured_on": self.measured_on,
            "negative_fraction": self.negative_fraction,
            "dense_negative_fraction": self.dense_negative_fraction,
            "dense_height": self.dense_height,
            "ringing": [r.to_dict() for r in self.rows],
            "target_relative": self.target_relative,
            "choice": None if self.choice is None else self.choice.to_dict(),
            "choice_sentence": self.choice_sentence, "notes": list(self.notes)}

    def summary_lines(self) -> list[str]:
        """What the command prints: the export, its errors, the table, the choice."""
        e = self.export
        meas = "" if self.measured_relative_rmse is None else \
            f", measured {self.measured_relative_rmse:.3%} ({self.measured_on})"
        dense = "" if self.dense_negative_fraction is None else \
            f" (dense check {self.dense_negative_fraction:.3%})"
        lam = f" (lambda {e.window_lambda:.4g})" if e.window_lambda else ""
        out = [f"{self.map_name}: {self.width}x{self.height}, {self.convention}, scale "
               f"{self.scale}; {self.signal} SH to L = {e.lmax}, window {e.window}{lam}, "
               f"{(e.lmax + 1) ** 2} coefficients x {len(e.channels)} channel(s)",
               f"  basis: {NORMALISATION}", f"  ordering: {ORDERING}",
               f"  predicted RMSE {self.predicted_relative_rmse:.3%} of the mean{meas}; "
               f"negative on {self.negative_fraction:.3%} of directions{dense}",
               "", f"ringing table ({self.signal}; error relative to the mean "
               f"{self.mean:.6g}; negative = share of directions, solid-angle weighted):"]
        return out + self.table_lines() + ["", f"choice: {self.choice_sentence}",
                                           *(f"note: {n}" for n in self.notes)]

    def table_lines(self) -> list[str]:
        """One line per (L, window): predicted and measured error, negative fractions."""
        head = f"{'L':>3} {'window':8} {'lambda':>9} {'predicted':>10} {'measured':>10} " \
               f"{'negative':>9} {'dense':>9}"
        lines = [head]
        for r in self.rows:
            lam = "" if not r.window_lambda else f"{r.window_lambda:.3g}"
            meas = "" if r.measured_relative_rmse is None else f"{r.measured_relative_rmse:.3%}"
            dense = "" if r.dense_negative_fraction is None else \
                f"{r.dense_negative_fraction:.2%}"
            lines.append(f"{r.L:>3} {r.window:8} {lam:>9} {r.predicted_relative_rmse:>10.3%} "
                         f"{meas:>10} {r.negative_fraction:>9.2%} {dense:>9}")
        return lines


def measured_where(height: int, irradiance: bool, check_axes: int) -> str:
    """What the measured error was computed over (:func:`envfit.sh._ringing.measured_rmse`):
    irradiance at ``check_axes`` spherical Fibonacci directions; radiance on the pixel
    centres of a 2H-row lat-long grid, weighted by solid angle (``check_axes`` unused).

    >>> measured_where(32, False, 7)
    'the 8192 pixel centres of a 128x64 grid, solid-angle weighted'
    >>> measured_where(32, True, 7)
    '7 directions'
    """
    if irradiance:
        return f"{int(check_axes)} directions"
    h2 = 2 * int(height)
    return f"the {2 * h2 * h2} pixel centres of a {2 * h2}x{h2} grid, solid-angle weighted"


def default_table_lmax(height: int) -> int:
    """The ringing table's top degree without ``--table-lmax``: min(TABLE_LMAX, H − 1), at
    least 1."""
    return max(1, min(TABLE_LMAX, int(height) - 1))


@dataclass(frozen=True)
class SHReportOptions:
    """What :func:`sh_report` exports and checks (the options of ``envfit sh``).

    Attributes
    ----------
    irradiance : export :math:`\\hat A_l L_{lm}` (R&H 2001) instead of :math:`L_{lm}`.
    window : one of :data:`envfit.sh._sh_export.WINDOWS` for the export.
    target_relative : the relative RMSE the choice must meet.
    scale : "linear" or "display" (the values the coefficients are of).
    table_lmax : the ringing table covers L = 1…table_lmax and ``lmax``, 1 ≤ table_lmax ≤
        H − 1 (None: min(:data:`TABLE_LMAX`, H − 1), :func:`default_table_lmax`).
    check : also measure (ground truth at ``check_axes`` directions) and evaluate the
        negative fractions densely (``dense_height`` rows).
    check_axes, dense_height : the sizes of that check.
    convention : the name reported for the world frame (None: envfit's, ``--up``).
    condon_shortley : write the coefficients for the basis with the Condon–Shortley phase
        (Sloan 2008, D3DX: odd m negated) in JSON and CSV (GLSL keeps its own basis).
    """

    irradiance: bool = False
    window: str = "none"
    target_relative: float = 0.01
    scale: str = "linear"
    table_lmax: int | None = None
    check: bool = True
    check_axes: int = CHECK_AXES
    dense_height: int = DENSE_HEIGHT
    convention: str | None = None
    condon_shortley: bool = False


def _options(options: SHReportOptions | None) -> SHReportOptions:
    if options is None:
        return SHReportOptions()
    if not isinstance(options, SHReportOptions):
        raise ParameterError(f"options must be an SHReportOptions, got {type(options).__name__}")
    return options


def plan(envmap: EnvMap, lmax, options: SHReportOptions | None = None) -> list:
    """Every option checked before any work (ParameterError / MemoryBudgetError, one line):
    names and ranges, then the planned time and memory
    (:func:`envfit.sh._plan.check_sh_plan`); returns its stages."""
    o = _options(options)
    if not isinstance(envmap, EnvMap):
        raise ParameterError("sh_report needs an EnvMap")
    if envmap.height < 2:         # no degree 1 <= L <= H-1: no ringing table
        raise ParameterError(f"map {envmap.name or ''} ({envmap.width}x{envmap.height}) has "
                             f"{envmap.height} row: envfit sh needs a map of H >= 2 rows (its "
                             "ringing table's degrees are 1 <= L <= H-1)")
    check_lmax(lmax, envmap.height)
    if o.window not in WINDOWS:
        raise ParameterError(f"unknown --window {o.window!r}; use one of {', '.join(WINDOWS)}")
    if o.scale not in ("linear", "display"):
        raise ParameterError(f"--scale must be linear or display for SH export, got {o.scale!r}"
                             if o.scale in SCALES else f"unknown --scale {o.scale!r}")
    check_positive(o.target_relative, "--target-relative")
    table_lmax = default_table_lmax(envmap.height) if o.table_lmax is None else o.table_lmax
    check_int(table_lmax, "--table-lmax", 1)
    if o.check:
        check_int(o.check_axes, "--check-axes", 1)
        check_int(o.dense_height, "--check-height", 1)
    return check_sh_plan(envmap.height, envmap.channels, lmax, table_lmax, check=o.check,
                         check_axes=o.check_axes, dense_height=o.dense_height,
                         irradiance=o.irradiance)


def _checked_rows(scaled: EnvMap, alm, rows, export: SHCoefficients, mean: float,
                  o: SHReportOptions, quiet: bool = True):
    """The rows and the export with their dense negative fraction and measured error."""
    exps = [sh_coefficients(scaled, r.L, irradiance=o.irradiance, window=r.window,
                            lam=r.window_lambda, alm=alm)
            for r in progress(rows, desc="sh: exports", quiet=quiet)] + [export]
    dense = dense_negative_fractions(exps, o.dense_height, quiet=quiet)
    meas = [m / mean for m in measured_rmse(scaled, exps, o.check_axes, alm)]
    rows = tuple(replace(r, dense_negative_fraction=d, measured_relative_rmse=m)
                 for r, d, m in zip(rows, dense, meas))
    return rows, dense[-1], meas[-1]


def _signal_mean(envmap: EnvMap, alm, lp: int, o: SHReportOptions) -> tuple[np.ndarray, float]:
    """The power per degree and the mean of the exported signal (positive, else refused)."""
    mean = signal_mean(alm, shading_factors(lp, o.irradiance))
    if not mean > 0:
        raise ParameterError(f"map {envmap.name or ''} has mean {mean:.6g} on the {o.scale} "
                             "scale: relative errors and negativity need a positive mean")
    return power_by_degree(alm, lp), mean


def sh_report(envmap: EnvMap, lmax: int, options: SHReportOptions | None = None, *,
              quiet: bool = True) -> SHReport:
    """SH coefficients of ``envmap`` to ``lmax`` for an engine, with predictions and choice.

    ``envmap``'s ``up`` / convention fixes the world axes of the coefficients; ``lmax`` is
    the cut-off L, 0 ≤ L ≤ H − 1; ``options`` (:class:`SHReportOptions`) what is exported
    and checked; ``quiet``: no progress bars (the ringing table's rows, the dense check's
    blocks). Every option is checked before any work, its range and the planned time and
    memory (:func:`plan`): a value beyond is refused in one line naming the largest that fits.
    """
    o = _options(options)
    plan(envmap, lmax, o)
    L = int(lmax)
    table_lmax = default_table_lmax(envmap.height) if o.table_lmax is None else int(o.table_lmax)
    sc = fit_scale(o.scale, envmap)
    scaled = envmap.with_data(sc.apply(envmap.data))
    Ls = sorted(set(range(1, int(table_lmax) + 1)) | ({L} if L >= 1 else set()))
    top = max(Ls)
    lp = max(2 * envmap.height - 1, top)
    alm = bilinear_sh_coefficients(scaled, lp)
    power, mean = _signal_mean(envmap, alm, lp, o)
    g = shading_factors(lp, o.irradiance)
    export = sh_coefficients(scaled, L, irradiance=o.irradiance, window=o.window,
                             alm=truncate_alm(alm, top), condon_shortley=o.condon_shortley)
    w = np.asarray(export.window_weights)
    rows = tuple(ringing_rows(truncate_alm(alm, top), power, o.irradiance, Ls, quiet=quiet))
    kw = {}
    if o.check:
        rows, kw["dense_negative_fraction"], kw["measured_relative_rmse"] = _checked_rows(
            scaled, truncate_alm(alm, top), rows, export, mean, o, quiet)
        kw.update(check_axes=int(o.check_axes) if o.irradiance else None,
                  dense_height=int(o.dense_height),
                  measured_on=measured_where(envmap.height, o.irradiance, int(o.check_axes)))
    choice, sentence = choose(rows, float(o.target_relative))
    return SHReport(
        export=export, map_name=envmap.name or "map", width=envmap.width,
        height=envmap.height, convention=o.convention or f"envfit grid, +{envmap.up} up",
        scale=sc.describe(), mean=mean,
        predicted_relative_rmse=truncation_rmse(power, g, w) / mean,
        negative_fraction=negative_fraction(truncate_alm(alm, L), w * g[:L + 1]),
        rows=rows, target_relative=float(o.target_relative), choice=choice,
        choice_sentence=sentence, power_lmax=lp, notes=tuple(envmap.notes),
        scaled=scaled, **kw)


# ---------------------------------------------------------------- documents and files
def _comments(r: SHReport) -> list[str]:
    return [f"envfit sh: {r.map_name} ({r.width}x{r.height}), {r.convention}, scale {r.scale}",
            f"predicted RMSE {r.predicted_relative_rmse:.4%} of the mean {r.mean:.6g}; "
            f"negative on {r.negative_fraction:.3%} of directions",
            f"choice for {r.target_relative:.3g}: {r.choice_sentence}"]


def document(r: SHReport, fmt: str) -> str:
    """The ``--format`` document: JSON (:meth:`SHReport.to_dict`), CSV or GLSL."""
    if fmt == "json":
        return json.dumps(to_jsonable(r.to_dict()), indent=2) + "\n"
    if fmt == "csv":
        return to_csv(r.export)
    if fmt == "glsl":
        return to_glsl(r.export, _comments(r))
    raise ParameterError(f"unknown --format {fmt!r}; use one of {', '.join(FORMATS)}")


def _ringing_csv(r: SHReport, path) -> Path:
    keys = list(r.rows[0].to_dict())
    return atomic_write_csv(path, keys, [[row.to_dict()[k] for k in keys] for row in r.rows])


def sh_outputs(r: SHReport) -> dict[str, Callable[[Path], Path]]:
    """``--out`` files → their writers (each atomic): ``sh.png`` (look here first),
    ``sh.json``, ``sh.csv``, ``sh.glsl``, ``ringing.csv``."""
    from envfit.plots import plot_sh
    return {"sh.png": lambda p: plot_sh(preview_images(r), _plot_data(r), p),
            "sh.json": lambda p: atomic_write_json(p, r.to_dict()),
            "sh.csv": lambda p: atomic_write_text(p, document(r, "csv")),
            "sh.glsl": lambda p: atomic_write_text(p, document(r, "glsl")),
            "ringing.csv": lambda p: _ringing_csv(r, p)}


def _plot_data(r: SHReport) -> dict:
    e = r.export
    return {"title": f"{r.map_name} ({r.width}x{r.height}, {r.convention}): {r.signal} SH, "
                     f"L = {e.lmax}, window {e.window}",
            "signal": r.signal, "target": r.target_relative,
            "rows": [x.to_dict() for x in r.rows],
            "choice": None if r.choice is None else r.choice.to_dict(),
            "export": {"L": e.lmax, "window": e.window,
                       "predicted": r.predicted_relative_rmse,
                       "negative": r.negative_fraction}}


def _display(values: np.ndarray) -> np.ndarray:
    """(H, W, C) → display RGB in [0, 1] (the display scale fitted on the clipped values)."""
    v = np.maximum(values, 0.0)
    v = np.repeat(v, 3, axis=-1) if v.shape[-1] == 1 else v[..., :3]
    return fit_scale("display", EnvMap(v)).apply(v) if np.any(v > 0) else v


def preview_images(r: SHReport) -> dict:
    """The map and the exported signal at the map's pixels (display RGB) and where the signal
    is negative (any channel): the signal by ``ducc0.sht.synthesis_2d`` on the map's own
    equiangular grid (:func:`envfit.sh._sh_export.pixel_synthesis`)."""
    m, e = r.scaled, r.export
    f = np.asarray(e.window_weights) * shading_factors(e.lmax, e.irradiance)
    vals = pixel_synthesis(m, bilinear_sh_coefficients(m, e.lmax), f, e.lmax)
    tol = 1e-9 * abs(r.mean)
    return {"map": _display(m.data), "signal": _display(vals),
            "negative": (vals < -tol).any(axis=-1)}

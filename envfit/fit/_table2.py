"""The paper's Table 2 experiment (Sec. 9.1): reconstruct a map from N samples with the
Sobolev kernel K_gd^(s) for a grid of (s, N), and report the reconstruction RMSE.

For each N the map is sampled at N directions (spherical Fibonacci by default, the same
points for every s); for each s the samples are interpolated with
:class:`~envfit.sobolev._interpolation.SobolevInterpolator`, evaluated at every pixel centre, and
compared with the map on a named value scale (:mod:`envfit.maps._scales`; the paper's values are
display-referred, see docs/ERRATA.md, "Table 2"). The scale is fitted once on the map and applied to
the map *before* sampling: the scaled map is the function being reconstructed.

Cells are stored as they finish (:class:`~envfit.base._store.ResultStore`), so a rerun with the
same output folder skips them; a stored cell that is not sound (edited, corrupt, another
cell's) is recomputed with a note, and a second run on the same folder is refused while the
first holds its lock (:mod:`envfit.base._store`).
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from envfit.theory import sphere_points

from envfit.base import check_ints
from envfit.base import html_result
from envfit.base import s_key
from envfit.maps import EnvMap, check_sample_count
from envfit.base import ParameterError
from envfit.sobolev import SobolevInterpolator
from envfit.maps import local_to_world
from envfit.maps import rmse, rmse_solid_angle
from envfit.base import SOLVERS, plan_memory
from envfit.maps import check_not_constant, fit_scale
from envfit.base import ResultStore, array_fingerprint, number, one_of

__all__ = ["PAPER_S", "PAPER_N", "QUICK_N", "RMSE_RTOL", "Table2Cell", "Table2Result", "run_table2",
           "sample_directions", "format_table2", "check_grid", "plan_table2_memory",
           "PAPER_TABLE2_PISA"]

#: the paper's grid (Table 2)
PAPER_S = (1.1, 1.5, 1.9)
PAPER_N = (100, 500, 1000, 2500, 5000, 10000, 20000)
#: a grid that runs in seconds on a laptop
QUICK_N = (100, 250, 500, 1000, 2000)
#: an iteratively solved cell's RMSE equals the exact solution's to this relative bound
RMSE_RTOL = 1e-6
#: the paper's published Table 2 (Pisa map, display-referred RMSE), for side-by-side printing
PAPER_TABLE2_PISA = {
    1.1: (0.255, 0.174, 0.156, 0.130, 0.114, 0.098, 0.085),
    1.5: (0.234, 0.152, 0.138, 0.114, 0.098, 0.083, 0.070),
    1.9: (0.241, 0.153, 0.139, 0.120, 0.107, 0.097, 0.089),
}


@dataclass
class Table2Cell:
    """One (s, N) reconstruction: RMSE per pixel (as the paper) and solid-angle weighted.

    ``solver``: how the coefficients were obtained (``"cholesky"`` or ``"iterative"``);
    ``iterations``: CG iterations, refinements included (0 for Cholesky); ``residual``: largest relative residual
    ``|f - K alpha| / |f|`` over the channels (0 for Cholesky: not computed);
    ``rmse_change_bound``: bound of the RMSE's relative change against the exact solution
    (iterative: sup-norm bound of the interpolant's change / RMSE, at most
    :data:`RMSE_RTOL`; Cholesky: 0).
    """
    s: float
    n: int
    rmse: float
    rmse_solid_angle: float
    seconds: float
    seconds_fit: float
    seconds_evaluate: float
    solver: str = "cholesky"
    iterations: int = 0
    residual: float = 0.0
    rmse_change_bound: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class Table2Result:
    map: str
    scale: str
    scale_description: str
    pointset: str
    seed: int
    height: int
    s_values: list[float]
    n_values: list[int]
    cells: list[Table2Cell] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: ``(path, reason)`` of outputs that could not be written (disk full mid-run, …): the
    #: cells are complete in this result, only their files are missing
    unwritten: list[tuple[str, str]] = field(default_factory=list)

    def cell(self, s: float, n: int) -> Table2Cell:
        for c in self.cells:
            if np.isclose(c.s, s) and c.n == n:
                return c
        raise KeyError((s, n))

    def rmse_table(self, key: str = "rmse") -> np.ndarray:
        """(len(s), len(N)) array of the chosen RMSE."""
        return np.array([[getattr(self.cell(s, n), key) for n in self.n_values]
                         for s in self.s_values])

    @property
    def s_best(self) -> float:
        """The s with the lowest per-pixel RMSE at the largest N (the paper's choice)."""
        col = self.rmse_table()[:, -1]
        return float(self.s_values[int(np.argmin(col))])

    def s_best_by_n(self) -> dict[int, float]:
        t = self.rmse_table()
        return {n: float(self.s_values[int(np.argmin(t[:, k]))]) for k, n in enumerate(self.n_values)}

    def to_dict(self) -> dict:
        return {
            "map": self.map, "scale": self.scale, "scale_description": self.scale_description,
            "pointset": self.pointset, "seed": self.seed, "height": self.height,
            "rows": [c.to_dict() for c in self.cells],
            "s_best": self.s_best,
            "s_best_by_n": {str(k): v for k, v in self.s_best_by_n().items()},
            "files": self.files, "notes": self.notes,
            "unwritten": [list(u) for u in self.unwritten],
        }

    def _repr_html_(self) -> str:
        """Jupyter: the RMSE table (one row per s, one column per N) and the best s."""
        t = self.rmse_table()
        return html_result(
            f"Table2Result: {self.map} ({self.height} rows, {self.scale} scale, {self.pointset})",
            [(f"best s at N = {self.n_values[-1]}", self.s_best), ("scale", self.scale_description)],
            (["s \\ N", *self.n_values], [[s, *row] for s, row in zip(self.s_values, t)]))


def sample_directions(n: int, *, pointset: str = "sf", seed: int = 0, up: str = "y") -> np.ndarray:
    """N sample directions in world coordinates (the map's local frame rotated by ``up``)."""
    local = sphere_points(pointset, n, seed=seed)
    return local @ local_to_world(up).T


def check_grid(s_values: Sequence[float], n_values: Sequence[int]) -> tuple[list[float], list[int]]:
    """The (s, N) grid as floats and sorted ints; ParameterError if empty or out of range."""
    try:
        s_values = [float(s) for s in s_values]
    except (TypeError, ValueError):
        raise ParameterError(f"s values must be numbers in (1, 2), got {list(s_values)!r}") from None
    n_values = sorted(check_ints(n_values, "N", 2))
    if not s_values or not n_values:
        raise ParameterError("table2 needs at least one s and one N")
    for s in s_values:
        if not 1.0 < s < 2.0:
            raise ParameterError(f"s must satisfy 1 < s < 2 (Eq. 14), got {s:g}")
    return s_values, n_values


def plan_table2_memory(n_max: int, width: int, height: int, channels: int,
                       what: str = "table2", solver: str = "cholesky") -> int:
    """The memory guard of a Table 2 sweep (:func:`envfit.base._resources.plan_memory`), before any
    sample point is made: the interpolator of the largest N (on ``solver``'s path; ``auto``:
    dense where it fits, else iterative) plus the map-sized arrays (the map on its scale,
    pixel directions, solid angles, one reconstruction)."""
    pixels = int(width) * int(height)
    c = int(channels)
    return plan_memory(n_max, what, channels=c, fixed_bytes=8 * pixels * (4 + 3 * c),
                       solver=solver)


#: what a stored cell must hold to be used (cells stored before the solver fields existed
#: were all Cholesky: the later fields take their defaults)
TABLE2_FIELDS = ("s", "n", "rmse", "rmse_solid_angle", "seconds", "seconds_fit", "seconds_evaluate")
_OPTIONAL = tuple(f for f in Table2Cell.__dataclass_fields__ if f not in TABLE2_FIELDS)


def table2_cell_key(s: float, n: int) -> str:
    return f"s{s_key(s)}_n{n}"


def cell_checks(s: float, n: int) -> dict:
    """The types and ranges a stored cell (s, N) must have to be used
    (:meth:`~envfit.base._store.ResultStore.get`): a cell forged with a valid checksum but a
    string, NaN or negative RMSE, or another s or N than its key, is recomputed."""
    nonneg = number(0.0)
    return {"s": one_of(float(s)), "n": one_of(int(n)), "rmse": nonneg,
            "rmse_solid_angle": nonneg, "seconds": nonneg, "seconds_fit": nonneg,
            "seconds_evaluate": nonneg, "solver": one_of("cholesky", "iterative"),
            "iterations": number(0, integer=True), "residual": nonneg,
            "rmse_change_bound": nonneg}


def run_table2(envmap: EnvMap, s_values: Sequence[float] = PAPER_S,
               n_values: Sequence[int] = PAPER_N, *, pointset: str = "sf",
               scale: str = "display", seed: int = 0, out: str | Path | None = None,
               save_reconstructions: bool = True, quiet: bool = True,
               on_cell: Callable[[Table2Cell, bool], None] | None = None,
               on_note: Callable[[str], None] | None = None,
               solver: str = "auto") -> Table2Result:
    """Run the (s, N) sweep on ``envmap``; see the module docstring.

    Parameters
    ----------
    s_values, n_values : the grid (each s in (1, 2); each N an integer ≥ 2 and at most the
        map's pixel count, :func:`~envfit.maps._envmap.check_sample_count`).
    pointset : ``"sf"`` (spherical Fibonacci, deterministic) or ``"random"`` (seeded).
    scale : ``"display"`` (paper), ``"linear"`` or ``"log"``.
    out : folder for the resumable cells, the reconstructions (EXR + PNG) of the largest N.
    on_cell : called as ``on_cell(cell, resumed)`` after each cell (for progress output).
    on_note : called with each note of the store (a stored cell recomputed because it was
        not sound); default: printed to stderr (:func:`envfit.base._progress.print_note`). The notes
        are also in ``result.notes``.
    solver : the interpolator's solver (:class:`~envfit.sobolev._interpolation.SobolevInterpolator`):
        ``"auto"`` (measured crossover; iterative where the dense matrix does not fit),
        ``"cholesky"`` or ``"iterative"``. An iterative cell is iterated until its RMSE equals
        the exact solution's to :data:`RMSE_RTOL` relative (a bound, recorded per cell).

    Before anything of size N is made: the memory guard for the largest N
    (:func:`plan_table2_memory`, :class:`~envfit.base._errors.MemoryBudgetError` naming the
    largest N that fits), N against the pixel count, and a map constant on ``scale``
    (:func:`~envfit.maps._scales.check_not_constant`) is refused.
    """
    s_values, n_values = _checked_grid(envmap, s_values, n_values, solver)
    sc = fit_scale(scale, envmap)
    target = np.asarray(sc.apply(envmap.data), dtype=np.float64)          # H×W×C on the scale
    check_not_constant(target, scale, envmap.name)
    store = ResultStore(out, {
        "map": array_fingerprint(envmap.data), "scale": sc.describe(), "pointset": pointset,
        "seed": int(seed), "up": envmap.up, "height": target.shape[0]}, kind="table2",
        on_note=on_note)
    result = Table2Result(map=envmap.name or "(unnamed)", scale=scale,
                          scale_description=sc.describe(), pointset=pointset, seed=int(seed),
                          height=target.shape[0], s_values=s_values, n_values=n_values)
    sweep = _Sweep(envmap, target, sc, pointset, seed,
                   Path(out) if out is not None and save_reconstructions else None, n_values[-1],
                   solver)
    try:
        _run_cells(store, sweep, result, quiet, on_cell)
    finally:
        store.close()
        result.notes.extend(store.notes)
        result.unwritten[:0] = store.unwritten
    if out is not None:
        result.files.update(_existing_files(Path(out), s_values, n_values[-1]))
    return result


def _checked_grid(envmap: EnvMap, s_values, n_values, solver: str) -> tuple[list[float], list[int]]:
    """:func:`run_table2`'s checks before anything of size N is made: the grid, the solver,
    the memory guard for the largest N (before any sample point), then N against the map's
    pixel count. Returns the grid as :func:`check_grid` does."""
    s_values, n_values = check_grid(s_values, n_values)
    if solver not in SOLVERS:
        raise ParameterError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    plan_table2_memory(n_values[-1], envmap.width, envmap.height, envmap.channels,
                       solver=solver)
    check_sample_count(n_values[-1], envmap.width, envmap.height, name=envmap.name)
    return s_values, n_values


def _run_cells(store: ResultStore, sweep: "_Sweep", result: Table2Result, quiet: bool,
               on_cell: Callable[[Table2Cell, bool], None] | None) -> None:
    """Every (s, N) cell in order (N outer): the stored one where it is sound, else computed
    (:meth:`_Sweep.cell`) and stored at once; appended to ``result.cells``, reported to
    ``on_cell(cell, resumed)``, counted on a progress bar unless ``quiet``."""
    from envfit.base import progress_bar
    bar = progress_bar(len(result.s_values) * len(result.n_values), desc="table2", quiet=quiet,
                       unit="cell")
    try:
        for n in result.n_values:
            for s in result.s_values:
                key = table2_cell_key(s, n)
                done = store.get(key, fields=TABLE2_FIELDS, checks=cell_checks(s, n))
                cell = (Table2Cell(**{k: done[k] for k in TABLE2_FIELDS + _OPTIONAL if k in done})
                        if done is not None else None)
                if cell is None:
                    bar.set_postfix_str(f"s={s:g} N={n}")
                    cell = sweep.cell(s, n, result)
                    store.put(key, cell.to_dict())
                result.cells.append(cell)
                bar.update(1)
                if on_cell:
                    on_cell(cell, done is not None)
    finally:
        bar.close()


class _Sweep:
    """What every cell of one map's sweep shares: the target on its scale, the pixel
    directions and solid angles, and the samples of the current N (made on first need)."""

    def __init__(self, envmap: EnvMap, target: np.ndarray, sc, pointset: str, seed: int,
                 recon_dir: Path | None, n_max: int, solver: str = "auto"):
        self.envmap, self.target, self.sc = envmap, target, sc
        self.scaled = envmap.with_data(target)
        self.pointset, self.seed, self.recon_dir, self.n_max = pointset, seed, recon_dir, n_max
        self.solver = solver
        self.pixel_dirs = envmap.directions().reshape(-1, 3)
        self.weights = envmap.solid_angles()
        self._n, self._samples = None, None

    def samples(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        if self._n != n:
            points = sample_directions(n, pointset=self.pointset, seed=self.seed,
                                       up=self.envmap.up)
            self._n = n
            self._samples = (points, self.scaled.lookup(points).reshape(n, self.target.shape[2]))
        return self._samples

    def cell(self, s: float, n: int, result: Table2Result) -> Table2Cell:
        """Interpolate the N samples with K_gd^(s), evaluate at every pixel, score (one cell).

        Iterative: if the solve's bound of the interpolant's change exceeds
        :data:`RMSE_RTOL` x RMSE, iterate on to that bound and evaluate again (rare: the
        default stopping rule is 1e-8 of the samples' RMS)."""
        points, values = self.samples(n)
        t0 = time.perf_counter()
        interp = SobolevInterpolator(points, values, s, solver=self.solver)
        t1 = time.perf_counter()
        recon = np.asarray(interp(self.pixel_dirs)).reshape(self.target.shape)
        err = float(rmse(recon, self.target))
        info = interp.solve_info
        iterations = info.iterations        # CG iterations of the solve and its refinements
        while info.solver == "iterative" and max(info.error_bound) > RMSE_RTOL * err > 0:
            t1 += interp.refine(0.5 * RMSE_RTOL * err).seconds_solve
            new = interp.solve_info        # (auto: the dense path if CG failed; then exact)
            if new.solver == "iterative" and not new.converged:
                break
            iterations += new.iterations
            info = new
            recon = np.asarray(interp(self.pixel_dirs)).reshape(self.target.shape)
            err = float(rmse(recon, self.target))
        if info.fallback:
            result.notes.append(f"table2 s = {s:g}, N = {n}: {info.fallback}; solved by the "
                                f"dense Cholesky path instead")
        t2 = time.perf_counter()
        del interp
        if self.recon_dir is not None and n == self.n_max:
            _save_reconstruction(self.recon_dir, recon, self.sc, s, n, self.envmap.up, result)
        iterative = info.solver == "iterative"
        return Table2Cell(s=s, n=n, rmse=err,
                          rmse_solid_angle=float(rmse_solid_angle(recon, self.target,
                                                                  self.weights)),
                          seconds=t2 - t0, seconds_fit=t1 - t0, seconds_evaluate=t2 - t1,
                          solver=info.solver,
                          iterations=iterations if info.solver == "iterative" else 0,
                          residual=max(info.residual) if iterative else 0.0,
                          rmse_change_bound=(max(info.error_bound) / err
                                             if iterative and err > 0 else 0.0))


def table2_recon_stem(s: float, n: int) -> str:
    return f"reconstruction_s{s:.2f}_n{n}"


def _existing_files(out: Path, s_values, n_max) -> dict[str, str]:
    files = {}
    for s in s_values:
        for ext in ("exr", "png"):
            p = out / f"{table2_recon_stem(s, n_max)}.{ext}"
            if p.exists():
                files[f"{table2_recon_stem(s, n_max)}.{ext}"] = str(p)
    return files


def _save_reconstruction(out: Path, recon: np.ndarray, sc, s: float, n: int, up: str,
                         result: Table2Result) -> None:
    """EXR of the reconstruction (on the comparison scale) and a display-referred PNG preview.

    A write that fails (disk full, …) is recorded in ``result.unwritten`` and the sweep goes
    on: the cell's numbers do not depend on the image files.
    """
    from envfit.maps import save_envmap
    stem = table2_recon_stem(s, n)
    preview = np.clip(sc.to_display(recon), 0.0, 1.0)
    for path, img in ((out / f"{stem}.exr", recon), (out / f"{stem}.png", preview)):
        try:
            save_envmap(path, EnvMap(img.astype(np.float32), up=up, name=stem))
        except OSError as exc:
            result.unwritten.append((str(path), getattr(exc, "strerror", None) or str(exc)))


def _solver_label(result: Table2Result, n: int) -> str:
    """``chol``, ``cg`` (iterative; max iterations over s) or ``mixed`` for column N."""
    cells = [c for c in result.cells if c.n == n]
    kinds = {c.solver for c in cells}
    if kinds == {"iterative"}:
        return f"cg{max(c.iterations for c in cells)}"
    return "chol" if kinds == {"cholesky"} else "mixed"


def format_table2(result: Table2Result, *, key: str = "rmse", paper: bool = False) -> str:
    """The result as the paper prints Table 2: one row per s, one column per N."""
    t = result.rmse_table(key)
    label = "RMSE per pixel" if key == "rmse" else "RMSE, solid-angle weighted"
    lines = [f"{label} of the interpolated map {result.map!r} ({result.scale_description})",
             "  s    | " + " ".join(f"{n:>7d}" for n in result.n_values)]
    lines.append("  " + "-" * (len(lines[-1]) - 2))
    for i, s in enumerate(result.s_values):
        mark = ""
        lines.append(f"  {s:<4.2f} | " + " ".join(f"{v:7.4f}" for v in t[i]) + mark)
    best = result.s_best_by_n()
    lines.append("  best | " + " ".join(f"{best[n]:>7.2f}" for n in result.n_values))
    lines.append("  solver " + " ".join(f"{_solver_label(result, n):>7}" for n in result.n_values))
    if paper:
        lines.append("")
        lines.append("Paper, Table 2 (Pisa map, display-referred):")
        lines.append("  s    | " + " ".join(f"{n:>7d}" for n in PAPER_N))
        for s, row in PAPER_TABLE2_PISA.items():
            lines.append(f"  {s:<4.2f} | " + " ".join(f"{v:7.3f}" for v in row))
    return "\n".join(lines)

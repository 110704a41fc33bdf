r"""Worker-side tasks of a library sweep: sample a map, factorise once for many maps,
evaluate one map. Module-level functions of picklable arguments, so that a process pool
or a dask worker can run them; each loads at most one map at a time.

The shared step rests on K depending only on the nodes and s: with the samples of M maps
(C_k channels each) side by side as columns, :math:`F = [f_1 \dots f_M]` (N x sum C_k),

.. math::  K^{(s)} = L L^T \ \text{(one Cholesky, N^3/3 flops)}, \qquad
           A = L^{-T} L^{-1} F \ \text{(O(N^2 \textstyle\sum C_k))},

and map k's interpolant is :math:`\tilde f_k(u) = \sum_j A_{jk} K(u, p_j)` (Eq. 14).
Evaluation needs only the nodes and the map's own columns of A, never the N x N factor
(:meth:`SobolevInterpolator.from_coefficients`), so it can run on any worker.

The scaled map is what is sampled and compared, exactly as in :func:`envfit.fit._table2.run_table2`
(the scale is fitted on the map, applied to its pixels, then the result is looked up), so a
library cell equals the single-map cell to rounding.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.base import interpolator_nbytes, memory_budget_bytes
from envfit.sobolev import SobolevInterpolator
from envfit.maps import MapSource
from envfit.maps import rmse, rmse_solid_angle
from envfit.maps import fit_scale
from envfit.fit import sample_directions

__all__ = ["SweepSpec", "load_scaled", "sample_task", "solve_task", "evaluate_task"]


@dataclass(frozen=True)
class SweepSpec:
    """What every task of one sweep shares: the sample directions' recipe and the scale."""
    pointset: str = "sf"
    seed: int = 0
    scale: str = "display"
    up: str = "y"
    #: the factorisation's solver: "cholesky" (one dense factor for all maps, the default),
    #: "iterative" (preconditioned CG, every map's columns side by side: one preconditioner
    #: for all maps) or "auto" (Cholesky where the dense matrix fits, else iterative — the
    #: single-map crossover N = 3000 was measured with 3 columns; a library has many more,
    #: which favour one factor)
    solver: str = "cholesky"

    def points(self, n: int) -> np.ndarray:
        return sample_directions(n, pointset=self.pointset, seed=self.seed, up=self.up)


def load_scaled(source: MapSource, spec: SweepSpec):
    """``(scaled map, scale)``: the map on ``spec.scale`` (float64), scale fitted on it."""
    env = source.load()
    if env.up != spec.up:
        raise ParameterError(f"map {source.label} has up={env.up}, the library up={spec.up}")
    sc = fit_scale(spec.scale, env)
    return env.with_data(np.asarray(sc.apply(env.data), dtype=np.float64)), sc


def sample_task(source: MapSource, spec: SweepSpec, n_values: list[int]) -> dict:
    """Load one map, put it on the scale, sample it at the N points of every N in ``n_values``.

    Returns ``{"values": {N: (N, C) array}, "height", "width", "channels", "scale_description"}``.
    """
    scaled, sc = load_scaled(source, spec)
    c = scaled.channels
    values = {int(n): np.ascontiguousarray(scaled.lookup(spec.points(n)).reshape(n, c))
              for n in n_values}
    return {"values": values, "height": scaled.height, "width": scaled.width, "channels": c,
            "scale_description": sc.describe()}


def solve_task(spec: SweepSpec, s: float, n: int, values: np.ndarray, widths: list[int]) -> dict:
    """One factorisation of K^(s) at the N points, all maps' samples as right-hand sides.

    ``values`` is (N, sum(widths)), the maps' columns side by side. Returns ``{"alphas":
    [(N, C_k) per map], "seconds": wall time, "timings": matrix/cholesky/solve}``.
    """
    t0 = time.perf_counter()
    # one factorisation (or one preconditioner) per (s, N) shared by every map
    interp = SobolevInterpolator(spec.points(n), values, s, solver=_library_solver(spec, n, values))
    alpha = interp.coefficients
    edges = np.cumsum([0, *widths])
    alphas = [np.array(alpha[:, a:b], order="F") for a, b in zip(edges[:-1], edges[1:])]
    timings = dict(interp.timings)
    info = interp.solve_info
    iterative = info.solver == "iterative"
    solves = [{"solver": info.solver, "iterations": int(info.iterations),
               "residual": float(max(info.residual[a:b])) if iterative else 0.0,
               "error_bound": float(max(info.error_bound[a:b])) if iterative else 0.0}
              for a, b in zip(edges[:-1], edges[1:])]
    del interp, alpha
    return {"alphas": alphas, "seconds": time.perf_counter() - t0, "timings": timings,
            "solves": solves}


def _library_solver(spec: SweepSpec, n: int, values: np.ndarray) -> str:
    """The solver of one shared solve: ``spec.solver``; "auto" is Cholesky where the dense
    matrix fits the memory budget, else the iterative path."""
    if spec.solver != "auto":
        return spec.solver
    fits = interpolator_nbytes(n, values.shape[1]) <= memory_budget_bytes()
    return "cholesky" if fits else "iterative"


def evaluate_task(source: MapSource, spec: SweepSpec, s: float, n: int, alpha: np.ndarray,
                  keep_reconstruction: bool = False) -> dict:
    """Reconstruct one map from its coefficients at every pixel centre; RMSEs on the scale.

    Returns the :class:`~envfit.fit._table2.Table2Cell` fields (``seconds_fit`` left for the
    driver to fill with the shared factorisation's time) plus ``height``, ``width``,
    ``scale_description``; with ``keep_reconstruction`` also ``reconstruction`` (H x W x C
    float32, on the scale) and ``preview`` (display-referred, clipped to [0, 1]).
    """
    t0 = time.perf_counter()
    scaled, sc = load_scaled(source, spec)
    h, w, c = scaled.data.shape
    if alpha.shape != (n, c):
        raise ParameterError(f"map {source.label}: coefficients {alpha.shape} do not match "
                             f"N = {n} and {c} channel(s) (did the file change during the run?)")
    evaluator = SobolevInterpolator.from_coefficients(spec.points(n), alpha, s)
    t1 = time.perf_counter()
    recon = np.asarray(evaluator(scaled.directions().reshape(-1, 3))).reshape(h, w, c)
    t2 = time.perf_counter()
    target = scaled.data
    cell = {"s": float(s), "n": int(n), "rmse": float(rmse(recon, target)),
            "rmse_solid_angle": float(rmse_solid_angle(recon, target, scaled.solid_angles())),
            "seconds_evaluate": t2 - t1, "seconds_load": t1 - t0,
            "height": h, "width": w, "scale_description": sc.describe()}
    if keep_reconstruction:
        cell["reconstruction"] = recon.astype(np.float32)
        cell["preview"] = np.clip(sc.to_display(recon), 0.0, 1.0).astype(np.float32)
    return cell

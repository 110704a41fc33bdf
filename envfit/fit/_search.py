r"""The search for ŝ and its 95 % interval, implemented once: a coarse grid, a shared
refinement lattice and a cubic spline.

One :class:`SmoothnessSearch` per map decides which values of s it needs next
(:meth:`~SmoothnessSearch.requests`), is given the criterion there
(:meth:`~SmoothnessSearch.add`; cells of :func:`envfit.fit._criterion.evaluate_criterion`) and
finally returns the estimate (:meth:`~SmoothnessSearch.result`). Every s it asks for lies on
a fixed lattice, so the maps of a library ask for the *same* s values and one factorisation
per s serves them all (:func:`envfit.batch._library_fit.fit_smoothness_library`); a single map
runs the same search (:func:`envfit.fit._smoothness.fit_smoothness_samples`) and gets the same
ŝ as inside a library, to rounding. :func:`run_searches` is the loop both use.

1. the coarse grid :data:`S_GRID` (step 0.075);
2. the bracket around the grid minimum (its grid neighbours, or the edge of (1, 2)) on the
   lattice of step 0.075/``refine`` (:func:`lattice`; default 3, step 0.025); ŝ is the
   minimum, inside the bracket, of the cubic spline through the lattice values;
3. ``likelihood``: the profile interval :math:`2N(\mathrm{score}(s) - \mathrm{score}(\hat s))
   \le \chi^2_{1,0.95}` — lattice points are added outward from ŝ, :data:`WALK_BATCH` per
   side and round, until the criterion crosses the threshold on both sides (or the edge of
   (1, 2) is reached); ŝ is then the spline minimum through all of them, and the crossings
   are solved on that spline. ``loo``/``holdout``: the bootstrap interval of the argmin on
   the grid (:func:`bootstrap_argmin_interval`), widened to contain ŝ.

σ̂ at ŝ is read from the spline of :math:`\log\hat\sigma + \tfrac12\log(2 - s)` through the same
lattice points (:attr:`SearchResult.sigma`; no further factorisation): within ~1e-7 of the
exact σ̂ at ŝ for s ≳ 1.3, up to ~5e-4 within 0.05 of s = 1 (GP maps, N = 300). The estimate and the interval
ends are within ~1e-5 of the exact optimum and crossings (GP samples, N = 400, against a
1e-7 Brent search); a search needs ~20–30 evaluations.

Example
-------
>>> search = SmoothnessSearch("likelihood", n=100)
>>> def evaluate(s_values, bootstrap):           # a parabola with its minimum at 1.4
...     return [{"score": (s - 1.4) ** 2, "sigma": [1.0], "boot": None} for s in s_values]
>>> res = run_searches([search], lambda wanted: [search.add(s, c) for s, c in
...                    zip(wanted[0], evaluate(wanted[0], None))])[0]
>>> round(res.s, 9), [round(x, 4) for x in res.s_interval]
(1.4, [1.2614, 1.5386])
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

from envfit.base import ParameterError

__all__ = ["S_GRID", "DEFAULT_REFINE", "CHI2_1_95", "EDGE_LO", "EDGE_HI", "WALK_BATCH",
           "SearchResult", "SmoothnessSearch", "run_searches", "lattice", "search_lattice",
           "bootstrap_argmin_interval"]

#: the coarse grid the criterion is evaluated on before the refinement
S_GRID = tuple(np.round(np.arange(1.05, 1.96, 0.075), 4))
#: the lattice refines the grid's step this many times
DEFAULT_REFINE = 3
CHI2_1_95 = 3.841458820694124
#: the ends of (1, 2) as the search evaluates them
EDGE_LO, EDGE_HI = 1.0 + 1e-6, 2.0 - 1e-6
#: lattice points requested per side and round while looking for the interval's ends
WALK_BATCH = 4


@dataclass
class SearchResult:
    """The outcome of one :class:`SmoothnessSearch`."""
    s: float
    s_interval: tuple[float, float]
    #: σ̂ per channel at ŝ, from the spline of log σ̂ through the lattice values
    sigma: list[float]


def lattice(grid: Sequence[float], refine: int) -> np.ndarray:
    """The grid refined ``refine`` times (same origin), inside (1, 2), plus both edges.

    >>> lattice([1.2, 1.5, 1.8], 1)[:3].tolist()
    [1.000001, 1.2, 1.5]
    """
    g = np.asarray(grid, dtype=float)
    h = (g[1] - g[0]) / refine if len(g) > 1 else 0.075 / refine
    j = np.arange(int(np.floor((1.0 - g[0]) / h)) - 1, int(np.ceil((2.0 - g[0]) / h)) + 2)
    pts = np.round(g[0] + j * h, 10)
    pts = pts[(pts > EDGE_LO) & (pts < EDGE_HI)]
    return np.concatenate([[EDGE_LO], pts, [EDGE_HI]])


def search_lattice(s_grid: Sequence[float], refine: int) -> tuple[list[float], np.ndarray]:
    """``(grid, lattice)``: the checked grid as the lattice's own floats, and the lattice.

    ``s_grid`` must be uniform and increasing with 3 or more values, ``refine`` ≥ 1
    (:class:`~envfit.base._errors.ParameterError` otherwise).
    """
    grid = [float(s) for s in s_grid]
    if len(grid) < 3 or not np.allclose(np.diff(grid), grid[1] - grid[0]) or grid[1] <= grid[0]:
        raise ParameterError("the s search needs a uniform, increasing s grid of 3 or more values")
    if int(refine) < 1:
        raise ParameterError(f"refine must be at least 1, got {refine}")
    lat = lattice(grid, int(refine))
    return [float(lat[np.argmin(np.abs(lat - g))]) for g in grid], lat


def bootstrap_argmin_interval(grid, means: np.ndarray) -> tuple[float, float]:
    """95 % percentile interval of the per-resample argmin over ``grid`` of ``means``
    (n_bootstrap, len(grid)), each argmin refined by a parabola through its neighbours."""
    grid = np.asarray(grid, dtype=float)
    n_bootstrap = means.shape[0]
    k = np.argmin(means, axis=1)
    s_star = np.empty(n_bootstrap)
    for b in range(n_bootstrap):                  # parabolic refinement of each argmin
        j = int(np.clip(k[b], 1, len(grid) - 2))
        y0, y1, y2 = means[b, j - 1:j + 2]
        den = y0 - 2 * y1 + y2
        off = 0.5 * (y0 - y2) / den if den > 0 else 0.0
        s_star[b] = grid[j] + np.clip(off, -1, 1) * (grid[1] - grid[0])
    return float(np.percentile(s_star, 2.5)), float(np.percentile(s_star, 97.5))


class SmoothnessSearch:
    """The lattice search of one map (module docstring).

    Parameters
    ----------
    method : ``"likelihood"``, ``"loo"`` or ``"holdout"`` (the interval's kind).
    n : the number of samples (the likelihood's score is the log-likelihood over ``n``).
    s_grid, refine : the coarse grid and its refinement (:func:`search_lattice`).

    Attributes
    ----------
    ev : dict
        s → the criterion's cell there (``score``, ``sigma``, and ``boot`` at grid points
        for loo/holdout); filled by :meth:`add`, possibly ahead (resumed cells).
    """

    def __init__(self, method: str, n: int, s_grid: Sequence[float] = S_GRID,
                 refine: int = DEFAULT_REFINE):
        self.method, self.n = method, int(n)
        self.grid, self.lat = search_lattice(s_grid, refine)
        self._grid_set = set(self.grid)
        self.ev: dict[float, dict] = {}

    def add(self, s: float, cell: dict) -> None:
        """Record the criterion's ``cell`` at ``s`` (a value :meth:`requests` returned)."""
        self.ev[float(s)] = cell

    def needs_bootstrap(self, s: float) -> bool:
        """Whether the cell at ``s`` must carry the bootstrap means (loo/holdout, grid)."""
        return self.method != "likelihood" and float(s) in self._grid_set

    def requests(self) -> list[float]:
        """The s values this search still needs (empty: :meth:`result` is ready)."""
        missing = [s for s in self.grid if s not in self.ev]
        if missing:
            return missing
        inner = self._inner()
        missing = [s for s in inner if s not in self.ev]
        if missing or self.method != "likelihood":
            return missing
        s_hat, target = self._target(inner)
        return [*self._walk(s_hat, target, -1)[1], *self._walk(s_hat, target, +1)[1]]

    def result(self) -> SearchResult:
        """ŝ, its 95 % interval and σ̂ at ŝ (every request answered)."""
        inner = self._inner()
        if self.method == "likelihood":
            run, s_hat, interval = self._profile_interval(inner)
        else:
            run = inner
            s_hat = self._minimum(run, inner[0], inner[-1])[0]
            means = np.array([self.ev[s]["boot"] for s in self.grid]).T
            b_lo, b_hi = bootstrap_argmin_interval(self.grid, means)
            interval = (min(b_lo, s_hat), max(b_hi, s_hat))
        return SearchResult(s=s_hat, s_interval=(float(interval[0]), float(interval[1])),
                            sigma=self._sigma_at(run, s_hat))

    def curve(self) -> list[dict]:
        """Every evaluation, ``{"s", "score"}`` in increasing s."""
        return [{"s": float(s), "score": float(c["score"])} for s, c in sorted(self.ev.items())]

    # -- the steps ------------------------------------------------------------------
    def _score(self, s: float) -> float:
        return self.ev[s]["score"]

    def _bracket(self) -> tuple[float, float]:
        k = int(np.argmin([self._score(s) for s in self.grid]))
        lo = self.grid[k - 1] if k > 0 else EDGE_LO
        hi = self.grid[k + 1] if k < len(self.grid) - 1 else EDGE_HI
        return lo, hi

    def _inner(self) -> list[float]:
        """Lattice points of the bracket, strictly inside (1, 2) (the edges are evaluated
        only when an interval reaches them)."""
        lo, hi = self._bracket()
        return [float(s) for s in self.lat if lo <= s <= hi and EDGE_LO < s < EDGE_HI]

    def _spline(self, run: Sequence[float]) -> CubicSpline:
        from scipy.interpolate import CubicSpline  # local: ~0.1 s to import

        return CubicSpline(np.asarray(run), np.array([self._score(s) for s in run]))

    def _minimum(self, run, lo: float, hi: float) -> tuple[float, float]:
        """(s, value) of the minimum on [lo, hi] of the spline through ``run``."""
        cs = self._spline(run)
        cand = [lo, hi, *[float(r) for r in cs.derivative().roots(extrapolate=False)
                          if lo <= r <= hi]]
        vals = cs(np.array(cand))
        k = int(np.argmin(vals))
        return float(cand[k]), float(vals[k])

    def _target(self, inner) -> tuple[float, float]:
        """(ŝ on the bracket, the score where 2N (score − score(ŝ)) = χ²₁,₀.₉₅)."""
        s_hat, best = self._minimum(inner, inner[0], inner[-1])
        return s_hat, best + CHI2_1_95 / (2 * self.n)

    def _walk(self, s_hat: float, target: float, side: int) -> tuple[float | None, list[float]]:
        """(outermost lattice point needed on this side, or None; points still to evaluate)."""
        outer = self.lat[self.lat < s_hat][::-1] if side < 0 else self.lat[self.lat > s_hat]
        for pos, s in enumerate(outer):
            if s not in self.ev:
                return None, [float(x) for x in outer[pos:pos + WALK_BATCH] if x not in self.ev]
            if self._score(s) > target:
                return float(s), []
        return float(outer[-1]) if len(outer) else s_hat, []

    def _profile_interval(self, inner) -> tuple[list[float], float, tuple[float, float]]:
        """(the lattice run used, ŝ, the profile-likelihood interval)."""
        s_hat, target = self._target(inner)
        left = self._walk(s_hat, target, -1)[0]
        right = self._walk(s_hat, target, +1)[0]
        run = [float(s) for s in self.lat
               if min(left, inner[0]) <= s <= max(right, inner[-1])]
        s_hat = self._minimum(run, inner[0], inner[-1])[0]
        from scipy import optimize  # local: ~0.1 s to import

        cs = self._spline(run)
        f = lambda x: float(cs(x)) - target  # noqa: E731
        lo_s = left if f(left) <= 0 else optimize.brentq(f, left, s_hat, xtol=1e-6)
        hi_s = right if f(right) <= 0 else optimize.brentq(f, s_hat, right, xtol=1e-6)
        return run, s_hat, (float(lo_s), float(hi_s))

    def _sigma_at(self, run, s: float) -> list[float]:
        """σ̂ per channel at ``s``: the spline through ``run`` of log σ̂ + ½ log(2 − s) (σ̂
        grows as (2 − s)^(−1/2) towards s = 2, where the kernel's coefficients a_l, l ≥ 1,
        vanish with 1/Γ(1 − s), Eq. 16; without the term the spline is off by 1e-2 at
        s = 1.91), or of σ̂ itself (≥ 0) for a channel with σ̂ = 0 somewhere (constant)."""
        from scipy.interpolate import CubicSpline  # local: ~0.1 s to import

        x = np.asarray(run, dtype=float)
        sig = np.array([self.ev[r]["sigma"] for r in run], dtype=float).reshape(len(run), -1)
        out = []
        for col in sig.T:
            if np.all(col > 0):
                y = np.log(col) + 0.5 * np.log(2.0 - x)
                out.append(float(np.exp(CubicSpline(x, y)(s) - 0.5 * np.log(2.0 - s))))
            else:
                out.append(max(float(CubicSpline(x, col)(s)), 0.0))
        return out


def run_searches(searches: Sequence[SmoothnessSearch],
                 evaluate_round: Callable[[dict[int, list[float]]], None]) -> list[SearchResult]:
    """Drive ``searches`` to their results, round after round.

    Each round collects every search's :meth:`~SmoothnessSearch.requests` as ``{index: [s,
    …]}`` and calls ``evaluate_round`` with it, which must :meth:`~SmoothnessSearch.add` a
    cell for each (a library evaluates each distinct s once for all maps that ask for it).
    """
    while True:
        wanted = {i: r for i, sr in enumerate(searches) if (r := sr.requests())}
        if not wanted:
            return [sr.result() for sr in searches]
        evaluate_round(wanted)

r"""An importance density over shading axes, for measuring an RMSE over *uniform* axes.

The RMSE a renderer sees across normals is :math:`(\mathbb E_a\,d(a))^{1/2}` over uniform
axes a, with :math:`d(a)` an estimator's mean squared error at axis a. On a linear map with a
sun, :math:`d` is heavy-tailed over the sphere: the few axes whose lobe catches the sun hold
most of the mean, so a uniform sample of M axes usually holds too few of them and
:math:`\frac1M\sum d(a_m)` is skewed — below the mean in most runs, far above it in a few.
Importance sampling the axes (Owen 2013, ch. 9) draws :math:`a_m \sim q` and weights each by
:math:`w(a) = u(a)/q(a)`, :math:`u = 1/4\pi`:

.. math:: \widehat{\mathrm{MSE}} = \frac1M\sum_m w(a_m)\,d(a_m), \qquad
          \mathbb E_q\,[w\,d] = \mathbb E_u\,[d],

unbiased for any q that is positive wherever u is, and far less variable when q follows d.

:class:`AxisProposal` is the defensive mixture (Hesterberg 1995)

.. math:: q = \tfrac13\,u + \tfrac13\,q_\mathrm{brdf} + \tfrac13\,q_\mathrm{map},

whose weights are bounded by 3 whatever the map (so the estimate is never worse than 3×
the uniform one's variance), with :math:`q_\mathrm{brdf}, q_\mathrm{map}` piecewise constant
on an equal-area grid of R × 2R cells over the sphere (rows uniform in cos θ of the map's
frame, columns uniform in φ), each cell's mass proportional to a proxy of the squared error
of BRDF and map sampling at its centre (:func:`envfit.sampling._proxies.proxy_second_moments`:
:math:`\int\rho_a L^2` and :math:`\int\rho_a^2 L^2/p` by a block quadrature of the map).
A draw picks a component, then a cell, then a point uniform in the cell (uniform in cos θ
and φ within it: uniform in solid angle).

References
----------
A. B. Owen, *Monte Carlo theory, methods and examples*, 2013, ch. 9 (importance sampling).
T. Hesterberg, "Weighted average importance sampling and defensive mixture distributions",
Technometrics 37(2), 1995.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.shading._ground_truth import weight_function
>>> from envfit.sampling._map_sampler import MapSampler
>>> m = EnvMap(np.ones((8, 16, 1)), up="z")
>>> q = AxisProposal.of(m, MapSampler(m), weight_function("diffuse", 30.0), rows=4)
>>> axes, w = q.draw(np.random.default_rng(0), 5)
>>> axes.shape, bool(np.all(np.abs(w - 1.0) < 0.05))     # a constant map: q near uniform
((5, 3), True)
>>> bool(w.max() <= 1.0 / UNIFORM_SHARE)                   # the defensive bound
True
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.maps import local_to_world, rows_dot, rows_times
from envfit.maps import EnvMap

__all__ = ["AxisProposal", "UNIFORM_SHARE", "PROPOSAL_ROWS"]

#: the uniform component's share of the mixture: the weights are at most 1/UNIFORM_SHARE
UNIFORM_SHARE = 1.0 / 3.0
#: rows R of the proposal's cell grid (R × 2R equal-area cells; 0.065 rad at R = 48)
PROPOSAL_ROWS = 48


@dataclass(frozen=True)
class AxisProposal:
    r"""A mixture density over unit axes: a share ``uniform`` of the uniform density and the
    rest piecewise constant on ``rows`` × 2·``rows`` equal-area cells with probabilities
    ``cell_mass`` (sum 1), cells in the frame of a map with up axis ``up``.

    ``relative_density(a)`` is :math:`4\pi q(a)`; ``draw(rng, M)`` returns M axes of q and
    their weights :math:`1/(4\pi q)`, whose mean under q is 1.
    """

    up: str
    rows: int
    cell_mass: np.ndarray
    uniform: float = UNIFORM_SHARE

    def __post_init__(self):
        mass = np.asarray(self.cell_mass, dtype=np.float64).ravel()
        r = check_int(self.rows, "rows", 1)
        if mass.shape != (2 * r * r,) or not np.all(np.isfinite(mass)) or np.any(mass < 0):
            raise ParameterError(f"cell_mass must be {2 * r * r} finite values >= 0")
        if not mass.sum() > 0:
            raise ParameterError("cell_mass must not be all zero")
        if not 0.0 < float(self.uniform) <= 1.0:
            raise ParameterError(f"uniform must be in (0, 1], got {self.uniform!r}")
        local_to_world(self.up)                      # checks up
        object.__setattr__(self, "cell_mass", mass / mass.sum())

    @classmethod
    def uniform_density(cls, up: str = "z", rows: int = 1) -> "AxisProposal":
        """The uniform density (weights 1), as a proposal."""
        return cls(up, rows, np.ones(2 * rows * rows), 1.0)

    @classmethod
    def of(cls, envmap: EnvMap, sampler, weight, *, rows: int = PROPOSAL_ROWS) -> "AxisProposal":
        r"""The module's mixture for a map, its sampler and a lobe: a third uniform, a third
        :math:`\propto\int\rho_a L^2` (BRDF sampling's second moment), a third
        :math:`\propto\int\rho_a^2 L^2/p` (map sampling's), at the cell centres."""
        from envfit.sampling import normalised_moments, proxy_second_moments

        r = check_int(rows, "rows", 1)
        moments = proxy_second_moments(envmap, sampler, weight, cell_centres(r, envmap.up))
        return cls(envmap.up, r, sum(normalised_moments(moments)), UNIFORM_SHARE)

    @property
    def cells(self) -> int:
        return 2 * self.rows * self.rows

    def cell_of(self, axes) -> np.ndarray:
        """The cell index of each axis (..., 3)."""
        a = np.asarray(axes, dtype=np.float64)
        m = local_to_world(self.up)
        z = np.clip(rows_dot(a, m[:, 2]) / np.linalg.norm(a, axis=-1), -1.0, 1.0)
        phi = np.mod(np.arctan2(rows_dot(a, m[:, 1]), rows_dot(a, m[:, 0])),
                     2.0 * np.pi)
        r = self.rows
        row = np.minimum(((1.0 - z) * 0.5 * r).astype(np.int64), r - 1)
        col = np.minimum((phi * (r / np.pi)).astype(np.int64), 2 * r - 1)
        return row * (2 * r) + col

    def relative_density(self, axes) -> np.ndarray:
        r""":math:`4\pi q(a)` at each axis: ``uniform`` + (1 − ``uniform``)·cells·mass(cell)."""
        return self.uniform + (1.0 - self.uniform) * self.cells * self.cell_mass[self.cell_of(axes)]

    def draw(self, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
        """``count`` i.i.d. axes of q (world frame) and their weights 1/(4π q)."""
        n = check_int(count, "count", 0)
        r = self.rows
        from_cells = rng.random(n) >= self.uniform
        cell = np.where(from_cells, rng.choice(self.cells, size=n, p=self.cell_mass),
                        rng.integers(0, self.cells, size=n))     # uniform = a uniform cell
        row, col = np.divmod(cell, 2 * r)
        z = 1.0 - 2.0 * (row + rng.random(n)) / r
        phi = np.pi * (col + rng.random(n)) / r
        s = np.sqrt(np.maximum(1.0 - z * z, 0.0))
        local = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)
        axes = rows_times(local, local_to_world(self.up).T)
        return axes, 1.0 / self.relative_density(axes)


def cell_centres(rows: int, up: str = "z") -> np.ndarray:
    """The centres (rows · 2 rows, 3) of the equal-area cells, in the order of
    :meth:`AxisProposal.cell_of`, world frame of a map with up axis ``up``."""
    r = check_int(rows, "rows", 1)
    z = 1.0 - 2.0 * (np.arange(r) + 0.5) / r
    phi = np.pi * (np.arange(2 * r) + 0.5) / r
    s = np.sqrt(1.0 - z * z)
    local = np.stack(np.broadcast_arrays(s[:, None] * np.cos(phi)[None, :],
                                         s[:, None] * np.sin(phi)[None, :], z[:, None]),
                     axis=-1).reshape(-1, 3)
    return rows_times(local, local_to_world(up).T)

r"""The stored quadrature cells of ``envfit validate``: their keys, the measured statistics
they keep, whether a stored one is current, and the :class:`envfit.predict.QuadratureRule` one gives.

A cell is one (BRDF, point set, weighting, N): the measured RMSE over the axes (total and
per channel, its relative standard error, the errors' kurtosis), the worst-case error per
candidate s (``wce``, keyed by :func:`envfit.base._keys.s_key`), the band-limited one per s without the
lookup transfer (``wce_bandlimited_by_s``), the rule's error power per degree to the map's
band limit (``error_power``), :math:`\sum_j w_j` (``weight_sum``), the seconds it cost, and
``error`` (the message when the weights could not be computed; every value None then).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import s_key
from envfit.predict import QuadratureRule
from envfit.shading import rmse_over_axes

from envfit.validate._config import ALL_POINTSETS, BRDF_INDEX

__all__ = ["cell_key", "twist_seed", "error_stats", "cell_is_current", "rule_from_cell"]


def cell_key(brdf: str, pointset: str, weights: str, n: int) -> str:
    """The store key of a quadrature cell.

    >>> cell_key("glossy", "sf", "osw", 64)
    'quad_glossy_sf_osw_64'
    """
    return f"quad_{brdf}_{pointset}_{weights}_{n}"


def twist_seed(seed: int, brdf: str, pointset: str, n: int) -> list[int]:
    """The seed of the twists about the axes of one (BRDF, point set, N) (both weightings)."""
    return [int(seed), 12, BRDF_INDEX[brdf], ALL_POINTSETS.index(pointset), int(n)]


def error_stats(est: np.ndarray, truth: np.ndarray) -> dict:
    """RMSE (total, per channel), its relative standard error over axes, and the kurtosis.

    >>> st = error_stats(np.array([[1.0], [3.0]]), np.array([[0.0], [0.0]]))
    >>> st["measured_rmse"] == 5.0 ** 0.5, st["error_kurtosis"]
    (True, 1.64)
    """
    r = rmse_over_axes(est, truth)
    e2 = ((est - truth) ** 2).mean(axis=1)                         # per axis, mean over channels
    m = e2.size
    mean = float(e2.mean())
    rel_se = float(e2.std(ddof=1) / (2.0 * math.sqrt(m) * mean)) if mean > 0 and m > 1 else None
    e = (est - truth).ravel()
    var = float(np.mean(e * e))
    kurt = float(np.mean(e ** 4) / var ** 2) if var > 0 else None
    return {"measured_rmse": float(r.total), "measured_rmse_channels": r.per_channel.tolist(),
            "measured_rel_se": rel_se, "error_kurtosis": kurt}


def cell_is_current(cell: dict | None, band_lmax: int, s_keys) -> bool:
    """Whether a stored cell can be reused: same band limit, an error power, and the
    worst-case errors (plain and band-limited) for every s of ``s_keys``.

    >>> cell_is_current({"band_lmax": 7, "error_power": [0.0], "wce": {"1.5000": 0.1},
    ...                  "wce_bandlimited_by_s": {"1.5000": 0.1}}, 7, ["1.5000"])
    True
    """
    return (cell is not None and cell.get("band_lmax") == band_lmax and "error_power" in cell
            and all(k in cell.get("wce", {}) and k in cell.get("wce_bandlimited_by_s", {})
                    for k in s_keys))


def rule_from_cell(cell: dict, s_used: float) -> QuadratureRule:
    """The :class:`envfit.predict.QuadratureRule` of a stored cell: N, the wce at ``s_used``, the error
    power and :math:`\\sum_j w_j` (None in a cell whose weights failed).

    >>> r = rule_from_cell({"n": 16, "wce": {"1.5000": 0.2}, "error_power": [0.0, 1.0],
    ...                     "weight_sum": 1.0}, 1.5)
    >>> r.n, r.wce, r.weight_sum
    (16, 0.2, 1.0)
    """
    return QuadratureRule(n=int(cell["n"]), wce=cell["wce"].get(s_key(s_used)),
                error_power=cell.get("error_power"), weight_sum=cell.get("weight_sum"))

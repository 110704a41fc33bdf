r"""The predicted error of a Cranley–Patterson-shifted estimator with a given point set, from a
warped spectrum: the sums over frequency space.

With the warped integrands' coefficients :math:`\hat h_i(k)` and the parts' point sets'
exponential sums :math:`S_i(k) = \frac1{n_i}\sum_j e^{2\pi i k\cdot u_{ij}}` (:func:`_exp_sums`,
one non-uniform FFT per set),

.. math:: \mathbb E_\Delta (F-I)^2 = \sum_{k\ne 0}\Big|\sum_i \hat h_i(k)S_i(k)\Big|^2

(Parseval on the torus; Cranley & Patterson 1976; for a lattice the classical variance of a
randomly shifted lattice rule, Sloan & Joe 1994, Lemma 2.3), split into

* ``box`` — :math:`\sum_i\sum_{|k_0|,|k_1|\le B}|\hat h_i|^2|S_i|^2`, plus for MIS the cross
  term :math:`2\,\mathrm{Re}\sum_{k_0}\hat h_1\overline{\hat h_2}S_1\overline{S_2}` on the
  column :math:`k_1 = 0` (the twist of the lobe's frame removes the others);
* ``tail`` — the power above the box, :math:`\max(V_i - \sum_{box}|\hat h_i|^2, 0)`: on the
  strips beside the frequency axes continued with the set's own sums, the rest at the Monte
  Carlo weight :math:`1/n_i` (:func:`envfit.predict.warped._spectral_tail.strip_tail`);
* ``random`` — :math:`\sum_i V_i/n_i`, what i.i.d. points would give.

References: R. Cranley, T. N. L. Patterson, SIAM J. Numer. Anal. 13 (1976); I. H. Sloan,
S. Joe, *Lattice Methods for Multiple Integration* (1994).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError
from envfit.sampling import square_samples
from envfit.predict.warped._spectral_tail import strip_tail
from envfit.predict.warped._techniques import TECHNIQUES

__all__ = ["STRIPS_NEGLIGIBLE", "random_mse", "shifted_mse_terms", "shifted_rmse"]

#: the strips of the tail are skipped where the power above the box at 1/n is below this
#: fraction of the part's box term (the prediction then moves by less than it)
STRIPS_NEGLIGIBLE = 1e-3


def _box_sum(half: np.ndarray) -> float:
    """Sum over the full box of a symmetric quantity given on its half k₁ ≥ 0."""
    return float(half[:, 0].sum() + 2.0 * half[:, 1:].sum())


def _exp_sums(u: np.ndarray, band: int) -> np.ndarray:
    r""":math:`S(k) = \frac1n\sum_j e^{2\pi i k\cdot u_j}` on the half box (2B+1, B+1)."""
    import ducc0

    n = u.shape[0]
    size = 2 * band + 2                                    # modes −B−1 … B
    out = np.zeros((size, size), dtype=np.complex128)
    ducc0.nufft.nu2u(points=np.ones(n, dtype=np.complex128), coord=2.0 * np.pi * u,
                     forward=False, epsilon=1e-10, out=out, nthreads=1)
    return out[1:, band + 1:] / n


def _split_points(spec, u) -> list[np.ndarray]:
    """The point sets of the parts: one set; for MIS the first round(ν₁N) points and the rest,
    or a given pair (u_map, u_brdf) (as :func:`envfit.sampling.mis_estimates`)."""
    if TECHNIQUES[spec.technique] == 1:
        return [square_samples(u)]
    if isinstance(u, (tuple, list)) and len(u) == 2 and np.ndim(u[0]) == 2:
        parts = [square_samples(u[0], "u_map"), square_samples(u[1], "u_brdf")]
    else:
        U = square_samples(u)
        n1 = int(np.floor(spec.fraction * U.shape[0] + 0.5))
        parts = [U[:n1], U[n1:]]
    if min(p.shape[0] for p in parts) == 0:
        raise ParameterError("MIS needs at least one point for each technique")
    return parts


def shifted_mse_terms(spec, u) -> dict:
    r"""The terms of the predicted mean squared error of the shifted estimator with the
    points u (a pair (u_map, u_brdf) for MIS) and the spectrum ``spec``
    (:class:`envfit.predict.renderer.WarpedSpectrum`): ``box``
    :math:`\sum_i\sum_{box}|\hat h_i|^2|S_i|^2` (+ the MIS cross term), ``tail`` the power
    above the box, :math:`\max(V_i - \sum_{box}|\hat h_i|^2, 0)`, with the strips along the
    axes continued with the set's sums and the rest at 1/n_i
    (:func:`envfit.predict.warped._spectral_tail.strip_tail`), ``random``
    :math:`\sum_i V_i/n_i` (what i.i.d. points would give)."""
    pts = _split_points(spec, u)
    box = tail = rnd = 0.0
    S = []
    for i, p in enumerate(pts):
        n = p.shape[0]
        s = _exp_sums(p, spec.band)
        S.append(s)
        part_box = _box_sum(spec.power[i] * np.abs(s) ** 2)
        box += part_box
        above = strip_tail(spec.power[i], float(spec.variance[i]), p,
                           negligible=STRIPS_NEGLIGIBLE * part_box, fits=spec.strip_fits[i])
        tail += above["strips"] + above["rest"]
        rnd += float(spec.variance[i]) / n
    if len(S) == 2:
        box += 2.0 * float(np.real(spec.cross * S[0][:, 0] * np.conj(S[1][:, 0])).sum())
    return {"box": box, "tail": tail, "random": rnd}


def random_mse(spec, u) -> float:
    r"""The Monte Carlo variance :math:`\sum_i V_i/n_i` of i.i.d. points of the sizes of u
    (``random`` of :func:`shifted_mse_terms`, without the exponential sums)."""
    return float(sum(float(v) / p.shape[0] for v, p in zip(spec.variance, _split_points(spec, u))))


def shifted_rmse(spec, u) -> float:
    r"""Predicted RMSE over uniform axes, channels, shifts and twists of the estimator
    ``spec.technique`` with the square points u (any set; a pair (u_map, u_brdf) for MIS):
    :math:`(\text{box} + \text{tail})^{1/2}` of :func:`shifted_mse_terms`.

    >>> import numpy as np
    >>> from envfit.maps import EnvMap
    >>> from envfit.predict.warped._warped_spectrum import warped_spectrum
    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> shifted_rmse(warped_spectrum(m, "brdf", grid=16, axes=4), np.full((4, 2), 0.3))
    0.0
    """
    t = shifted_mse_terms(spec, u)
    return math.sqrt(max(t["box"] + t["tail"], 0.0))

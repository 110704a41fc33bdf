"""envfit.predict.warped._spectral_tail: the power above the box on the strips beside the frequency
axes, continued with the set's own sums, against the direct sum of |ĥ|²|S|² to 2·10⁶ for
integrands whose whole spectrum lies on the axes (h = u₀, h = u₁ + u₁², jumps at the square's
edge), and unchanged (within the strips' small share) for an isotropic spectrum.
"""
from __future__ import annotations

import numpy as np
import pytest

from envfit.predict.warped._spectral_tail import strip_tail
from envfit.predict.warped._prediction_sums import _box_sum, _exp_sums
from envfit.theory._pointsets import square_points

B = 32
K_DIRECT = 1 << 21


def _line_power(k, which):
    """|ĥ(k)|² on an axis of h = u₀ (which 0) or h = u₁ + u₁² (which 1), k ≠ 0."""
    k = np.asarray(k, dtype=np.float64)
    if which == 0:                 # ∫ x e^{-2πikx} dx = i/(2πk)
        return 1.0 / (4 * np.pi ** 2 * k ** 2)
    # x + x²: i/(2πk) + (1/(2π²k²) + i/(2πk)) = 1/(2π²k²) + i/(πk)
    return (1.0 / (2 * np.pi ** 2 * k ** 2)) ** 2 + 1.0 / (np.pi ** 2 * k ** 2)


def _variance(which):
    return 1.0 / 12.0 if which == 0 else 1.0 / 5 + 2.0 / 4 + 1.0 / 3 - (1.0 / 2 + 1.0 / 3) ** 2


def _half_box(which):
    P = np.zeros((2 * B + 1, B + 1))
    k = np.arange(-B, B + 1)
    if which == 0:
        P[:, 0] = np.where(k != 0, _line_power(np.where(k != 0, k, 1), 0), 0.0)
    else:
        P[B, 1:] = _line_power(np.arange(1, B + 1), 1)      # k = (0, k₁), k₁ > 0 (half box)
    return P


def _direct(u, which):
    """Σ_{k≠0, |k| ≤ K} |ĥ|²|S|² on the axis, by a 1-D non-uniform FFT of the set's coordinate."""
    import ducc0
    x = np.ascontiguousarray(2 * np.pi * u[:, which:which + 1])
    s = np.zeros(2 * K_DIRECT + 2, dtype=np.complex128)
    ducc0.nufft.nu2u(points=np.ones(len(u), dtype=np.complex128), coord=x, forward=False,
                     epsilon=1e-11, out=s, nthreads=1)
    s = s[1:] / len(u)
    k = np.arange(-K_DIRECT, K_DIRECT + 1)
    nz = k != 0
    return float(np.sum(_line_power(k[nz], which) * np.abs(s[nz]) ** 2))


@pytest.mark.parametrize("which", [0, 1])
@pytest.mark.parametrize("pointset,n", [("sf", 256), ("sf", 1024), ("sobol", 1024),
                                        ("random", 1024)])
def test_strips_reproduce_the_direct_sum(which, pointset, n):
    u = square_points(pointset, n, seed=3)
    P = _half_box(which)
    box = _box_sum(P * np.abs(_exp_sums(u, B)) ** 2)
    t = strip_tail(P, _variance(which), u)
    exact = _direct(u, which)
    assert t["strip_power"] == pytest.approx(t["above"], rel=1e-3)   # all of it on a strip
    predicted = box + t["strips"] + t["rest"]
    assert predicted == pytest.approx(exact, rel=0.03), (predicted, exact)
    old = box + t["above"] / n                     # the power above the box at 1/n
    if pointset != "random":
        assert abs(old / exact - 1) > 0.3          # which the strips correct


def test_isotropic_spectrum_is_nearly_unchanged():
    k0 = np.arange(-B, B + 1)[:, None]
    k1 = np.arange(0, B + 1)[None, :]
    r2 = (k0 ** 2 + k1 ** 2).astype(float)
    P = np.where(r2 > 0, 1.0 / np.maximum(r2, 1) ** 2, 0.0)
    box_power = P[:, 0].sum() + 2 * P[:, 1:].sum()
    above = 2 * np.pi * 0.5 / B ** 2                     # ∫_{|k|>B} |k|^-4 d²k, roughly
    u = square_points("sobol", 1024)
    t = strip_tail(P, box_power + above, u)
    assert t["above"] == pytest.approx(above)
    assert t["strip_power"] < 0.1 * above             # 14 rays of a 2-D spectrum
    assert (t["strips"] + t["rest"]) == pytest.approx(above / 1024, rel=0.1)


def test_small_box_falls_back_to_the_monte_carlo_weight():
    P = np.zeros((7, 4))
    P[:, 0] = [0.01, 0.02, 0.1, 0.0, 0.1, 0.02, 0.01]
    t = strip_tail(P, 1.0, square_points("sf", 64))
    assert t == {"strips": 0.0, "rest": (1.0 - 0.26) / 64, "strip_power": 0.0,
                 "above": pytest.approx(0.74)}


def test_negligible_power_above_the_box_skips_the_strips():
    u = square_points("sf", 1024)
    P = _half_box(0)
    full = strip_tail(P, _variance(0), u)
    assert full["strips"] > 0 and full["rest"] == pytest.approx(0.0, abs=1e-15)
    skipped = strip_tail(P, _variance(0), u, negligible=full["above"] / 1024)
    assert skipped["strips"] == 0.0 and skipped["rest"] == pytest.approx(full["above"] / 1024)
    kept = strip_tail(P, _variance(0), u, negligible=0.99 * full["above"] / 1024)
    assert kept == full

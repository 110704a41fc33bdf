"""The built-in default map: a synthesized map of known smoothness, so every command runs
without a file. It is a Gaussian-process sample with covariance K_gd^(1.5) (data_gen),
RGB, 256×512, made positive by a constant offset (a constant only changes the l = 0 term).
Its spectrum is exactly :math:`a_l^{(1.5)}` for l ≤ 255 (the grid's Nyquist degree) and zero
above, and Table 2 reads it through the bilinear lookup (resized for ``--quick``): at the
pixel scale it is smoother than :math:`K_{1.5}`, so Table 2's best s on it is expected above
1.5 (:mod:`envfit.fit._kriging` gives the expected optimum; ``envfit table2`` prints it).
"""
from __future__ import annotations

import numpy as np

from envfit.maps._envmap import EnvMap

DEFAULT_S0 = 1.5
DEFAULT_HEIGHT = 256
DEFAULT_SEED = 0


def default_envmap(*, up: str = "y", height: int = DEFAULT_HEIGHT) -> EnvMap:
    """The built-in synthesized map (deterministic)."""
    from envfit.data_gen import gaussian_process_map
    f = gaussian_process_map(DEFAULT_S0, height, seed=DEFAULT_SEED, channels=3)
    # offset so that every pixel is positive (a radiance map), with a 10% margin
    f = f - f.min() + 0.1 * (f.max() - f.min())
    return EnvMap(np.asarray(f, dtype=np.float32), up=up,
                  name=f"builtin:gp(s0={DEFAULT_S0},height={height},seed={DEFAULT_SEED})")

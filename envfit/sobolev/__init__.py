r"""The Sobolev kernel K_gd on the sphere: interpolation (Cholesky + near/far fast summation),
the band-limited kernel, and their numba hot loops.

Modules:

* ``_bandlimited_kernels`` (private) — Numba loop behind :mod:`envfit.sobolev._bandlimited`:
  a kernel matrix from a table in the angle.
* ``_interpolation_kernels`` (private) — Numba kernels behind :mod:`envfit.sobolev._interpolation` (the hot
  loops of envfit).
* :mod:`~envfit.sobolev._bandlimited` — The generalized distance kernel band-limited to a
  map's resolution, and the Gaussian-process likelihood of s and σ under it.
* :mod:`~envfit.sobolev._interpolation` — Kernel interpolation of scattered samples on the
  sphere with the generalized distance kernel.
* :mod:`~envfit.sobolev._kernel_nodes` — The kernel on a node set: the nodes as the numba
  kernels read them, the kernel matrix factorised in place, and the power sums that evaluate
  an interpolant (direct or near/far).
* :mod:`~envfit.sobolev._iterative` — Preconditioned conjugate gradients for the Sobolev
  kernel system :math:`K\alpha = f` without the N x N matrix: O(N log N) products, O(N k)
  memory.
* :mod:`~envfit.sobolev._likelihood` — The Gaussian-process log-likelihood with the scale
  profiled out, implemented once.
* :mod:`~envfit.sobolev._nearfar` — The near/far split that evaluates kernel sums in O(N log
  N): the kernel's power part :math:`g(t) = (2 - 2t)^{s-1}` outside a cap of chordal radius
  δ is a polynomial :math:`P_L(t)`, i.e. an SH convolution (ducc0), and pairs closer than δ
  get the exact correction :math:`g - P_L` from a 3-D cell list (see
  :mod:`envfit.sobolev._interpolation`).

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "ProfiledLikelihood": "_interpolation", "SobolevInterpolator": "_interpolation",
    "SolveInfo": "_interpolation",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "bandlimited_log_likelihood": "_bandlimited",
    "map_band_limit": "_bandlimited",
    "max_samples": "_bandlimited",
    "pixel_centre_samples": "_bandlimited",
    "profiled_log_likelihood": "_likelihood",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})

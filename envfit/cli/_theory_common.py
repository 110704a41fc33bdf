"""What the ``envfit theory`` sub-subcommands share: argument checks, help texts, progress.

A helper module of :mod:`envfit.cli._theory` (not a subcommand of its own).
"""
from __future__ import annotations

import math

from envfit.base import ParameterError
from envfit.cli._ranges import Ranged
from envfit.defaults import DEFAULT_SHININESS

#: the ranges of theory's options (``--help`` and the errors say these words)
S_RANGE = Ranged(1, 2, "s", integer=False, lo_open=True, hi_open=True)
SHININESS_RANGE = Ranged(0, 10000, "n", integer=False, lo_open=True)
#: degrees of the spectra (ducc0's adjoint synthesis: about 5 s and 0.3 GB at 4096)
LMAX_CAP = 4096
#: points of one rule: the closed form Eq. 41 is an O(N^2) pair sum (about a minute at 65536)
N_CAP = 65536

#: the paper's highest spectral degree (default --lmax of ``figures``)
DEFAULT_SPLIT_LMAX = 170

#: help of --shininess (wce, table1, figures)
SHININESS_HELP = (f"glossy exponent n, {SHININESS_RANGE} (default {DEFAULT_SHININESS:g}, the "
                  "paper's); n of about 10 "
                  "or less is slow on first use (minutes: the lobe's jump at the horizon, "
                  "e^-n, makes the engine sum the kernel embedding to SH degree 32768)")
#: the note on morphed points closing the descriptions of wce and figures
MORPH_HELP = ("Points are morphed for the BRDF by default: their heights are importance-sampled "
              "from p (diffuse z = sqrt(z'), glossy Eq. 67; Sec. 7.2), so that equal weights "
              "1/N estimate the normalised shading integral (Eq. 17).")


def check_s(s: float) -> float:
    from envfit.theory import check_smoothness
    return check_smoothness(s)


def check_positive_int(v: int, name: str, lo: int = 1) -> int:
    if v is None or int(v) < lo:
        raise ParameterError(f"{name} must be an integer >= {lo}, got {v}")
    return int(v)


def check_shininess(n: float) -> float:
    if not (math.isfinite(n) and n > 0):
        raise ParameterError(f"--shininess must be > 0, got {n:g}")
    return float(n)


def progress_callback(bar):
    def cb(label: str) -> None:
        bar.set_postfix_str(label)
        bar.update(1)
    return cb


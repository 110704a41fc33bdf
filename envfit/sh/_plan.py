r"""Time and memory of ``envfit sh`` before the work: every option's valid range (issue 22,
item 7).

Ranges
    ``--lmax`` :math:`0\le L\le H-1` and ``--table-lmax`` :math:`1\le T\le H-1` (the map's
    band limit: above it the coefficients describe the bilinear lookup's aliasing, not the
    map); ``--check-axes`` :math:`\ge 1`, ``--check-height`` :math:`\ge 1`; and each within
    the memory budget (:func:`envfit.base._resources.memory_budget_bytes`) and, together, the
    time limit (:func:`time_limit_seconds`, ``ENVFIT_TIME_LIMIT``, default
    :data:`DEFAULT_TIME_LIMIT` s). A value beyond is refused in one line naming the option
    and the largest value that fits (:func:`check_sh_plan`).

Cost model (:func:`sh_stages`), C channels, on this machine's speeds measured once per
process by :func:`machine_rates` (a few tens of milliseconds of the same kernels, scaled by
the machine's current load, :func:`load_factor`):

* a Gauss–Legendre synthesis of degree l (``ducc0.sht.synthesis_2d``, nlat = max(256,
  4(l+1)) rings of 2 nlat points): :math:`C\,(2n_{lat}^2 + n_{lat}(l+1)^2/2)` units; a
  ringing row costs 1 (none, hanning, lanczos, and sloan's own negative fraction each) plus
  sloan's λ search, at most :math:`24 + 4\log_2(l+1)` (counted on a sun map and on forest:
  5–41 syntheses per degree for L ≤ 20); memory: 3 grids of :math:`8C\,2n_{lat}^2` bytes;
* the world-frame rotation of an export of degree l (``ducc0.sht.rotate_alm``):
  :math:`C(l+1)^3` units;
* the dense check: :math:`2h^2` pixels × :math:`(t+1)^2` basis values (t ≤
  :data:`~envfit.sh._ringing.DIRECT_LMAX` the largest degree checked) + as many
  multiply-adds per export channel; memory: one block of rows
  (:data:`~envfit.sh._ringing.DENSE_BLOCK_BYTES`) + a 32 MiB basis chunk;
* the measured error: irradiance — :math:`M(l+1)^2` basis values per export of degree
  l ≤ DIRECT_LMAX at M axes, :math:`CM(l+1)` synthesis units above it and for the ground
  truth (:math:`l = L_{sh} = \max(H-1, \min(2H-1, 511))`; measured: 2 µs per axis at
  H = 64, C = 3); radiance — one synthesis on a 2H-row grid per export.

The model is an estimate, used to refuse what would run for hours, not to promise a
duration. Measured on a shared 2-core machine (load 7): the dense check within 15 % (23 s
predicted, 20 s taken, forest at 128 rows, ``--check-height 1024``), the whole run of an
irradiance export within 20 %; the table is an upper bound — it assumes sloan's λ search on
every degree (50 syntheses at L = 63), which a map that never rings skips (a smooth map:
30 s predicted, 1.6 s taken; forest: 27 s predicted, 9 s taken, L = 1..60).
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from envfit.base import MemoryBudgetError, ParameterError
from envfit.base import Stage, budget_words, format_bytes, memory_budget_bytes, time_limit_words
from envfit.base import time_limit_seconds as _time_limit
from envfit.sh._ringing import (CHECK_AXES, DENSE_BLOCK_BYTES, DENSE_HEIGHT,
                                    DIRECT_LMAX, check_degree)

__all__ = ["DEFAULT_TIME_LIMIT", "Rates", "time_limit_seconds", "machine_rates",
           "sh_stages", "check_sh_plan"]

#: seconds the planned work of one ``envfit sh`` may take (``ENVFIT_TIME_LIMIT`` overrides)
DEFAULT_TIME_LIMIT = 900.0
_WINDOWS = 4
_BASIS_CHUNK = 32 * 2**20


@dataclass(frozen=True)
class Rates:
    """Seconds per unit of each kernel (:func:`machine_rates`)."""

    basis: float       # one real SH basis value at one direction (real_sh_basis)
    flop: float        # one multiply-add of a basis @ coefficients product
    synthesis: float   # one unit of a GL synthesis (module docstring)
    rotation: float    # one (l+1)^3 unit of rotate_alm


def time_limit_seconds() -> float:
    """The time limit: ``ENVFIT_TIME_LIMIT`` (seconds, at least 1; ``0``, ``none`` or ``inf``:
    none) or :data:`DEFAULT_TIME_LIMIT` (:func:`envfit.base._resources.time_limit_seconds`)."""
    return _time_limit(DEFAULT_TIME_LIMIT)


def _best(fn, repeats: int = 3) -> float:
    out = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out = min(out, time.perf_counter() - t0)
    return max(out, 1e-9)


@lru_cache(maxsize=1)
def _cpu_rates() -> Rates:
    """The kernels' speeds on one core of this machine (the best of 3 runs, ~50 ms once per
    process): a basis of degree 8 at 16384 directions (a dense-check chunk), a 4096×289 by
    289×96 product, a three-channel GL synthesis of degree 32 on 256 rings (a ringing
    row's), a rotation of degree 32."""
    import ducc0
    from envfit.sh._sh_export import gl_synthesis, real_sh_basis
    rng = np.random.default_rng(0)
    d = rng.normal(size=(16384, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    a, b = rng.random((4096, 289)), rng.random((289, 96))
    alm = rng.random((3, 33 * 34 // 2)) + 0j
    alm[:, :33] = alm[:, :33].real
    return Rates(
        basis=_best(lambda: real_sh_basis(d, 8)) / (16384 * 81),
        flop=_best(lambda: a @ b) / (4096 * 289 * 96),
        synthesis=_best(lambda: gl_synthesis(alm, np.ones(33), 32, 256)) / (
            3 * _syn_units(32, 256)),
        rotation=_best(lambda: ducc0.sht.rotate_alm(alm[0], 32, 0.1, 0.2, 0.3)) / 33 ** 3)


def load_factor() -> float:
    """How much longer work takes on this machine now than alone on its cores: the 1-minute
    load average over the cores this process may use, at least 1."""
    from envfit.base import machine_cores
    try:
        return max(1.0, os.getloadavg()[0] / machine_cores())
    except (AttributeError, OSError):  # pragma: no cover - no load average
        return 1.0


def machine_rates() -> Rates:
    """Seconds per unit of each kernel on this machine now: the measured speeds
    (:func:`_cpu_rates`) times :func:`load_factor` (on a shared machine the wall time, not
    the CPU time, is what the limit is about)."""
    r, f = _cpu_rates(), load_factor()
    return Rates(basis=r.basis * f, flop=r.flop * f, synthesis=r.synthesis * f,
                 rotation=r.rotation * f)


def _nlat(l: int) -> int:
    return max(256, 4 * (l + 1))


def _syn_units(l: int, nlat: int) -> float:
    return 2.0 * nlat * nlat + nlat * (l + 1) ** 2 / 2.0


def _sloan_syntheses(l: int) -> float:
    return 4 + 24 + 4 * math.log2(l + 1)


#: fixed caps of ``--check-axes`` and ``--check-height`` (the planned time and memory may
#: refuse less: the message names the largest that fits)
MAX_CHECK_AXES = 2 ** 20
MAX_CHECK_HEIGHT = 16384



def _table(h: int, c: int, Ls, check: bool, irradiance: bool, r: Rates) -> Stage:
    """The ringing table: its syntheses, and with ``check`` the rows' exports (rotation)
    and, for radiance, their measured error on a 2H-row grid."""
    secs, top = 0.0, max(Ls)
    for l in Ls:
        secs += c * r.synthesis * _syn_units(l, _nlat(l)) * _sloan_syntheses(l)
        if check:
            secs += _WINDOWS * c * r.rotation * (l + 1) ** 3
            if not irradiance:
                secs += _WINDOWS * c * r.synthesis * _syn_units(l, 2 * h)
    grid = 3 * 8 * c * 2 * _nlat(top) ** 2
    radiance = 0 if irradiance or not check else 4 * 8 * c * 2 * (2 * h) ** 2
    return Stage(f"the ringing table (L = 1..{top}, {_WINDOWS} windows)", grid + radiance,
                 secs, option="--table-lmax")


def _export(c: int, L: int, r: Rates) -> Stage:
    """The export of degree L: rotation to the world frame, its negative fraction."""
    secs = c * (2 * r.rotation * (L + 1) ** 3 + r.synthesis * _syn_units(L, _nlat(L)))
    return Stage(f"the export to L = {L} (world rotation, negativity on a {_nlat(L)}-ring "
                 "grid)", 3 * 8 * c * 2 * _nlat(L) ** 2 + 48 * c * (L + 1) ** 2, secs,
                 option="--lmax")


def _dense(c: int, Ls, L: int, hd: int, r: Rates) -> Stage:
    """The dense negative-fraction check of every export of degree <= DIRECT_LMAX."""
    degrees = [l for l in Ls if l <= DIRECT_LMAX]
    k = c * (_WINDOWS * len(degrees) + (L <= DIRECT_LMAX))
    if k == 0:
        return Stage("the dense check (nothing to check)", 0, 0.0, option="--check-height")
    n = (max(degrees + ([L] if L <= DIRECT_LMAX else [])) + 1) ** 2
    pixels = 2.0 * hd * hd
    return Stage(f"the dense check ({k} signals on a {2 * hd}x{hd} grid)",
                 DENSE_BLOCK_BYTES + _BASIS_CHUNK + 8 * (n * k + 4 * hd),
                 pixels * n * (r.basis + k * r.flop), option="--check-height")


def _measured(h: int, c: int, Ls, L: int, axes: int, irradiance: bool, r: Rates) -> Stage:
    """The measured irradiance error at ``axes`` directions (radiance: in the table): the
    ground truth and each export's evaluation (direct sums to DIRECT_LMAX, above it a
    synthesis at the directions)."""
    if not irradiance:
        return Stage("the measured error (radiance: on the 2H grid)", 0, 0.0,
                     option="--check-axes")
    lsh = max(h - 1, min(2 * h - 1, 511))
    degrees = [l for l in Ls for _ in range(_WINDOWS)] + [L]
    direct = sum((l + 1) ** 2 for l in degrees if l <= DIRECT_LMAX)
    general = sum(l + 1 for l in degrees if l > DIRECT_LMAX) + (lsh + 1)
    return Stage(f"the measured error at {axes} directions", _BASIS_CHUNK + 8 * axes * (6 + 4 * c),
                 axes * (direct * r.basis + c * general * r.synthesis), option="--check-axes")


def sh_stages(height: int, channels: int, lmax: int, table_lmax: int, *, check: bool = True,
              check_axes: int = CHECK_AXES, dense_height: int = DENSE_HEIGHT,
              irradiance: bool = False, rates: Rates | None = None) -> list[Stage]:
    """The stages of :func:`envfit.sh._report.sh_report` with their estimated
    seconds and peak bytes (module docstring), in the order they run."""
    r = machine_rates() if rates is None else rates
    h, c = int(height), max(1, int(channels))
    Ls = sorted(set(range(1, int(table_lmax) + 1)) | ({int(lmax)} if lmax >= 1 else set()))
    stages = [_export(c, int(lmax), r), _table(h, c, Ls, check, irradiance, r)]
    if check:
        stages += [_dense(c, Ls, int(lmax), int(dense_height), r),
                   _measured(h, c, Ls, int(lmax), int(check_axes), irradiance, r)]
    return stages


def _fits(stages, limit: float, budget: int) -> bool:
    return sum(s.seconds for s in stages) <= limit and max(s.nbytes for s in stages) <= budget


def _largest(plan, lo: int, hi: int) -> int | None:
    """Largest v in [lo, hi] with plan(v) fitting (plan increasing), None if not even lo."""
    if not plan(lo):
        return None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if plan(mid) else (lo, mid)
    return hi if plan(hi) else lo


_LOWEST = {"--lmax": 0, "--table-lmax": 1, "--check-height": 1, "--check-axes": 1}
_KEYS = {"--lmax": "lmax", "--table-lmax": "table_lmax", "--check-height": "dense_height",
         "--check-axes": "check_axes"}


def _seconds(s: float) -> str:
    return f"{s:.0f} s" if s < 1e4 else f"{s:.1e} s"


def check_sh_plan(height: int, channels: int, lmax: int, table_lmax: int, *,
                  check: bool = True, check_axes: int = CHECK_AXES,
                  dense_height: int = DENSE_HEIGHT, irradiance: bool = False,
                  rates: Rates | None = None) -> list[Stage]:
    """Every option of ``envfit sh`` in its range and the planned work within the machine's
    memory budget and the time limit, before any work; returns the stages.

    Raises :class:`ParameterError` (a degree above the band limit H − 1, or over the time
    limit) or :class:`MemoryBudgetError` in one line naming the option, what it would cost
    and the largest value that fits (the other options as given)."""
    opts = {"lmax": check_degree(lmax, height, "--lmax", 0),
            "table_lmax": check_degree(table_lmax, height, "--table-lmax", 1),
            "check_axes": int(check_axes), "dense_height": int(dense_height)}
    r = machine_rates() if rates is None else rates
    limit, budget = time_limit_seconds(), memory_budget_bytes()

    def stages_with(**kw) -> list[Stage]:
        return sh_stages(height, channels, check=check, irradiance=irradiance, rates=r,
                         **{**opts, **kw})

    stages = stages_with()
    if _fits(stages, limit, budget):
        return stages
    order = sorted(stages, key=lambda s: (s.nbytes <= budget, -s.seconds))
    for stage in order:
        key = _KEYS[stage.option]
        best = _largest(lambda v: _fits(stages_with(**{key: v}), limit, budget),
                        _LOWEST[stage.option], opts[key] - 1) if opts[key] > _LOWEST[
                            stage.option] else None
        if best is not None:
            raise _refusal(stage, opts[key], stages, limit, budget,
                           f"the largest {stage.option} that fits is {best}")
    worst = order[0]
    raise _refusal(worst, opts[_KEYS[worst.option]], stages, limit, budget,
                   "no value of it fits with the other options: "
                   + ("use --no-check or " if check else "use ") + "a smaller map (--max-height)")


def _refusal(stage: Stage, value: int, stages, limit: float, budget: int, hint: str):
    if stage.nbytes > budget:
        return MemoryBudgetError(
            f"{stage.option} {value}: {stage.name} needs {format_bytes(stage.nbytes)} but only "
            f"{format_bytes(budget)} can be used ({budget_words()}); {hint}")
    total = sum(s.seconds for s in stages)
    return ParameterError(
        f"{stage.option} {value}: the work would take about {_seconds(total)} on this machine "
        f"({stage.name}: {_seconds(stage.seconds)}), over {time_limit_words(limit)}; {hint}")

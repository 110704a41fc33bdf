r"""The renderer model sized to its own error: a cheap pilot, then the normals and scrambles
the answer needs.

The model of a sampled net (Owen scrambling, a digital shift:
:data:`~envfit.advisor._preset_options.SIZED_RANDOMISATIONS`) samples two things, and each
prediction carries the relative standard error of its RMSE from both
(:mod:`envfit.predict.renderer._model_error`): the normals (K, importance-sampled from a
spherical Fibonacci pool; error :math:`e_n \propto 1/\sqrt K`) and the random scrambles of the
net above the grid (Q; :math:`e_s \propto 1/\sqrt Q`). The grid level matters little once the
power above the grid is sampled — the grid is a control variate — so the sized model runs at
:data:`~envfit.advisor._preset_options.AUTO_LEVEL` and spends its time where the error is.

1. **Pilot**: K₀ = 48 normals, Q₀ = 16 scrambles at level 7 (a pass costs ~1/14 of the
   unsized model's: level 9, Q = 256); the search runs to the answer.
2. If the answer's model error :math:`\sqrt{e_n^2 + e_s^2}` (the default strategy's, at its
   answer or at the largest spp searched) exceeds the target ``model_error`` (default 5 %),
   the cheapest (K, Q) of :data:`NORMALS` × :data:`SHIFTS` whose predicted error
   :math:`\sqrt{e_n^2 K_0/K + e_s^2 Q_0/Q}` meets it — at most :data:`BUDGET` integrand
   points a pass, the unsized model's; if none meets it within that, the one of smallest
   predicted error — and the search runs again with those (:func:`sized_options`).

The answer reports the final model's error; it is an estimate (of the normals' spread and the
scrambles' spread), not a bound.
"""
from __future__ import annotations

import math
from dataclasses import replace

__all__ = ["NORMALS", "SHIFTS", "BUDGET", "pass_points", "sized_options", "predicted_error"]

#: the normals the sized model may take (the pool holds 1024)
NORMALS = (48, 96, 144, 192, 288, 384, 576)
#: the scrambles (Q) it may take
SHIFTS = (16, 64, 256)
#: the most integrand points a pass may evaluate: the unsized default's (48 normals, tables
#: of 4^10 points at level 9 and 256 × 4096 scrambled points), per technique
BUDGET = 48 * (4 ** 10 + 256 * 4096)


def pass_points(normals: int, level: int, shifts: int, reach: int) -> int:
    """Integrand points a pass evaluates per technique: per normal the fine table of
    4^(L+1) midpoints and Q·reach scrambled points.

    >>> pass_points(48, 9, 256, 4096) == BUDGET
    True
    """
    return int(normals) * (4 ** (int(level) + 1) + int(shifts) * int(reach))


def sized_options(opts, parts, reach: int | None = None):
    """The options of the final model after a pilot whose answer's model error parts are
    ``parts`` = (normals', scrambles') relative standard errors (module docstring), its
    sampled nets to ``reach`` (None: the pilot's), or None when the pilot meets
    ``opts.model_error`` (or its error is unknown)."""
    if not parts:
        return None
    reach = opts.reach if reach is None else int(reach)
    e_n, e_s = (float(x) for x in parts)
    tol = opts.model_error
    if math.hypot(e_n, e_s) <= tol:
        return None
    k0, q0 = opts.normals, opts.shifts

    def error(k, q):
        return math.hypot(e_n * math.sqrt(k0 / k), e_s * math.sqrt(q0 / q))

    sizes = [(k, q) for k in NORMALS for q in SHIFTS if k >= k0 and q >= q0
             and pass_points(k, opts.level, q, reach) <= BUDGET]
    meets = [c for c in sizes if error(*c) <= tol]
    if meets:
        k, q = min(meets, key=lambda c: (pass_points(c[0], opts.level, c[1], reach),
                                         error(*c)))
    else:
        k, q = min(sizes, key=lambda c: error(*c))
    if (k, q) == (k0, q0):
        return None
    return replace(opts, level=opts.level, normals=k, shifts=q, reach=reach)


def predicted_error(opts, parts, final) -> float:
    """The error :func:`sized_options` expects of ``final`` from the pilot's ``parts``.

    >>> from types import SimpleNamespace as S
    >>> round(predicted_error(S(normals=48, shifts=16), (0.06, 0.04), S(normals=192,
    ...       shifts=64)), 4)
    0.0361
    """
    e_n, e_s = parts
    return math.hypot(e_n * math.sqrt(opts.normals / final.normals),
                      e_s * math.sqrt(opts.shifts / final.shifts))

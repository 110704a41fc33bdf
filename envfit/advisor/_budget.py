r"""The advisor's memory and time plan, made before any work: every stage's predicted peak
from the map size, N, L and the options, against the machine's memory budget
(:func:`envfit.base._resources.memory_budget_bytes`); a map too big for it is downsampled to
what the predictions need, or the run is refused in one line naming an option that fits.

Why a map is downsampled (issue 22: an 8192×4096 map ran over 5 minutes and reached 19.9 GB)
------------------------------------------------------------------------------------------
Prediction (c) weights a rule's error power :math:`e_l` by the map's power :math:`\hat P_l` to
:math:`2H - 1` (:func:`envfit.advisor._model.spectral_lmax`). Its cost grows as the cube of the
map's size: the interpolant's SH analysis is :math:`O(H q L^2)` in time and :math:`O(H q L)`
in memory (:func:`envfit.shading._spectra.sh_analysis_cost`: 1.2 GB and 20 s to l = 2047 on a
2048×1024 map, 20 GB and ~20 min to l = 8191 on an 8192×4096 one) and every evaluated N of
every rule costs :math:`O(L^3)` (:func:`envfit.shading._spectra.rule_power_cost`: 1.7–9 s at
l = 2047, 12–36 s at l = 4095, ~2 log₂ N evaluations per rule). The rules the advisor sizes do
not need those degrees: N ≤ ``nmax`` = 65536 points are spaced :math:`\sqrt{4\pi/N}` apart,
so a rule integrates degrees up to about :math:`\sqrt{\pi N}/2 \approx 227` and sees every
higher degree only through its energy (above that degree :math:`e_l \to \frac{2l+1}{4\pi}
\sum_j w_j^2`, the addition theorem's diagonal, whatever the map). A map of
:data:`PREDICTION_MAX_HEIGHT` = 1024 rows holds degrees to 1023 and its interpolant's tail to
2047, an octave and more above that: the predictions are made on the map downsampled (exact
solid-angle block means, :meth:`envfit.maps._envmap.EnvMap.resized`, the mean kept) to at most
that height, and lower where the memory budget needs it. What the block means drop is
variance at scales finer than the kept pixels, which the rules see as white noise: the note
states how much of the map's variance the downsampled map keeps
(:func:`envfit.maps._envmap.variance_kept`).

Maps of at most 1024 rows are not touched (their predictions are bit-identical to before).
"""
from __future__ import annotations

import math
from dataclasses import replace

from envfit.advisor._options import AdviseOptions
from envfit.base._errors import MemoryBudgetError
from envfit.base._resources import (Plan, Stage, format_bytes, interpolator_nbytes,
                                    largest_n_within, memory_budget_bytes)
from envfit.kernels._bandlimited import max_samples
from envfit.maps._envmap import EnvMap
from envfit.shading._ground_truth import default_sh_lmax
from envfit.sampling._rules import STRATEGIES
from envfit.shading._spectra import rule_power_cost, sh_analysis_cost
from envfit.predict.renderer._warped_spectrum import spectrum_nbytes

__all__ = ["PREDICTION_MAX_HEIGHT", "MIN_HEIGHT", "advise_plan", "lobe_rows",
           "prediction_height"]

#: the most rows the advisor's predictions use (see the module docstring)
PREDICTION_MAX_HEIGHT = 1024
#: the fewest rows a downsampled map may keep (below, the run is refused)
MIN_HEIGHT = 64
#: bytes per pixel of the renderer rows' setup (the scaled, source and rest maps, two
#: samplers: +296 MB on a 2048x1024 map) and of the map nodes the next spectrum reuses,
#: beside one spectrum (:func:`envfit.predict.renderer._warped_spectrum.spectrum_nbytes`): the whole
#: renderer section measured +1.93 GB on a 2048x1024 map (four spectra, G = 512, 32 axes);
#: bench/big_maps.py on a 2048x1024 GP map with a sun: 2.36 GB resident (predicted 2.61 GB);
#: envfit advise on an 8192x4096 map (predictions at 2048x1024): 2.81 GB (predicted 2.87 GB)
_RENDERER_SETUP_BYTES_PER_PIXEL = 400
#: seconds per pixel and per axis of one warped spectrum (35 s for four spectra of city.exr,
#: 199 s on a 2048x1024 map; 2 loaded cores)
_RENDERER_SEC_PER_PIXEL_AXIS = 6e-7
#: bytes per point of a quadrature rule while its error power is computed
_RULE_BYTES_PER_POINT = 8 * 24


def _stream_seconds(upper: int, nmin: int, L: int, osw: bool) -> float:
    """At most the seconds of one rule's search to ``upper`` (:func:`~envfit.advisor._search.
    smallest_n`): the doubling from ``nmin`` (one error power per N, the N-terms summing to
    < 2 upper) and a bisection of log₂(upper / 2) evaluations at up to ``upper`` points, each
    :func:`envfit.shading._spectra.rule_power_cost`; OSW adds an N×N Cholesky solve (N³/3
    flops at ~3 GFlop/s) per evaluation."""
    doubling = math.ceil(math.log2(max(2, upper / max(1, nmin)))) + 1
    bisection = math.log2(max(2, upper / 2))
    t1 = rule_power_cost(1, L)[1]                     # the degree part of one evaluation
    tn = rule_power_cost(upper, L)[1] - t1             # the point part at N = upper
    secs = (doubling + bisection) * t1 + tn * (2 + bisection)
    return secs + (1e-10 * upper ** 3 * (doubling + bisection) if osw else 0.0)


def _search_stage(h: int, opts: AdviseOptions) -> Stage:
    """The quadrature searches: one rule error power to 2H − 1 per evaluated N (and OSW's
    N×N solve); seconds: the most a search can take (:func:`_stream_seconds`) for each rule
    and realisation (the cache and rules that stop early take less: on a 2048x1024 GP map
    with a sun, target 1 % of the mean, predicted at most ~4100 s, measured 1256 s on 2
    loaded cores, bench/big_maps.py)."""
    L = 2 * h - 1
    nb, secs = 0, 0.0
    for ps in opts.pointsets:
        k = opts.seeds if ps in ("random", "jitter", "bnot") else 1
        for w in opts.weights:
            upper = opts.nmax if w == "equal" else opts.osw_upper
            secs += k * _stream_seconds(upper, opts.nmin, L, w == "osw")
            nb = max(nb, rule_power_cost(upper, L)[0]
                     + (interpolator_nbytes(upper, 1) if w == "osw" else 0))
    return Stage("quadrature search", int(nb), secs,
                 f"rule error power to l = {L} per N, up to N = {opts.nmax}")


def advise_plan(height: int, channels: int, opts: AdviseOptions, *,
                resident: int = 0, source_height: int | None = None) -> Plan:
    """The stages of ``envfit advise`` on a 2H x H map of C channels with ``opts``, each with
    its predicted peak bytes and seconds beyond what the process holds already (the input
    map among it); ``resident``: more bytes held throughout. Resident: the map on its scale
    and the copy the fit and the renderer setup keep (2 x 8 H W C). ``source_height``: the
    rows of the input map when it is downsampled to ``height`` first (block means in ~32 MB
    blocks, the float64 result and its copy; ~10 ns per input value, measured ~3 s for a
    1-channel 8192x4096 map with its variance)."""
    h, c = int(height), max(1, int(channels))
    w, L = 2 * h, 2 * h - 1
    pix = h * w
    stages = []
    if source_height is not None and int(source_height) > h:
        h0 = int(source_height)
        stages.append(Stage("downsampling", 2 * 8 * pix * c + 2 * 32 * 2 ** 20,
                            1e-8 * 2 * h0 * h0 * c, f"{2 * h0}x{h0} to {w}x{h}"))
    n_fit = min(int(opts.fit_n), max(10, max_samples(h - 1)))
    stages.append(Stage("band-limited fit", interpolator_nbytes(n_fit, c) + 8 * pix * (c + 4),
                        2e-7 * n_fit ** 2 * 20 + 1e-7 * pix, f"{n_fit} samples"))
    nb, t = sh_analysis_cost(h, c, L)
    stages.append(Stage("map power", nb, t + sh_analysis_cost(h, c, h - 1)[1],
                        f"SH coefficients of the interpolant to l = {L}"))
    if opts.pointsets:
        stages.append(_search_stage(h, opts))
    if opts.renderer:
        nspec = len({STRATEGIES[s] for s in opts.strategies})
        stages.append(Stage("renderer spectra",
                            _RENDERER_SETUP_BYTES_PER_PIXEL * pix
                            + spectrum_nbytes(h, opts.renderer_grid),
                            nspec * _RENDERER_SEC_PER_PIXEL_AXIS * pix
                            * opts.renderer_spectrum_axes,
                            f"{nspec} warped spectra, grid {opts.renderer_grid}"))
    if opts.check:
        lg = default_sh_lmax(opts.lobe(), h)
        nb, t = sh_analysis_cost(h, c, lg)
        per_axis = 8 * (8 + 2 * c) * max(1, opts.workers) * opts.nmax
        stages.append(Stage("check", nb + per_axis, t, f"ground truth to l = {lg}"))
    return Plan("advise", stages, resident=int(resident) + 8 * pix * c * 2)


def lobe_rows(opts: AdviseOptions, tol: float = 0.1) -> int:
    r"""The fewest rows whose predictions (to degree 2H − 1) hold what a glossy lobe of
    exponent n passes: :math:`\lambda_{2H} \approx e^{-2H(2H+1)/2n} \le` ``tol``, i.e.
    :math:`2H(2H+1) \ge 2n\ln(1/\text{tol})` (the large-n form of the lobe's Funk–Hecke
    factors, which the sharp lobes that need many rows satisfy); 1 for the diffuse lobe. A
    downsampled map keeps at least these rows (n = 1e6 needs 1073: 2048 rows of an 8K map).

    >>> lobe_rows(AdviseOptions(brdf="glossy", shininess=1e6, target_rmse=0.01))
    1073
    """
    if opts.brdf != "glossy" or opts.shininess is None:
        return 1
    need = 2.0 * float(opts.shininess) * math.log(1.0 / tol)
    return max(1, math.ceil((-1.0 + math.sqrt(1.0 + 4.0 * need)) / 4.0))


def _heights(h: int) -> list[int]:
    """Candidate heights, largest first: H, then H / k for the integer factors k of H (a
    block mean), ending at :data:`MIN_HEIGHT` or the smallest factor above it."""
    out = [h]
    for k in range(2, h // MIN_HEIGHT + 1):
        if h % k == 0 and h // k < out[-1]:
            out.append(h // k)
    if out[-1] > PREDICTION_MAX_HEIGHT:          # no factor lands at or below the cap
        out.append(PREDICTION_MAX_HEIGHT)        # (a smooth resize)
    return out


def _search_refusal(envmap: EnvMap, opts: AdviseOptions, plan: Plan, h: int,
                    kw: dict) -> MemoryBudgetError | None:
    """Where the quadrature search alone is over budget and lowering one N option makes the
    plan fit: one line naming that option and the largest value of it that fits (the plan
    is arithmetic: the bisection allocates nothing); None otherwise."""
    if plan.worst().name != "quadrature search":
        return None
    c, budget = envmap.channels, memory_budget_bytes()
    names = (("osw_nmax",) if "osw" in opts.weights else ()) + ("nmax",)
    for name in names:
        def peak(n, name=name):
            return advise_plan(h, c, replace(opts, **{name: max(opts.nmin, n)}), **kw).peak()
        if peak(opts.nmin) > budget:
            continue
        fits = max(opts.nmin, largest_n_within(peak, budget, getattr(opts, name)))
        return MemoryBudgetError(
            f"advise on the {envmap.width}x{envmap.height} map at {name} = "
            f"{getattr(opts, name)}: the quadrature search ({plan.worst().detail}) needs "
            f"{format_bytes(plan.peak())} but only {format_bytes(budget)} can be used; "
            f"the largest {name} that fits is {fits}")
    return None


def _refusal(envmap: EnvMap, opts: AdviseOptions, plan: Plan, h: int) -> MemoryBudgetError:
    """One line: the smallest plan's worst stage, and the option that makes it fit."""
    c, res = envmap.channels, 8 * 2 * h * h * envmap.channels
    fixes = []
    kw = {"resident": res, "source_height": envmap.height}
    search = _search_refusal(envmap, opts, plan, h, kw)
    if search is not None:
        return search
    if opts.renderer and advise_plan(h, c, replace(opts, renderer=False), **kw).fits():
        fixes.append("--no-renderer")
    if opts.check and advise_plan(h, c, replace(opts, check=False), **kw).fits():
        fixes.append("without --check")
    if "osw" in opts.weights and opts.pointsets:
        lean = replace(opts, osw_nmax=max(opts.nmin, 256), nmax=max(opts.nmin, 4096))
        if advise_plan(h, c, lean, **kw).fits():
            fixes.append("--osw-nmax 256 --nmax 4096")
    hint = (f"it fits with {' or '.join(fixes)}" if fixes else
            "free memory, or set ENVFIT_MEMORY_LIMIT if more can be used")
    w = plan.worst()
    return MemoryBudgetError(
        f"advise on the {envmap.width}x{envmap.height} map even at {2 * h}x{h}: {w.name} "
        f"({w.detail}) needs {format_bytes(plan.peak())} but only "
        f"{format_bytes(memory_budget_bytes())} can be used; {hint}")


def prediction_height(envmap: EnvMap, opts: AdviseOptions) -> tuple[int, Plan]:
    """The height of the map the predictions use and its plan: the largest candidate
    (:func:`_heights`) at most :data:`PREDICTION_MAX_HEIGHT` (or the rows a sharp glossy lobe
    needs, :func:`lobe_rows`) whose plan fits the memory budget. Costs no allocation.

    Raises
    ------
    envfit.base._errors.MemoryBudgetError
        Not even :data:`MIN_HEIGHT` rows fit: one line naming the stage and an option that
        fits (``--no-renderer``, no ``--check``, smaller ``--osw-nmax``/``--nmax``).
    """
    h0, c = envmap.height, envmap.channels
    need, heights = lobe_rows(opts), _heights(h0)
    cap = PREDICTION_MAX_HEIGHT if need <= PREDICTION_MAX_HEIGHT else \
        min((k for k in heights if k >= need), default=h0)
    plan = None
    for h in heights:
        if h > cap:
            continue
        plan = advise_plan(h, c, opts, resident=8 * 2 * h * h * c if h < h0 else 0,
                           source_height=h0)
        if plan.fits():
            return h, plan
    if plan is None:  # pragma: no cover - _heights always ends at or below the cap
        raise MemoryBudgetError("no height to plan")
    raise _refusal(envmap, opts, plan, h)

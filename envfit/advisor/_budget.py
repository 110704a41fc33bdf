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
from envfit.base import MemoryBudgetError
from envfit.base import (Plan, Stage, budget_words, format_bytes, interpolator_nbytes,
                         largest_n_within, memory_budget_bytes)
from envfit.defaults import TWO_LOBE_BSDFS
from envfit.sobolev import max_samples
from envfit.maps import EnvMap
from envfit.shading import default_sh_lmax
from envfit.sampling import STRATEGIES
from envfit.shading import rule_power_cost, sh_analysis_cost
from envfit.predict.warped import spectrum_nbytes

__all__ = ["PREDICTION_MAX_HEIGHT", "MIN_HEIGHT", "advise_plan", "lobe_rows",
           "prediction_height", "renderer_plan", "check_renderer_plan"]

#: the most rows the advisor's predictions use (see the module docstring)
PREDICTION_MAX_HEIGHT = 1024
#: the fewest rows a downsampled map may keep (below, the run is refused)
MIN_HEIGHT = 64
#: bytes per pixel of the renderer rows' setup (the scaled, source and rest maps, two
#: samplers: +296 MB on a 2048x1024 map) and of the map nodes the next spectrum reuses,
#: beside one spectrum (:func:`envfit.predict.warped._warped_spectrum.spectrum_nbytes`): the whole
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


# ----------------------------------------------------------------------------- renderer model

#: bytes per point of the renderer model's finest table (4^(L+1) points, L =
#: ``--renderer-level``) while a pass runs: the technique's table, the parts per normal and
#: their moment pyramids, every randomisation's transforms. Measured (peak RSS beyond the
#: loaded map, the three strategies, a 32x16 map, AMD EPYC): at L = 9 independent 376,
#: ldsampler on its grid 490, zsobol 470, multijitter 460, orthogonal 460, envfit sobol 357;
#: GGX (alpha 0.2) independent 465
RENDERER_BYTES_PER_POINT = 500
#: bytes per shifted point of a digital shift sampled above its grid (Q x N points per N,
#: ``RendererModelOptions.shifts``): ldsampler at L = 9 to 4096 spp measured +470 (diffuse),
#: +200 (GGX) per point
RENDERER_BYTES_PER_SHIFTED = 500
#: bytes per (pool normal, pilot point) pair of the normals' proposal (the P x 4^pilot cosine
#: matrix and its temporaries): 83.8 MB measured at P = 1024, pilot level 6
PROPOSAL_BYTES_PER_PAIR = 20
#: the frames' proposal of a microfacet BSDF: bytes per pool frame and fixed (compiled
#: proxies per frame, numpy ones in blocks of 2^18 points): 52 MB measured for 8192 frames
#: (GGX); its time ~0.3 ms a frame (``_renderer_options.MICROFACET_POOL``)
PROPOSAL_MICROFACET_BYTES = (64, 200 * 2 ** 18)
#: bytes per map pixel of the renderer's emitter technique: kept while the model runs, and at
#: its construction's peak (measured on a 1024x512 map, by renderer: from 32 / 64 to
#: 268 / 548)
TECHNIQUE_BYTES_PER_PIXEL = (300, 600)
#: seconds per table point, normal (frame) and pass, by the sampler's randomisation (the rest:
#: ``"other"``; a microfacet BSDF: ``"microfacet"``, every sampler; a digital shift's shifted
#: points too) — the per-normal (per-frame) cost is this times the finest table's 4^(L+1)
#: points (times the footprint's normals with ``--sphere-pixels``). Calibrated with
#: ``bench/preset_plan_check.py`` on forest.exr (1024x512, 16 normals, each sampler's default
#: level, the cache off; AMD EPYC, 2 cores, load ~1): measured per point 0.35-0.45 µs
#: (independent, L = 7; one renderer's 1.5), 0.84-1.1 (jittered), 0.54-1.5 (nets, multi-jittering,
#: orthogonal arrays, L = 9), ldsampler 0.18 over its 2.4 M fine and shifted points, GGX
#: 0.45-0.94; each constant at about the largest measured: a pass took 0.3-0.8x its plan.
#: Owen-scrambled nets after the compiled lookups and the one sampled table (48 normals, 2 M
#: fine and scrambled points each, load 0.75): 0.20 (zsobol), 0.28 (tabulated_sobol), 0.30
#: (paddedsobol); ldsampler 0.25
RENDERER_SECONDS_PER_POINT = {"independent": 1.0e-6, "jittered": 1.2e-6, "digital_shift": 0.25e-6,
                            "owen": 0.4e-6, "other": 1.5e-6, "microfacet": 1.5e-6}
#: the passes a search typically takes: one for the nets sampled above the grid (every coarse
#: spp in one pass, the spp between them from the same tables), else 2 (1 to 4 measured:
#: the coarse spp, the brackets)
RENDERER_PASSES = {"digital_shift": 1, "owen": 1, "other": 2}


def renderer_passes(randomisation: str) -> int:
    """The passes the plan counts for a sampler's randomisation (:data:`RENDERER_PASSES`)."""
    return RENDERER_PASSES.get(randomisation, RENDERER_PASSES["other"])


def _renderer_stages(pixels: int, opts, level: int, normals: int, max_spp: int) -> list:
    """The renderer model's stages (:func:`renderer_plan`) at ``level``, ``normals`` and
    ``max_spp`` (the other options as in ``opts``)."""
    from envfit.advisor._renderer_options import MICROFACET_POOL, spp_cap
    from envfit.predict.renderer import RendererModelOptions
    m = opts.model_options()
    rand = opts.record.sampler(opts.sampler).randomisation
    base = (MICROFACET_POOL if opts.microfacet and opts.bsdf not in TWO_LOBE_BSDFS
            else RendererModelOptions().pool)
    pool = max(base, normals)                                 # as opts.model_options()
    pilot = 4 ** m.pilot_level
    foot = m.footprint_side ** 2 if opts.sphere_pixels is not None else 1
    fine = 4 ** (level + 1)
    cap = spp_cap(rand, level, max_spp, m.shifts, sampled=opts.reaches_above(rand),
                  reach=m.reach if level == m.max_level else None)
    # Q·cap points: every sampled N reads its prefix of one table (_sampled_nets)
    shifted = (int(m.shifts * cap)
               if rand in ("digital_shift", "owen") and 2 * cap > 1 << level else 0)
    what = "frames" if opts.microfacet else "normals"
    tables = RENDERER_BYTES_PER_POINT * fine * (1 + (foot > 1))
    per_point = RENDERER_SECONDS_PER_POINT["microfacet" if opts.microfacet else rand] \
        if opts.microfacet or rand in RENDERER_SECONDS_PER_POINT else \
        RENDERER_SECONDS_PER_POINT["other"]
    return [
        Stage("the emitter technique", TECHNIQUE_BYTES_PER_PIXEL[1] * pixels, 1e-6 * pixels,
              f"{pixels} pixels"),
        Stage(f"the {what}' proposal",
              PROPOSAL_MICROFACET_BYTES[0] * pool + PROPOSAL_MICROFACET_BYTES[1]
              if opts.microfacet else PROPOSAL_BYTES_PER_PAIR * pool * pilot,
              3e-4 * pool if opts.microfacet else 1e-8 * pool * pilot,
              f"{pool} {what} x {pilot} pilot points",
              "--renderer-normals" if normals > base else ""),
        Stage("the model's passes", tables + RENDERER_BYTES_PER_SHIFTED * shifted,
              renderer_passes(rand) * normals * per_point * (fine * foot + shifted),
              f"{normals} {what}, tables of {fine} points"
              + (f", {shifted} {'scrambled' if rand == 'owen' else 'shifted'} points to {cap} spp"
                 if shifted else ""),
              "--renderer-level"),
    ]


def renderer_plan(pixels: int, opts, *, resident: int = 0) -> Plan:
    """The memory and time plan of the renderer model of ``envfit advise --renderer`` on a map
    of ``pixels`` pixels with :class:`~envfit.advisor._renderer_options.RendererAdviseOptions`
    ``opts``, before any of it runs: the emitter technique (per map pixel), the normals'
    (frames') proposal (pool × pilot table) and the passes (the finest table's 4^(L+1)
    points, a digital shift's or Owen scrambling's Q·N shifted (scrambled) points where it is
    sampled above its grid; seconds:
    :func:`renderer_passes` passes of K normals at :data:`RENDERER_SECONDS_PER_POINT` per point).
    ``resident``: bytes held throughout (the map); the technique's kept bytes are added.

    >>> from envfit.advisor._renderer_options import RendererAdviseOptions
    >>> from envfit.renderers import RENDERERS
    >>> name = next(n for n, r in RENDERERS.items() if "ldsampler" in r.samplers)
    >>> p = renderer_plan(512 * 256, RendererAdviseOptions(name, sampler="ldsampler", level=9))
    >>> p.worst().name, p.worst().option, round(p.peak() / 1e9, 1)
    ("the model's passes", '--renderer-level', 1.1)
    """
    stages = _renderer_stages(int(pixels), opts, opts.level, opts.normals, opts.max_spp)
    return Plan("the renderer model", stages,
                resident=int(resident) + TECHNIQUE_BYTES_PER_PIXEL[0] * int(pixels))


def _largest_fitting(pixels: int, opts, option: str, resident: int, budget: int):
    """The largest value of ``option`` below the asked one whose plan fits, or None."""
    now = {"--renderer-level": opts.level, "--renderer-normals": opts.normals,
           "--nmax": opts.max_spp}

    def fits(v: int) -> bool:
        kw = {**now, option: v}
        st = _renderer_stages(pixels, opts, kw["--renderer-level"], kw["--renderer-normals"],
                            kw["--nmax"])
        return Plan("", st, resident=resident).fits(budget)

    if option == "--renderer-level":
        return next((v for v in range(now[option] - 1, 0, -1) if fits(v)), None)
    v = largest_n_within(lambda k: 0 if fits(max(1, k)) else 1, 0, now[option] - 1)
    if v < 1 or not fits(v):
        return None
    if option == "--nmax":                    # the largest spp the sampler runs up to it
        v = opts.record.sampler(opts.sampler).runnable(v)[-1]
    return v


def check_renderer_plan(envmap: EnvMap, opts) -> Plan:
    """:func:`renderer_plan` of ``envmap`` checked against the memory budget before the model
    is built; returns the plan.

    Raises
    ------
    envfit.base._errors.MemoryBudgetError
        One line: the model's size options, what the plan needs and its largest stage, the
        budget and where it comes from, and the largest value of each option that fits alone
        (``--renderer-level``, and ``--nmax`` where a digital net's sampled points count,
        for the passes; ``--renderer-normals`` for the proposal), e.g. ``the renderer model
        at --renderer-level 11, 48 normals, spp to 65536 needs ~20 GB (…), the memory budget
        is 6.1 GB (80% of available memory): --renderer-level 10 fits``.
    """
    pixels = envmap.width * envmap.height
    resident = int(getattr(envmap.data, "nbytes", 0))
    plan = renderer_plan(pixels, opts, resident=resident)
    budget = memory_budget_bytes()
    if plan.fits(budget):
        return plan
    w = plan.worst()
    options = {"--renderer-normals": ("--renderer-normals",),
               "--renderer-level": ("--renderer-level", "--nmax")}.get(w.option, ())
    fixes = [f"{o} {v}" for o in options
             if (v := _largest_fitting(pixels, opts, o, plan.resident, budget)) is not None]
    what = "frames" if opts.microfacet else "normals"
    raise MemoryBudgetError(
        f"the renderer model at --renderer-level {opts.level}, {opts.normals} {what}, spp to "
        f"{opts.spp_cap()} needs ~{format_bytes(plan.peak())} ({w.name}: {w.detail}), the "
        f"memory budget is {format_bytes(budget)} ({budget_words()}): "
        + (f"{' or '.join(fixes)} fits" if fixes else
           "no smaller value of its options fits: free memory, raise ENVFIT_MEMORY_LIMIT or "
           "use a smaller map"))

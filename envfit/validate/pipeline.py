r"""Predicted errors checked against ground-truth shading integrals on a map (Figs. 7–8).

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals", Secs. 5, 7.2, 8 and 9.2.

What is measured
----------------
The map is put on a value scale (:func:`envfit.maps.scales.fit_scale`, ``display`` as the
paper's Table 2 or ``linear``); the scaled map's bilinear interpolant is the integrand f.
M axes :math:`a_m` are drawn uniformly on the sphere (seeded). For each BRDF p (diffuse,
glossy n = 30), the ground truth :math:`I(a_m) = \frac{1}{2\pi r_s}\int f\,p(u\cdot a_m)dS`
comes from :func:`envfit.shading.ground_truth.shading_integral` (exact SH of the bilinear interpolant).

* **Quadrature** (Eq. 34, Fig. 7): for each point set (``envfit.theory.pointsets``: sf, sobol,
  lp, bnot, random, jitter), N and weighting, the N points are morphed for p (importance
  sampling, Sec. 7.2: :math:`z = \sqrt{z'}` / Eq. 67), rotated into the frame of each axis
  (:func:`envfit.theory.pointsets.frame_from_axis`) with an independent seeded twist about the
  axis, and :math:`\tilde I(a_m) = \sum_j w_j f(R_m u_j)` with equal weights 1/N or the
  optimal sample weights (OSW, :func:`envfit.theory.weights.optimal_weights`, computed for the
  s used for the prediction). Measured: :math:`\mathrm{RMSE} = (\frac{1}{MC}\sum_{m,c}
  (\tilde I - I)^2)^{1/2}` (:func:`envfit.shading.estimators.rmse_over_axes`). Stochastic point
  sets use one realisation per N (seeded); its own worst-case error is the prediction.
* **Truncation** (Eq. 35, Fig. 8): SH truncation at degree L
  (:func:`envfit.shading.estimators.sh_truncation_curve`) on the full map and all axes; HSH
  truncation (:func:`envfit.shading.estimators.hsh_truncation_curve`, a clipped hemispherical
  quadrature per axis, the expensive part) on the map downscaled to
  ``hsh_max_height`` rows and the first ``hsh_axes`` axes, against a ground truth on
  that same downscaled map.

What is predicted
-----------------
The worst-case error E(s) of the rule (Eq. 41, the value of
:func:`envfit.theory.quadrature.worst_case_error`, computed by :func:`rule_worst_case_error`;
rotation invariant, so one number per rule) or of the truncation (Eqs. 51–52,
:func:`envfit.theory.truncation.truncation_error_curve`), for the map's fitted smoothness s
(``envfit fit``; or a given s). Three predictions of the RMSE:

(a) *shape only* (the paper, Sec. 9.2: "in accordance ... up to a multiplicative factor"):
    :math:`\hat R = c_p\,E`, one factor per BRDF p fitted in log space across all its rules
    (every point set, weighting and N): the least-squares solution of
    :math:`\min_c \sum (\log R_{meas} - \log c - \log E)^2`, i.e.
    :math:`\log c_p = \mathrm{mean}(\log R_{meas} - \log E)` — the geometric mean of the
    ratios (:func:`shape_constant`). The residual
    :math:`(\mathrm{mean}(\log_{10}R_{meas} - \log_{10}E - \log_{10}c_p)^2)^{1/2}` (dex,
    :func:`shape_residual`) says how well the theory's *shape* holds; it is also computed
    for other s (:data:`S_CANDIDATES`) to see which s makes the shapes match best (Sec. 9's
    claim that s ≈ 1.5 suits radiance maps).
(b) *absolute* (beyond the paper): under the Gaussian-process reading of the Sobolev
    model, f ~ GP(0, σ² K_gd^(s)), the error of any linear rule is Gaussian with
    :math:`E_f[(\tilde I - I)^2] = \sigma^2 E(s)^2` (E is the norm of the error's
    representer, Eq. 39). With σ̂ from the profiled likelihood (``envfit fit --method
    likelihood``, per channel, combined as RMS: :math:`\sigma = (\frac1C\sum_c
    \hat\sigma_c^2)^{1/2}`, matching the RMSE's mean over channels), the prediction
    :math:`\sigma E` uses no measured error at all (``predicted_rmse``).
(b') *refined absolute* (beyond the paper, ``predicted_rmse_refined``): the same model made
    exact for what a lat-long map is. (i) An H-row map holds no degree above H − 1 (the
    GP maps of :mod:`envfit.data_gen.gp` are band-limited exactly there), so the error spectrum
    Eq. 42 is summed only to l = H − 1 (:func:`bandlimited_worst_case_error`); (ii) the fit
    is of a zero-mean GP after removing the map's mean :math:`\bar m`, and a rule whose
    weights do not sum to 1 (OSW) errs by :math:`\bar m(\sum_j w_j - 1)` on it, for every
    axis: :math:`\hat R = (\sigma'^2 E'^2 + (\sum_j w_j - 1)^2\,\overline{m^2})^{1/2}`
    (:math:`\overline{m^2}` the mean over channels of the squared solid-angle mean);
    (iii) s and σ come from the likelihood of the same band-limited model
    (:mod:`envfit.kernels.bandlimited`: the kernel truncated at degree H − 1, samples at pixel
    centres), fitted beside the paper's fit (``s_refined``, ``sigma_refined``): the full
    kernel and bilinear lookups read a finite-resolution map as smoother than it is (ŝ
    about 0.04 too high on 256-row GP maps with s₀ = 1.5, 0.16 on 64-row ones), which made
    (b') 10 % low for random points; (iv) the estimators integrate the bilinear
    interpolant, whose power at degree l is the pixel field's times
    :math:`\tau_l` (:func:`envfit.shading.spectra.lookup_transfer`, ``lookup_transfer``; 1 at low
    degrees, 0.25 at H − 1), so degree l of the error spectrum is weighted by
    :math:`\tau_l`: :math:`E'^2 = \sum_{l\le H-1} a_l(\hat s')\,\tau_l\,e_l`
    (without it (b') was up to 35 % high for spherical Fibonacci points at N = 4096 on
    256-row maps, whose error lives near the band limit).
    One map is one realisation of the model: its power in degree l scatters as
    :math:`\chi^2_{(2l+1)C}`, so its RMSE departs from (b') by an expected relative standard
    deviation :func:`model_scatter` (``model_scatter``, large for rules whose error sits in a
    few low degrees: random points with equal weights) — reported beside the ratio.
(c) *spectral* (beyond the paper, no model, ``predicted_rmse_spectral``): the map's own power
    per degree :math:`\hat P_l` (:func:`map_degree_power`) times the rule's error power
    :math:`e_l` (:func:`rule_error_power`), :math:`(\frac1C\sum_{c,l}\hat P_{l,c}e_l)^{1/2}`
    (:func:`spectral_rmse`): the exact mean over random rotations on *this* map. It agrees with
    the measurement to its Monte Carlo error whenever the machinery is right; where (c) agrees
    and (b') does not, the map departs from the l^(-2s) model.

Agreement figures (:func:`agreement`): fitted log-log slopes over N ∈ [64, 4096]
(:func:`loglog_slope`, ``np.polyfit``) measured vs predicted; the ratio measured/predicted
across N; the rank order of the point sets (Kendall's τ, ``scipy.stats.kendalltau``, of the
geometric-mean levels over the slope range); the shape residual per candidate s; for (b)
the ratio predicted/measured per cell.

Costs (defaults, 1024×512 map, 2 idle cores; forest.exr: 159 s in all, 172 s with plots)
-----------------------------------------------------------------------------------------
* quadrature cells ≈ 134 s: N = 4096 alone 64 s, 2048 26 s, the rest < 45 s; OSW cells
  76 s against 58 s for equal weights (on 2 shared cores the same run took 290–420 s).
* bilinear lookups: M·ΣN = 2000·8176 ≈ 16 M per (BRDF, point set), ≈ 4 s with 2 threads;
  equal weights and OSW share them (:func:`quadrature_estimates_multi`);
* OSW: one float64 Cholesky of an N×N matrix per (BRDF, point set, N), ≈ 1–1.5 s at 4096
  (plus the 134 MB kernel matrix);
* BNOT: ≈ 15 s at N = 4096, ≈ 30 s for 16…4096 (cached in-process per (N, seed), shared by
  the two BRDFs): its cells cost 44 s against 16–19 s for the other sets;
* worst-case errors: O(N²), ≈ 0.05 s at 4096, once per candidate s (6 values);
  the band-limited spectrum (ducc0 adjoint SHT to degree H − 1) ≈ 0.05 s;
* the two fits of s (the paper's and the band-limited one; ``fit_n`` = 1500 samples, ~36
  Cholesky factorisations each) ≈ 4 s; the lookup transfer τ ≈ 0.7 s;
* HSH projections: ≈ 12 s for 250 axes on 128 rows up to L = 16 (the truncation part
  altogether ≈ 12–18 s);
* QMC-equivalent N (bisection over SF point sets up to ``equivalent_nmax`` = 4096) ≈ 5 s.

Resumable: every (brdf, pointset, weights, N) cell, the fit and each truncation curve is a
:class:`envfit.base.store.ResultStore` cell.

Example
-------
>>> import numpy as np
>>> from envfit.maps.envmap import EnvMap
>>> from envfit.data_gen.gp import gaussian_process_map
>>> env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp")
>>> cfg = ValidateConfig(s=1.5, brdfs=("diffuse",), pointsets=("sf",), weights=("equal",),
...                      n_values=(16, 64), axes=50, scale="linear", truncation=False,
...                      fit_n=200)
>>> res = run_validation(env, cfg)
>>> r = res["results"][0]
>>> r["pointset"], r["n"], len(r["measured_rmse"])
('sf', [16, 64], 2)
>>> bool(np.isclose(r["predicted_rmse"][0], res["sigma"] * r["predicted_wce"][0]))
True
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from envfit.theory.errors import TheoryParameterError
from envfit.theory.pointsets import POINTSETS, generate
from envfit.theory.truncation import equivalent_qmc_points, truncation_error_curve
from envfit.theory.weights import equal_weights, optimal_weights

from envfit.kernels.bandlimited import (map_band_limit)
from envfit.base.checks import check_int, check_ints, check_names, check_positive
from envfit.maps.envmap import EnvMap, check_sample_count
from envfit.base.errors import ParameterError
from envfit.shading.estimators import hsh_truncation_curve, rmse_over_axes, sh_truncation_curve
from envfit.base.progress import progress_bar
from envfit.base.resources import plan_memory
from envfit.maps.scales import check_not_constant, fit_scale
from envfit.shading.ground_truth import shading_integral, weight_function
from envfit.shading.spectra import (bandlimited_worst_case_error, bandlimited_worst_case_errors,  # noqa: F401
                      low_degree_power_ratio, lookup_transfer, map_degree_power, model_scatter,
                      pixel_degree_power, rule_error_power, sh_truncation_curve_transfer,
                      spectral_rmse)
from envfit.fit.sigma import bandlimited_profiled_sigma, combine_sigma, parse_s, profiled_sigma
from envfit.shading.quadrature import LOOKUP_BLOCK, quadrature_estimates_multi, random_axes
from envfit.theory.quadrature import worst_case_error
from envfit.validate.agreement import SLOPE_RANGE, agreement, loglog_slope, measured_equivalent_n
from envfit.base.store import ResultStore, array_fingerprint

__all__ = ["ValidateConfig", "quick_config", "run_validation", "plan_validation_memory",
           "map_statistics", "ALL_POINTSETS", "WEIGHTINGS", "BRDFS", "DEFAULT_N", "QUICK_N",
           "S_CANDIDATES", "QUICK_DESCRIPTION"]

#: the paper's six point sets (Sec. 7.1), in a fixed order (also the seed index)
ALL_POINTSETS = ("sf", "sobol", "lp", "bnot", "random", "jitter")
WEIGHTINGS = ("equal", "osw")
BRDFS = ("diffuse", "glossy")
DEFAULT_N = tuple(2 ** k for k in range(4, 13))            # 16 … 4096
QUICK_N = tuple(2 ** k for k in range(4, 11))              # 16 … 1024
QUICK_POINTSETS = ("sf", "sobol", "lp", "random", "jitter")
#: smoothness values against which the fitted s is compared (shape residual)
S_CANDIDATES = (1.1, 1.3, 1.5, 1.7, 1.9)

QUICK_DESCRIPTION = (
    "--quick: the map downscaled to at most 256 rows, M = 500 axes, N = 16…1024, point sets "
    "sf, sobol, lp, random, jitter (BNOT left out: its optimal-transport construction alone "
    "costs ~10 s at N = 1024), s fitted from 600 samples, SH truncation L = 0…12, HSH on 64 "
    "rows with 100 axes up to L = 10, QMC-equivalent N searched up to 1024.")

_BRDF_INDEX = {"diffuse": 0, "glossy": 1}
#: what a stored truncation cell's refined prediction means (a cell with another is redone)
_TRUNCATION_REFINED_MODEL = "band-limited fit; SH weighted by the lookup transfer"
_WEIGHT_INDEX = {"equal": 0, "osw": 1}


# ----------------------------------------------------------------------------- config

@dataclass
class ValidateConfig:
    """What :func:`run_validation` runs (the defaults are the full run of the issue).

    Attributes
    ----------
    s : "auto" (fit s and σ with ``fit_method`` from ``fit_n`` samples) or a value in (1, 2)
        (σ then from the profiled likelihood at that s, :func:`profiled_sigma`).
    brdfs, shininess : "diffuse" and/or "glossy" (n = ``shininess``).
    pointsets, weights, n_values : the quadrature rules (weights ∈ {"equal", "osw"}).
    axes : M, the number of random axes.
    scale : value scale of the integrand ("display", "linear", "log").
    seed : one seed for axes, twists, stochastic point sets and the fit.
    truncation : run the SH/HSH truncation experiment (Fig. 8).
    sh_L, hsh_L : cut-off degrees; diffuse HSH uses ``diffuse_hsh_L`` (exact from L = 1).
    hsh_axes, hsh_max_height : the cheaper setting of the HSH measurement.
    equivalent_nmax : largest N searched for the QMC-equivalent of a truncation.
    s_candidates : s values compared by the shape residual (the used s is added).
    fit_method, fit_n : the smoothness fit.
    workers : threads for the bilinear lookups and the O(N²) error sums.
    quick : only recorded (what ``--quick`` changed is in :data:`QUICK_DESCRIPTION`).
    """

    s: float | str = "auto"
    brdfs: Sequence[str] = BRDFS
    shininess: float = 30.0
    pointsets: Sequence[str] = ALL_POINTSETS
    weights: Sequence[str] = WEIGHTINGS
    n_values: Sequence[int] = DEFAULT_N
    axes: int = 2000
    scale: str = "display"
    seed: int = 0
    truncation: bool = True
    sh_L: Sequence[int] = tuple(range(0, 21))
    hsh_L: Sequence[int] = tuple(range(0, 17))
    diffuse_hsh_L: Sequence[int] = (0, 1, 2)
    hsh_axes: int = 250
    hsh_max_height: int = 128
    equivalent_nmax: int = 4096
    s_candidates: Sequence[float] = S_CANDIDATES
    fit_method: str = "likelihood"
    fit_n: int = 1500
    workers: int = 2
    quick: bool = False

    def __post_init__(self) -> None:
        self.s = parse_s(self.s)
        self.brdfs = tuple(check_names(self.brdfs, BRDFS, "BRDF"))
        self.pointsets = tuple(check_names(self.pointsets, tuple(POINTSETS), "point set"))
        self.weights = tuple(check_names(self.weights, WEIGHTINGS, "weighting"))
        self.shininess = check_positive(self.shininess, "shininess")
        self.n_values = tuple(sorted(set(check_ints(self.n_values, "N", 2))))
        self.axes = check_int(self.axes, "the number of axes", 2)
        self.sh_L = tuple(sorted(set(check_ints(self.sh_L, "L", 0))))
        self.hsh_L = tuple(sorted(set(check_ints(self.hsh_L, "L", 0))))
        self.diffuse_hsh_L = tuple(sorted(set(check_ints(self.diffuse_hsh_L, "L", 0))))
        self.hsh_axes = check_int(self.hsh_axes, "hsh_axes", 2)
        self.hsh_max_height = check_int(self.hsh_max_height, "hsh_max_height", 2)
        self.equivalent_nmax = check_int(self.equivalent_nmax, "equivalent_nmax", 2)
        self.fit_n = check_int(self.fit_n, "fit_n", 10)
        self.workers = max(1, int(self.workers))
        cands = []
        for v in self.s_candidates:
            cands.append(parse_s(v))
        self.s_candidates = tuple(sorted(set(float(c) for c in cands)))
        if self.scale not in ("display", "linear", "log"):
            raise ParameterError(f"scale must be display, linear or log, got {self.scale!r}")
        if not self.brdfs or not self.pointsets or not self.weights or not self.n_values:
            raise ParameterError("validate needs at least one BRDF, point set, weighting and N")

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def quick_config(**overrides) -> ValidateConfig:
    """The ``--quick`` configuration (:data:`QUICK_DESCRIPTION`), with ``overrides``.

    The map itself is downscaled by the caller (the CLI: ``--max-height 256``).

    >>> quick_config().axes, quick_config().n_values[-1]
    (500, 1024)
    """
    base = dict(axes=500, n_values=QUICK_N, pointsets=QUICK_POINTSETS, fit_n=600,
                sh_L=tuple(range(0, 13)), hsh_L=tuple(range(0, 11)), hsh_axes=100,
                hsh_max_height=64, equivalent_nmax=1024, quick=True)
    base.update(overrides)
    return ValidateConfig(**base)


# ----------------------------------------------------------------------------- building blocks


# ----------------------------------------------------------------------------- pipeline

def _cell_key(brdf: str, pointset: str, weights: str, n: int) -> str:
    return f"quad_{brdf}_{pointset}_{weights}_{n}"


def _s_key(s: float) -> str:
    return f"{float(s):.4f}"


def _twist_seed(seed: int, brdf: str, pointset: str, n: int) -> list[int]:
    return [int(seed), 12, _BRDF_INDEX[brdf], ALL_POINTSETS.index(pointset), int(n)]


def _error_stats(est: np.ndarray, truth: np.ndarray) -> dict:
    """RMSE (total, per channel), its relative standard error over axes, and the kurtosis."""
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


def _fit(envmap: EnvMap, cfg: ValidateConfig, store: ResultStore, quiet: bool, *,
         kernel: str = "full") -> dict:
    """s and σ per channel (a stored cell): ``kernel="full"`` the paper's fit (``cfg.fit_method``)
    for (a) and (b); ``"bandlimited"`` the likelihood of the band-limited model for (b').
    A given s (``cfg.s``) gets σ by the profiled likelihood of that kernel at it."""
    key = "fit" if kernel == "full" else "fit_bandlimited"
    cell = store.get(key)
    if cell is not None:
        cell["resumed"] = True
        return cell
    t0 = time.perf_counter()
    what = "" if kernel == "full" else "band-limited "
    if cfg.s == "auto":
        from envfit.fit.smoothness import fit_smoothness
        res = fit_smoothness(envmap, method=cfg.fit_method if kernel == "full" else "likelihood",
                             n=cfg.fit_n, scale=cfg.scale, seed=cfg.seed, kernel=kernel,
                             quiet=quiet)
        cell = {"s": float(res.s), "s_interval": [float(x) for x in res.s_interval],
                "sigma_channels": [float(x) for x in res.sigma], "band_lmax": res.band_lmax,
                "n": int(res.n), "source": "fit", "notes": list(res.notes),
                "method": res.method if kernel == "full" else
                "likelihood, kernel band-limited at H - 1, samples at pixel centres"}
    else:
        sc = fit_scale(cfg.scale, envmap)
        scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
        if kernel == "full":
            sig = profiled_sigma(scaled, float(cfg.s), n=cfg.fit_n, seed=cfg.seed)
            used, band = cfg.fit_n, None
        else:
            sig, used = bandlimited_profiled_sigma(scaled, float(cfg.s), n=cfg.fit_n, seed=cfg.seed)
            band = map_band_limit(scaled)
        cell = {"s": float(cfg.s), "s_interval": None, "sigma_channels": sig.tolist(),
                "band_lmax": band, "n": int(used), "source": "given", "notes": [],
                "method": f"given s; sigma by the {what}profiled likelihood at that s"}
    cell["seconds"] = time.perf_counter() - t0
    store.put(key, cell)
    cell["resumed"] = False
    return cell


def plan_validation_memory(envmap: EnvMap, cfg: ValidateConfig) -> None:
    """The memory guard of :func:`run_validation` (:func:`envfit.base.resources.plan_memory`),
    before any point is made: the quadrature rules at the largest N (the N x N kernel matrix
    of the OSW weights when ``"osw"`` is among the weightings; points, weights and
    ``workers`` lookup blocks) and the smoothness fit of ``fit_n`` samples."""
    from envfit.fit.smoothness import plan_fit_memory
    c = envmap.channels
    workers = max(1, int(cfg.workers))
    lookup = 8 * (8 + 2 * c) * workers                  # per direction of a lookup block
    plan_memory(cfg.n_values[-1], "validate's quadrature rules", channels=c,
                kernel="osw" in cfg.weights, per_n_bytes=8 * 16 + lookup,
                fixed_bytes=LOOKUP_BLOCK * lookup + 8 * envmap.width * envmap.height * (c + 4)
                + 8 * cfg.axes * (9 + 2 * c * len(cfg.weights)))
    plan_fit_memory(cfg.fit_n, envmap.width, envmap.height, c, method=cfg.fit_method,
                    what="validate's smoothness fit", n_name="fit_n")


def run_validation(envmap: EnvMap, config: ValidateConfig | None = None, *,
                   out: str | Path | None = None, quiet: bool = True,
                   on_cell: Callable[[str, bool], None] | None = None) -> dict:
    """Run the validation on ``envmap`` (see the module docstring); returns the JSON-ready dict.

    Parameters
    ----------
    envmap : the map on its raw (linear) values; ``config.scale`` is applied here.
    config : :class:`ValidateConfig` (default: the full run).
    out : folder of the resumable cells (:class:`envfit.base.store.ResultStore`); None = memory.
    quiet : no progress bar.
    on_cell : called as ``on_cell(key, resumed)`` after every stored cell.

    Returns
    -------
    ``{"map", "s", "sigma", "sigma_channels", "scale", "fit", "config", "results",
    "truncation", "agreement", "timings", "notes", "map_stats"}`` with ``results`` and
    ``truncation`` as documented in the CLI (per rule: ``n``, ``measured_rmse``,
    ``predicted_wce``, ``predicted_rmse`` = σ·wce, ``predicted_shape`` = c_p·wce,
    ``slope_measured``, ``slope_predicted``, …).
    """
    cfg = config or ValidateConfig()
    t_start = time.perf_counter()
    plan_validation_memory(envmap, cfg)          # before anything of size N or fit_n
    check_sample_count(cfg.fit_n, envmap.width, envmap.height, name=envmap.name, what="fit_n")
    timings = {"fit": 0.0, "truth": 0.0, "quadrature": 0.0, "truncation": 0.0,
               "equivalents": 0.0}
    sc = fit_scale(cfg.scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, cfg.scale, envmap.name)
    store_cfg = {"map": envmap.name, "fingerprint": array_fingerprint(envmap.data),
                 "up": envmap.up, "scale": cfg.scale, "s": cfg.s, "fit_method": cfg.fit_method,
                 "fit_n": cfg.fit_n, "seed": cfg.seed, "axes": cfg.axes,
                 "shininess": cfg.shininess, "s_candidates": list(cfg.s_candidates),
                 "hsh_axes": cfg.hsh_axes, "hsh_max_height": cfg.hsh_max_height,
                 "equivalent_nmax": cfg.equivalent_nmax}
    store = ResultStore(out, store_cfg, kind="validate")

    fit = _fit(envmap, cfg, store, quiet)
    timings["fit"] = 0.0 if fit["resumed"] else fit["seconds"]
    if on_cell:
        on_cell("fit", fit["resumed"])
    s_used = float(fit["s"])
    sigma_ch = [float(x) for x in fit["sigma_channels"]]
    sigma = combine_sigma(sigma_ch)
    fit_ref = _fit(envmap, cfg, store, quiet, kernel="bandlimited")  # for prediction (b')
    timings["fit"] += 0.0 if fit_ref["resumed"] else fit_ref["seconds"]
    if on_cell:
        on_cell("fit_bandlimited", fit_ref["resumed"])
    s_ref = float(fit_ref["s"])
    sigma_ref_ch = [float(x) for x in fit_ref["sigma_channels"]]
    sigma_ref = combine_sigma(sigma_ref_ch)
    s_by_key = {_s_key(x): float(x) for x in cfg.s_candidates}
    s_by_key[_s_key(s_used)] = s_used          # the used s exactly (the OSW weights' s)
    s_list = [s_by_key[k] for k in sorted(s_by_key)]

    axes = random_axes(cfg.axes, [cfg.seed, 11])
    band_lmax = scaled.height - 1          # the highest degree an H-row lat-long map holds
    # RMS over channels of the map's mean: a rule with sum(w) != 1 errs by mean*(sum(w) - 1)
    mean_rms = float(np.sqrt(np.mean(scaled.mean() ** 2)))
    weights_obj = {b: weight_function(b, cfg.shininess) for b in cfg.brdfs}
    truths: dict[str, np.ndarray] = {}
    map_power = map_degree_power(scaled, band_lmax)                     # (C, H): prediction (c)
    # (b'): the bilinear lookup's transfer τ_l (interpolant power / pixel power)
    transfer = lookup_transfer(map_power, pixel_degree_power(scaled, band_lmax))

    def truth(b: str) -> np.ndarray:
        if b not in truths:
            t0 = time.perf_counter()
            truths[b] = shading_integral(scaled, axes, b, cfg.shininess)
            timings["truth"] += time.perf_counter() - t0
        return truths[b]

    # ---- quadrature cells
    total_cells = len(cfg.brdfs) * len(cfg.pointsets) * len(cfg.weights) * len(cfg.n_values)
    bar = progress_bar(total_cells, desc="validate: quadrature", quiet=quiet, unit="cell")
    cells: dict[str, dict] = {}
    t_quad = time.perf_counter()
    try:
        for b in cfg.brdfs:
            wf = weights_obj[b]
            for ps in cfg.pointsets:
                for n in cfg.n_values:
                    keys = {w: _cell_key(b, ps, w, n) for w in cfg.weights}
                    todo = []
                    for w, k in keys.items():
                        c = store.get(k)
                        if c is not None and c.get("band_lmax") == band_lmax \
                                and "error_power" in c and all(
                                sk in c.get("wce", {}) and sk in c.get("wce_bandlimited_by_s", {})
                                for sk in map(_s_key, s_list)):
                            cells[k] = c
                            bar.update(1)
                            if on_cell:
                                on_cell(k, True)
                        else:
                            todo.append(w)
                    if not todo:
                        continue
                    done = _compute_cells(scaled, axes, truth, b, wf, ps, n, todo, s_used,
                                          s_list, cfg, band_lmax)
                    for w, c in done.items():
                        store.put(keys[w], c)
                        cells[keys[w]] = c
                        bar.update(1)
                        if on_cell:
                            on_cell(keys[w], False)
    finally:
        bar.close()
    timings["quadrature"] = time.perf_counter() - t_quad - timings["truth"]

    results = []
    for b in cfg.brdfs:
        for ps in cfg.pointsets:
            for w in cfg.weights:
                cs = [cells[_cell_key(b, ps, w, n)] for n in cfg.n_values]
                wce = [c["wce"].get(_s_key(s_used)) for c in cs]
                entry = {"brdf": b, "pointset": ps, "weights": w,
                         "n": [int(n) for n in cfg.n_values],
                         "measured_rmse": [c["measured_rmse"] for c in cs],
                         "predicted_wce": wce,
                         "predicted_rmse": [None if v is None else sigma * v for v in wce],
                         "predicted_wce_bandlimited": [
                             None if c.get("error_power") is None else
                             bandlimited_worst_case_errors(None, None, None, [s_ref], band_lmax,
                                                           power=c["error_power"],
                                                           transfer=transfer)[0]
                             for c in cs],
                         "mean_error": [None if c.get("weight_sum") is None
                                        else abs(c["weight_sum"] - 1.0) * mean_rms for c in cs],
                         "band_lmax": band_lmax,
                         "measured_rmse_channels": [c["measured_rmse_channels"] for c in cs],
                         "measured_rel_se": [c["measured_rel_se"] for c in cs],
                         "error_kurtosis": [c["error_kurtosis"] for c in cs],
                         "weight_sum": [c["weight_sum"] for c in cs],
                         "wce_by_s": {sk: [c["wce"].get(sk) for c in cs] for sk in map(_s_key, s_list)},
                         "wce_bandlimited_by_s": {sk: [c["wce_bandlimited_by_s"].get(sk) for c in cs]
                                                  for sk in map(_s_key, s_list)},
                         "errors": [c.get("error") for c in cs],
                         "seconds": [c.get("seconds") for c in cs]}
                entry["predicted_rmse_refined"] = [
                    None if (wb is None or me is None) else math.hypot(sigma_ref * wb, me)
                    for wb, me in zip(entry["predicted_wce_bandlimited"], entry["mean_error"])]
                entry["predicted_rmse_spectral"] = [
                    None if c.get("error_power") is None else spectral_rmse(c["error_power"], map_power)
                    for c in cs]
                entry["model_scatter"] = [
                    None if (c.get("error_power") is None or me is None)
                    else model_scatter(c["error_power"], s_ref, sigma_ref_ch, me,
                                       transfer=transfer)
                    for c, me in zip(cs, entry["mean_error"])]
                entry["slope_measured"] = loglog_slope(entry["n"], entry["measured_rmse"])
                entry["slope_predicted"] = loglog_slope(entry["n"], wce)
                entry["slope_predicted_refined"] = loglog_slope(
                    entry["n"], entry["predicted_rmse_refined"])
                results.append(entry)

    # ---- truncation
    trunc = []
    if cfg.truncation:
        t_tr = time.perf_counter()
        trunc = _truncation(scaled, axes, truth, cfg, s_used, sigma, store, quiet, on_cell,
                            timings, s_ref=s_ref, sigma_ref=sigma_ref, transfer=transfer)
        timings["truncation"] = time.perf_counter() - t_tr - timings["equivalents"]

    agr = agreement(results, trunc, s_used=s_used, slope_range=SLOPE_RANGE)
    # fill the shape prediction (a) with the fitted constants
    for e in results:
        c = agr["shape_fit"]["constant"].get(e["brdf"])
        e["predicted_shape"] = [None if (c is None or v is None) else c * v for v in e["predicted_wce"]]
    for t in trunc:
        c = agr["shape_fit"]["constant"].get(t["brdf"])
        t["predicted_shape"] = [None if (c is None or v is None) else c * v for v in t["predicted_wce"]]
    # the measured QMC equivalent of each truncation, from the measured SF/equal curve
    for t in trunc:
        ref = next((e for e in results if e["brdf"] == t["brdf"] and e["pointset"] == "sf"
                    and e["weights"] == "equal"), None)
        t["measured_qmc_equivalent_n"] = [
            None if ref is None else measured_equivalent_n(ref["n"], ref["measured_rmse"], v)
            for v in t["measured_rmse"]]

    timings["total"] = time.perf_counter() - t_start
    # what the whole result cost to compute, resumed parts included (stored per cell)
    timings["compute"] = (float(fit.get("seconds") or 0.0) + timings["truth"]
                          + sum(float(s or 0.0) for e in results for s in e["seconds"])
                          + sum(float(t.get("seconds") or 0.0) for t in trunc))
    costs = {"by_pointset": {}, "by_weights": {}, "by_n": {}}
    for e in results:
        for n, sec in zip(e["n"], e["seconds"]):
            if sec is None:
                continue
            for key, name in (("by_pointset", e["pointset"]), ("by_weights", e["weights"]),
                              ("by_n", str(n))):
                costs[key][name] = costs[key].get(name, 0.0) + float(sec)
    notes = list(envmap.notes)
    store.close()                # every cell is written: release the --out folder's lock
    notes.extend(store.notes)    # cells recomputed because they were not sound (also on stderr)
    notes.extend(fit.get("notes", []))
    notes.extend(f"refined fit: {x}" for x in fit_ref.get("notes", []))
    return {
        "map": envmap.name, "map_size": [envmap.width, envmap.height],
        "channels": envmap.channels,
        "s": s_used, "sigma": sigma, "sigma_channels": sigma_ch,
        "s_refined": s_ref, "sigma_refined": sigma_ref, "sigma_refined_channels": sigma_ref_ch,
        "fit_refined": {k: v for k, v in fit_ref.items() if k != "resumed"},
        "lookup_transfer": [float(x) for x in transfer],
        "scale": cfg.scale, "scale_description": sc.describe(),
        "fit": {k: v for k, v in fit.items() if k != "resumed"},
        "config": cfg.to_dict(), "quick_description": QUICK_DESCRIPTION if cfg.quick else None,
        "axes": cfg.axes, "seed": cfg.seed,
        "results": results, "truncation": trunc, "agreement": agr,
        "map_stats": {**map_statistics(envmap, scaled, sc),
                      "power_ratio_low_degrees": low_degree_power_ratio(scaled, sigma_ref_ch,
                                                                        s_ref)},
        "timings": timings, "costs": costs, "notes": notes,
        "unwritten": [list(u) for u in store.unwritten],
    }


def _compute_cells(scaled: EnvMap, axes, truth, brdf: str, wf, pointset: str, n: int,
                   todo: list[str], s_used: float, s_list: list[float],
                   cfg: ValidateConfig, band_lmax: int) -> dict[str, dict]:
    """Compute the cells (brdf, pointset, n, w) for the weightings in ``todo`` (shared lookups)."""
    t0 = time.perf_counter()
    pts = generate(pointset, n, seed=cfg.seed, morph=wf.morph)
    t_pts = time.perf_counter() - t0
    wsets, errors, t_w = {}, {}, {}
    for w in todo:
        t1 = time.perf_counter()
        if w == "equal":
            wsets[w] = equal_weights(n)
        else:
            try:
                wsets[w] = optimal_weights(pts, wf, s_used)
            except (TheoryParameterError, ParameterError) as exc:
                errors[w] = str(exc)
        t_w[w] = time.perf_counter() - t1
    out: dict[str, dict] = {}
    ok = [w for w in todo if w in wsets]
    if ok:
        truth_b = truth(brdf)
        t1 = time.perf_counter()
        est = quadrature_estimates_multi(scaled, axes, pts, [wsets[w] for w in ok],
                                         seed=_twist_seed(cfg.seed, brdf, pointset, n),
                                         workers=cfg.workers)
        t_est = (time.perf_counter() - t1) / len(ok)
        for k, w in enumerate(ok):
            t2 = time.perf_counter()
            wce = {_s_key(s): worst_case_error(pts, wsets[w], wf, s, workers=cfg.workers)
                   for s in s_list}
            power = rule_error_power(pts, wsets[w], wf, band_lmax)
            band = dict(zip(map(_s_key, s_list),
                            bandlimited_worst_case_errors(pts, wsets[w], wf, s_list, band_lmax,
                                                          power=power)))
            cell = {"brdf": brdf, "pointset": pointset, "weights": w, "n": int(n),
                    **_error_stats(est[k], truth_b), "wce": wce,
                    "wce_bandlimited": band[_s_key(s_used)], "wce_bandlimited_by_s": band,
                    "band_lmax": band_lmax, "error_power": power.tolist(),
                    "weight_sum": float(np.sum(wsets[w])), "error": None}
            cell["seconds"] = t_pts / len(todo) + t_w[w] + t_est + (time.perf_counter() - t2)
            out[w] = cell
    for w, msg in errors.items():
        out[w] = {"brdf": brdf, "pointset": pointset, "weights": w, "n": int(n),
                  "measured_rmse": None, "measured_rmse_channels": None, "measured_rel_se": None,
                  "error_kurtosis": None, "wce": {_s_key(s): None for s in s_list},
                  "wce_bandlimited": None, "band_lmax": band_lmax,
                  "wce_bandlimited_by_s": {_s_key(s): None for s in s_list},
                  "error_power": None, "weight_sum": None, "error": msg, "seconds": t_w[w]}
    return out


def _truncation(scaled: EnvMap, axes, truth, cfg: ValidateConfig, s_used: float, sigma: float,
                store: ResultStore, quiet: bool, on_cell, timings: dict, *, s_ref: float,
                sigma_ref: float, transfer: np.ndarray) -> list[dict]:
    """The SH / HSH truncation curves (Fig. 8) with their predictions and QMC equivalents."""
    jobs = []
    for b in cfg.brdfs:
        jobs.append((b, "sh", list(cfg.sh_L)))
        jobs.append((b, "hsh", list(cfg.diffuse_hsh_L if b == "diffuse" else cfg.hsh_L)))
    hsh_env = scaled.resized(min(cfg.hsh_max_height, scaled.height))
    hsh_axes = axes[:min(cfg.hsh_axes, axes.shape[0])]
    hsh_truth: dict[str, np.ndarray] = {}
    out = []
    bar = progress_bar(len(jobs), desc="validate: truncation", quiet=quiet, unit="curve")
    try:
        for b, basis, Ls in jobs:
            key = f"trunc_{b}_{basis}"
            cell = store.get(key)
            wf = weight_function(b, cfg.shininess)
            if cell is None or cell.get("L") != Ls or abs(cell.get("s", -1) - s_used) > 1e-12 \
                    or abs(cell.get("s_refined", -1) - s_ref) > 1e-12 \
                    or cell.get("refined_model") != _TRUNCATION_REFINED_MODEL:
                t0 = time.perf_counter()
                if basis == "sh":
                    est = sh_truncation_curve(scaled, axes, b, Ls, shininess=cfg.shininess)
                    r = rmse_over_axes(est, truth(b))
                    m_axes, height = axes.shape[0], scaled.height
                else:
                    if b not in hsh_truth:
                        t1 = time.perf_counter()
                        hsh_truth[b] = shading_integral(hsh_env, hsh_axes, b, cfg.shininess)
                        timings["truth"] += time.perf_counter() - t1
                    est = hsh_truncation_curve(hsh_env, hsh_axes, b, Ls, shininess=cfg.shininess)
                    r = rmse_over_axes(est, hsh_truth[b])
                    m_axes, height = hsh_axes.shape[0], hsh_env.height
                wce_curve = truncation_error_curve(wf, s_used, max(Ls), basis)
                wce = [float(wce_curve[L]) for L in Ls]
                band_l = height - 1
                if band_l > max(Ls) and basis == "sh":
                    # SH truncation errs on degrees l > L of the interpolant: weighted by τ_l
                    bc = sh_truncation_curve_transfer(wf, s_ref, max(Ls), band_l, transfer)
                    wce_band = [float(bc[L]) for L in Ls]
                elif band_l > max(Ls):
                    # HSH (on the downscaled map) is not diagonal in l: no transfer (its error
                    # lives at degrees <= ~20, where τ > 0.97 on 128 rows)
                    bc = truncation_error_curve(wf, s_ref, max(Ls), basis, lmax=band_l)
                    wce_band = [float(bc[L]) for L in Ls]
                else:
                    wce_band = [None] * len(Ls)
                t_eq = time.perf_counter()
                equiv = _equivalents(wce, wf, s_used, cfg.equivalent_nmax)
                timings["equivalents"] += time.perf_counter() - t_eq
                cell = {"brdf": b, "basis": basis, "L": Ls,
                        "measured_rmse": np.atleast_1d(r.total).tolist(),
                        "predicted_wce": wce, "predicted_wce_bandlimited": wce_band,
                        "band_lmax": band_l, "qmc_equivalent_n": equiv,
                        "axes": int(m_axes), "map_height": int(height), "s": s_used,
                        "s_refined": s_ref, "refined_model": _TRUNCATION_REFINED_MODEL,
                        "seconds": time.perf_counter() - t0}
                store.put(key, cell)
                if on_cell:
                    on_cell(key, False)
            elif on_cell:
                on_cell(key, True)
            cell = dict(cell)
            cell["predicted_rmse"] = [sigma * v for v in cell["predicted_wce"]]
            # truncation keeps b_0 exactly: no error from the map's mean
            cell["predicted_rmse_refined"] = [None if v is None else sigma_ref * v
                                              for v in cell["predicted_wce_bandlimited"]]
            out.append(cell)
            bar.update(1)
    finally:
        bar.close()
    return out


def _equivalents(wces: Sequence[float], wf, s: float, nmax: int) -> list[int | None]:
    """QMC-equivalent N (morphed SF, equal weights; :func:`envfit.theory.truncation.equivalent_qmc_points`)
    of each worst-case error; None for 0 or beyond ``nmax``. Equal targets are searched once,
    and once a target needs more than ``nmax`` points every smaller one is skipped."""
    found: dict[float, int | None] = {}
    beyond = 0.0                           # largest target known to need > nmax points
    out = []
    for v in wces:
        if v is None or not (v > 0 and math.isfinite(v)) or v <= beyond:
            out.append(None)
            continue
        if v not in found:
            try:
                found[v] = int(equivalent_qmc_points(v, wf, s, nmax=nmax))
            except TheoryParameterError:
                found[v] = None
                beyond = v
        out.append(found[v])
    return out


def map_statistics(envmap: EnvMap, scaled: EnvMap, scale) -> dict:
    r"""Diagnostics for the report: dynamic range (peak / mean luminance on the linear map),
    the fraction of solid angle holding half of the linear energy, and, on the display
    scale, the fraction of pixels clipped at 1 (where the display transform flattens a sun).
    """
    y = envmap.luminance()
    om = envmap.solid_angles()
    e = y * om
    tot = float(e.sum())
    mean = tot / float(om.sum())
    stats_: dict = {"peak_over_mean": float(y.max() / mean) if mean > 0 else None}
    if tot > 0:
        order = np.argsort(e.ravel())[::-1]
        cum = np.cumsum(e.ravel()[order])
        k = int(np.searchsorted(cum, 0.5 * tot)) + 1
        stats_["solid_angle_fraction_half_energy"] = float(om.ravel()[order[:k]].sum() / om.sum())
    else:
        stats_["solid_angle_fraction_half_energy"] = None
    if scale.name == "display":
        clipped = np.any(envmap.data * scale.exposure >= 1.0, axis=2)
        stats_["display_clipped_fraction"] = float((om * clipped).sum() / om.sum())
    else:
        stats_["display_clipped_fraction"] = None
    sd = scaled.data
    stats_["scaled_min"] = float(sd.min())
    stats_["scaled_max"] = float(sd.max())
    return stats_


# ----------------------------------------------------------------------------- agreement


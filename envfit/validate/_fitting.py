r"""The two fits of ``envfit validate``, each a stored cell: the paper's (s and σ for
predictions (a) and (b)) and the band-limited model's (ŝ′, σ̂′ for (b′))."""
from __future__ import annotations

import time

import numpy as np

from envfit.base import ResultStore
from envfit.fit import bandlimited_profiled_sigma, profiled_sigma
from envfit.sobolev import map_band_limit
from envfit.maps import EnvMap
from envfit.maps import fit_scale

from envfit.validate._config import ValidateConfig

__all__ = ["fit_cell", "fit_both"]


def fit_cell(envmap: EnvMap, cfg: ValidateConfig, store: ResultStore, quiet: bool, *,
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
        from envfit.fit import fit_smoothness
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


def fit_both(envmap: EnvMap, cfg: ValidateConfig, store: ResultStore, quiet: bool,
             on_cell=None) -> tuple[dict, dict, float]:
    """The paper's fit and the band-limited one (:func:`fit_cell`), each reported to
    ``on_cell(key, resumed)``; returns ``(fit, fit_bandlimited, seconds)``, the seconds
    spent now (0 for a resumed cell)."""
    fits, seconds = [], 0.0
    for kernel, key in (("full", "fit"), ("bandlimited", "fit_bandlimited")):
        cell = fit_cell(envmap, cfg, store, quiet, kernel=kernel)
        seconds += 0.0 if cell["resumed"] else cell["seconds"]
        if on_cell:
            on_cell(key, cell["resumed"])
        fits.append(cell)
    return fits[0], fits[1], seconds

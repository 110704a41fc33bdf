"""Benchmark and accuracy report for the shading ground truth and the estimators.

Run:  /tmp/venv/bin/python bench/bench_shading.py [--height 512] [--axes 10000] [--json out.json]

Measures (median of 3 fresh calls where timed, wall clock, this machine's threads):

1. ``shading_integral(method="sh")`` on an H×2H RGB sun-and-sky map for M axes, diffuse and
   glossy n = 30 (the target: 10 000 axes on 1024×512 in a few seconds);
2. ``method="pixels"`` (the reference) on a few axes: time per axis, and the agreement
   with the SH method, for the diffuse lobe at several SH degrees (the truncation tail);
3. how much the choice of *function* matters (H = 64, 128): the integral of the bilinear
   interpolant (the ground truth) against that of the piecewise-constant pixels and of the
   band-limited interpolant of the pixel centres (ducc0 analysis on the F1 grid, lmax = H − 1);
4. the estimators: quadrature (2000 axes × 4096 points), SH truncation curve, HSH curve.

Synthetic maps only (data_gen), so it runs anywhere.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
import ducc0


from envfit.data_gen import SkyGradientMap, SunSkyMap, gaussian_process_map  # noqa: E402
from envfit.maps import EnvMap  # noqa: E402
from envfit.shading import (default_sh_lmax, funk_hecke_factors,  # noqa: E402
                            hsh_truncation_curve, quadrature_estimates, rmse_over_axes,
                            sh_truncation_curve, shading_integral, weight_function)
from envfit.shading._bilinear_sh import synthesize_convolution  # noqa: E402  # internal: the SH method's step
from envfit.shading._patches import axes_to_local  # noqa: E402  # internal: the ground truth's frame
from envfit.theory._weight_function import gauss_legendre_01  # noqa: E402  # internal: the product's GL rule


def _timed(fn, repeat=3):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times, out


def _axes(n, seed=0):
    a = np.random.default_rng(seed).standard_normal((n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def sun_sky_map(height: int) -> EnvMap:
    sun = SunSkyMap(sun_theta=1.0, sun_phi=0.5, sun_radius=0.05, sun_radiance=(100.0, 90.0, 70.0),
                    sky=SkyGradientMap(horizon=(1.0, 0.8, 0.6), zenith=(0.4, 0.6, 1.2)))
    return EnvMap(sun.render(height), name=f"sunsky{height}")


def piecewise_constant_integral(m: EnvMap, axes, weight, q: int = 4) -> np.ndarray:
    """Σ_p v_p ∫_cell p(u·a) dS / (2π r_s): the pixels as a piecewise-constant function
    (q×q Gauss–Legendre per pixel cell; for comparison only)."""
    h, w, c = m.data.shape
    x, wq = gauss_legendre_01(q)                                 # nodes, weights on [0, 1]
    th = (np.pi * (np.arange(h)[:, None] + x[None, :]) / h).ravel()
    wth = (np.pi / h * wq[None, :] * np.ones((h, 1))).ravel() * np.sin(th)
    ph = (2 * np.pi * (np.arange(w)[:, None] + x[None, :]) / w).ravel()
    wph = np.tile(2 * np.pi / w * wq, w)
    vals = np.repeat(np.repeat(m.data.astype(np.float64), q, axis=0), q, axis=1)
    wf = (vals * (wth[:, None, None] * wph[None, :, None])).reshape(-1, c)
    loc = axes_to_local(axes, m.up)
    r_s = float(weight.r_s)
    out = np.empty((loc.shape[0], c))
    st, ct = np.sin(th), np.cos(th)
    for k, a in enumerate(loc):
        z = (st[:, None] * (np.cos(ph) * a[0] + np.sin(ph) * a[1])[None, :] + ct[:, None] * a[2])
        out[k] = weight.p(z).ravel() @ wf
    return out / (2 * np.pi * r_s)


def bandlimited_integral(m: EnvMap, axes, weight) -> np.ndarray:
    """The band-limited interpolant of the pixel centres (ducc0 analysis_2d, F1, lmax = H−1)."""
    h, w, c = m.data.shape
    L = h - 1
    lam = funk_hecke_factors(weight, L)
    alm = np.stack([ducc0.sht.analysis_2d(map=np.ascontiguousarray(m.data[None, :, :, ch],
                                                                    dtype=np.float64),
                                          spin=0, lmax=L, geometry="F1", phi0=np.pi / w)[0]
                    for ch in range(c)])
    return synthesize_convolution(alm, L, lam, axes_to_local(axes, m.up))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--axes", type=int, default=10000)
    ap.add_argument("--pixel-axes", type=int, default=20)
    ap.add_argument("--json", type=str, default=None)
    args = ap.parse_args(argv)
    rep: dict = {"height": args.height, "axes": args.axes}
    H = args.height
    m = sun_sky_map(H)
    axes = _axes(args.axes)
    print(f"map {m.width}x{m.height}x{m.channels} (sun-and-sky), {len(axes)} axes")

    # 1. SH method
    for name, brdf in (("diffuse", "diffuse"), ("glossy30", "glossy")):
        w = weight_function(brdf, 30)
        L = default_sh_lmax(w, H)
        med, times, val = _timed(lambda: shading_integral(m, axes, brdf, 30))
        rep[f"sh_{name}"] = {"lmax": L, "median_s": med, "times_s": times}
        print(f"[sh] {name:9s} lmax={L:4d}: median {med:.2f} s  (runs {', '.join(f'{t:.2f}' for t in times)})")
        rep[f"_val_{name}"] = val

    # 2. pixel reference on a few axes
    sub = axes[:args.pixel_axes]
    for name, brdf in (("diffuse", "diffuse"), ("glossy30", "glossy")):
        t = time.perf_counter()
        pix = shading_integral(m, sub, brdf, 30, method="pixels")
        dt = time.perf_counter() - t
        scale = np.abs(pix).max()
        line = {"axes": len(sub), "seconds": dt, "per_axis_s": dt / len(sub)}
        if name == "diffuse":
            for L in sorted({H - 1, 2 * H - 1, 255, 511} - {0}):
                sh = shading_integral(m, sub, brdf, lmax=L)
                line[f"maxrel_sh_lmax{L}"] = float(np.abs(sh - pix).max() / scale)
        sh = rep[f"_val_{name}"][:len(sub)]
        line["maxrel_sh_default"] = float(np.abs(sh - pix).max() / scale)
        rep[f"pixels_{name}"] = line
        print(f"[pixels] {name:9s} {len(sub)} axes: {dt:.2f} s ({dt / len(sub):.3f} s/axis); "
              + "; ".join(f"{k}={v:.1e}" for k, v in line.items() if k.startswith("maxrel")))

    # 3. which function: bilinear (truth) vs piecewise-constant vs band-limited
    # (H = 64 and 128 with 4x4 Gauss points per pixel cell: the piecewise-constant reference's
    # own kink error ~h²/(12·16) stays well below the differences it measures; they scale as h²)
    for hh in (64, 128):
        mm = m if hh == H else sun_sky_map(hh)
        gp = EnvMap(gaussian_process_map(1.5, hh, seed=1, channels=1, offset=4.0), name="gp")
        for mapname, mp in (("sunsky", mm), ("gp", gp)):
            sub2 = axes[:200]
            for name, brdf in (("diffuse", "diffuse"), ("glossy30", "glossy")):
                wgt = weight_function(brdf, 30)
                truth = shading_integral(mp, sub2, brdf, 30)
                pc = piecewise_constant_integral(mp, sub2, wgt, q=4)
                bl = bandlimited_integral(mp, sub2, wgt)
                spread = np.abs(truth - truth.mean(axis=0)).max()
                d = {"rms_rel_const": float(np.sqrt(np.mean((pc - truth) ** 2)) / np.abs(truth).mean()),
                     "rms_rel_bandlimited": float(np.sqrt(np.mean((bl - truth) ** 2)) / np.abs(truth).mean()),
                     "max_rel_const": float(np.abs(pc - truth).max() / np.abs(truth).max()),
                     "max_rel_bandlimited": float(np.abs(bl - truth).max() / np.abs(truth).max()),
                     "rel_to_spread_const": float(np.abs(pc - truth).max() / spread)}
                rep[f"function_{mapname}{hh}_{name}"] = d
                print(f"[function] {mapname}{hh} {name:9s}: piecewise-constant rms {d['rms_rel_const']:.1e} "
                      f"max {d['max_rel_const']:.1e} (max/spread over axes {d['rel_to_spread_const']:.1e}); "
                      f"band-limited rms {d['rms_rel_bandlimited']:.1e} max {d['max_rel_bandlimited']:.1e}")

    # 4. estimators
    n = 4096
    j = np.arange(n)
    zp = 1.0 - (2 * j + 1) / (2.0 * n)
    phi = 2 * np.pi * np.mod(j * (np.sqrt(5.0) - 1.0) / 2.0, 1.0)
    z = np.sqrt(zp)
    pts = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    qa = axes[:2000]
    med, times, est = _timed(lambda: quadrature_estimates(m, qa, pts, np.full(n, 1.0 / n), seed=0), 1)
    ref = rep["_val_diffuse"][:len(qa)]
    rmse = rmse_over_axes(est, ref).total / np.abs(ref).mean()
    rep["quadrature_2000x4096"] = {"axes": len(qa), "seconds": med, "relative_rmse": float(rmse)}
    print(f"[estimators] quadrature {len(qa)} axes x 4096 SF points (diffuse): {med:.2f} s "
          f"(RMSE / mean {rmse:.2e})")
    Ls = list(range(0, 21))
    med, times, curve = _timed(lambda: sh_truncation_curve(m, axes, "glossy", Ls), 1)
    rm = rmse_over_axes(curve, rep["_val_glossy30"]).total
    rep["sh_curve_L0_20"] = {"seconds": med, "rmse": [float(v) for v in rm]}
    print(f"[estimators] SH truncation curve L=0..20, {len(axes)} axes, glossy: {med:.2f} s; "
          f"RMSE L=0,5,10,20: {rm[0]:.2e} {rm[5]:.2e} {rm[10]:.2e} {rm[20]:.2e}")
    mh = m.resized(128) if H > 128 else m
    ha = axes[:200]
    truth = shading_integral(mh, ha, "glossy", 30)
    med, times, curve = _timed(lambda: hsh_truncation_curve(mh, ha, "glossy", [1, 2, 5, 10]), 1)
    rm = rmse_over_axes(curve, truth).total
    rep["hsh_curve"] = {"height": mh.height, "axes": len(ha), "seconds": med,
                        "rmse": [float(v) for v in rm]}
    print(f"[estimators] HSH truncation curve L=1,2,5,10 on {mh.width}x{mh.height}, {len(ha)} axes, "
          f"glossy: {med:.2f} s; RMSE {', '.join(f'{v:.2e}' for v in rm)}")

    if args.json:
        Path(args.json).write_text(json.dumps({k: v for k, v in rep.items()
                                               if not k.startswith("_")}, indent=1))
    return rep


if __name__ == "__main__":
    main()

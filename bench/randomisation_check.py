"""Big brute-force check of the exact randomisation predictions
(envfit.predict.renderer.randomisation): for every method and N, the predicted MSE against the
mean over many randomisations of the points themselves — numpy constructions (the test
oracles: i.i.d., jittered, Kensler's CMJ, XOR shifts, bit-by-bit Owen scrambles, torus shifts)
and Mitsuba 3's own generators (ldsampler, multijitter, stratified; scalar_rgb) — on the tests'
integrands (smooth, a jump along a non-dyadic line, a narrow peak) and, with a map, on a real
warped integrand: map importance sampling (envfit's MapSampler) of a diffuse lobe whose axis
lies between the map's brightest pixel and the zenith, h = L·ρ_a/p per RGB channel.

Prints one row per (integrand, method, generator, N): predicted, brute force ± standard error,
ratio and z-score; the map integrand's brute force is the unbiased sample variance (its
integral is not known in closed form; every method is unbiased).

With ``--mis`` (and a map) the two streams of MIS instead: envfit's warped integrands of
balance-heuristic MIS (``envfit.predict.renderer.warped_integrand``, fraction ½: N map and N
lobe samples), predicted by ``mis_mse`` — the streams sharing one XOR-shifted net for
Mitsuba's ldsampler (its two 2-D dimensions), independent for multijitter and stratified —
against Mitsuba's own points of two consecutive 2-D dimensions per pixel; the row also gives
the predicted cross term's share 2·C12/MSE.

    python bench/randomisation_check.py                     # test integrands, N = 4 … 1024
    python bench/randomisation_check.py --map /work/shared/envmaps/city.exr --reps 4000
    python bench/randomisation_check.py --map /work/shared/envmaps/city.exr --mis --mitsuba
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from oracles.randomisers import (INTEGRANDS, Integrand, jittered_points,  # noqa: E402
                                 kensler_cmj_points, owen_scrambled_points, sobol_digits,
                                 xor_shifted_points)

from envfit.predict.renderer.randomisation import (NETS, DyadicGrid,  # noqa: E402
                                                   mis_mse, randomised_mse)
from envfit.renderers import KENSLER_PERMUTATIONS, multijitter_shape  # noqa: E402

#: points per chunk of the brute force (memory)
CHUNK = 1 << 21


def _numpy_sets(method: str, n: int):
    """A function (rng, reps) → (reps, N', 2) building ``method``'s points, and N' and the
    prediction's options; None where the method does not take this N."""
    r, m = math.isqrt(n), n.bit_length() - 1
    pow2 = n & (n - 1) == 0
    if method == "independent":
        return (lambda rng, k: rng.random((k, n, 2))), n, {}
    if method == "jittered" and r * r == n:
        return (lambda rng, k: jittered_points(rng, k, r)), n, {}
    if method == "cmj" and r * r == n:
        return (lambda rng, k: kensler_cmj_points(rng, k, r, r)), n, {"nx": r, "ny": r}
    if method == "digital_shift" and pow2:
        d = sobol_digits(n)
        return (lambda rng, k: xor_shifted_points(rng, k, d)), n, {}
    if method == "owen" and pow2:
        d = sobol_digits(n)
        return (lambda rng, k: owen_scrambled_points(rng, k, d, m)), n, {}
    if method == "cp_shift" and pow2:
        base = NETS["sobol"].points(m)
        return (lambda rng, k: (base[None] + rng.random((k, 1, 2))) % 1.0), n, {}
    return None


MITSUBA = {"ldsampler": "digital_shift", "multijitter": "cmj", "stratified": "jittered"}


def _mitsuba_sets(kind: str, spp: int):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    sampler = mi.load_dict({"type": kind, "sample_count": spp})
    n = sampler.sample_count()
    if kind == "ldsampler" and n != spp:
        return None
    start = [0]

    def make(rng, k):
        out = np.empty((k, n, 2))
        for s in range(k):
            sampler.seed(start[0] + s)
            for i in range(n):
                p = sampler.next_2d()
                out[s, i] = p[0], p[1]
                sampler.advance()
        start[0] += k
        return out
    options = {}
    if kind == "multijitter":       # Mitsuba's shape, over its hashed permutations
        options = dict(zip(("nx", "ny"), multijitter_shape(spp)),
                       permutations=KENSLER_PERMUTATIONS)
    return make, n, options


def _brute(f: Integrand, make, reps: int, n: int, rng, unbiased: bool):
    """Mean (over channels) of the MSE over ``reps`` randomisations, and its standard error."""
    est = []
    per = max(1, CHUNK // n)
    for k0 in range(0, reps, per):
        pts = make(rng, min(per, reps - k0))
        val = np.asarray(f.h(pts.reshape(-1, 2))).reshape(pts.shape[0], n, -1)
        est.append(val.mean(axis=1))
    F = np.concatenate(est)                                       # (reps, C)
    centre = F.mean(axis=0) if unbiased else f.integral
    e2 = ((F - centre) ** 2).mean(axis=1)
    if unbiased:
        e2 = e2 * reps / (reps - 1)
    return float(e2.mean()), float(e2.std(ddof=1) / math.sqrt(reps))


def _axis_near_sun(m, sampler) -> np.ndarray:
    """A lobe axis between the map's brightest pixel and the zenith."""
    lum = m.data.mean(axis=-1)
    i, j = np.unravel_index(np.argmax(lum), lum.shape)
    sun = sampler.pixel_point(np.array([i]), np.array([j]), np.array([0.5]), np.array([0.5]))[0]
    up = {"y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}.get(m.up)
    axis = sun + (up if up is not None else np.array([0.0, 1.0, 0.0]))
    return axis / np.linalg.norm(axis)


def _mis_rows(path: str, args) -> None:
    """MIS: two streams, the grids of h1, h2 and h1 + h2 from one pass of the integrand."""
    from envfit.maps import load_envmap
    from envfit.predict.warped import warped_integrand
    from envfit.sampling import MapSampler
    m = load_envmap(path, max_height=args.height)
    sampler = MapSampler(m)
    axis = _axis_near_sun(m, sampler)
    c = m.data.shape[-1]

    def parts(u):
        w = warped_integrand(m, "mis", axis, u, sampler=sampler)          # (2, K, C)
        return np.concatenate((w[0], w[1], w[0] + w[1]), axis=-1)

    t = time.time()
    g = DyadicGrid.from_callable(parts, args.level, nodes=args.nodes)
    grids = [DyadicGrid.from_arrays(g.mean[k * c:(k + 1) * c], g.mean_sq[k * c:(k + 1) * c])
             for k in range(3)]
    print(f"# mis:{Path(path).stem}: grids in {time.time() - t:.1f} s", flush=True)
    plan = {"ldsampler": ("digital_shift", True), "multijitter": ("cmj", False),
            "stratified": ("jittered", False), "independent": ("independent", False)}
    for kind, (method, shared) in plan.items():
        for spp in [int(v) for v in args.n.split(",")]:
            import mitsuba as mi
            mi.set_variant("scalar_rgb")
            s = mi.load_dict({"type": kind, "sample_count": spp})
            n = s.sample_count()
            opts = {"permutations": KENSLER_PERMUTATIONS} if kind == "multijitter" else {}
            res = mis_mse(method, grids[0], grids[1], n, shared=shared, total=grids[2], **opts)
            pred, cross = float(np.mean(res.mse)), float(np.mean(2 * res.cross))
            reps = args.reps if n <= 256 else max(500, args.reps // 4)
            pts = np.empty((reps, n, 2, 2))
            for r in range(reps):
                s.seed(r)
                for i in range(n):
                    a, b = s.next_2d(), s.next_2d()
                    pts[r, i] = (a[0], a[1]), (b[0], b[1])
                    s.advance()
            w1 = warped_integrand(m, "mis", axis, pts[:, :, 0].reshape(-1, 2), sampler=sampler)
            w2 = warped_integrand(m, "mis", axis, pts[:, :, 1].reshape(-1, 2), sampler=sampler)
            F = w1[0].reshape(reps, n, c).mean(axis=1) + w2[1].reshape(reps, n, c).mean(axis=1)
            e2 = ((F - F.mean(axis=0)) ** 2).mean(axis=1) * reps / (reps - 1)
            bf, se = float(e2.mean()), float(e2.std(ddof=1) / math.sqrt(reps))
            print(f"{'mis:' + Path(path).stem:12s} {method:14s} {kind:12s} {n:5d} {pred:11.4e} "
                  f"{bf:11.4e} ± {se:8.1e} {pred / bf:7.3f} {(pred - bf) / se:+6.2f} "
                  f"2C12/MSE {cross / pred:+.3f}", flush=True)


def _map_integrand(path: str, height: int) -> Integrand:
    from envfit.maps import load_envmap
    from envfit.sampling import MapSampler
    m = load_envmap(path, max_height=height)
    sampler = MapSampler(m)
    axis = _axis_near_sun(m, sampler)

    def h(u):
        d, p = sampler.sample(np.asarray(u).reshape(-1, 2))
        lobe = np.clip(d @ axis, 0.0, None) / np.pi
        return m.lookup(d) * (lobe / p)[:, None]
    return Integrand(f"map:{Path(path).stem}", h, float("nan"))


def _rows(f, grid, n_values, methods, generators, reps, rng, unbiased):
    for method in methods:
        for n in n_values:
            for gen in generators:
                if gen == "numpy":
                    spec = _numpy_sets(method, n)
                else:
                    spec = _mitsuba_sets(gen, n) if MITSUBA.get(gen) == method else None
                if spec is None:
                    continue
                make, npts, options = spec
                if npts > grid.size and method in ("digital_shift", "owen"):
                    continue
                t = time.time()
                pred = float(np.mean(randomised_mse(method, grid, npts, **options).mse))
                tp = time.time() - t
                k = reps if npts <= 256 else max(500, reps // 4)
                bf, se = _brute(f, make, k, npts, rng, unbiased)
                print(f"{f.name:12s} {method:14s} {gen:12s} {npts:5d} {pred:11.4e} "
                      f"{bf:11.4e} ± {se:8.1e} {pred / bf:7.3f} {(pred - bf) / se:+6.2f} "
                      f"{tp:6.2f}s", flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", help="a lat-long map for the real warped integrand")
    ap.add_argument("--height", type=int, default=256, help="the map's rows (downscaled)")
    ap.add_argument("--level", type=int, default=11, help="grid level L (M = 2^L)")
    ap.add_argument("--nodes", type=int, default=3, help="Gauss nodes per cell axis")
    ap.add_argument("--reps", type=int, default=10000, help="randomisations per cell")
    ap.add_argument("--n", default="4,16,64,256,1024")
    ap.add_argument("--methods", default="independent,jittered,cmj,digital_shift,owen,cp_shift")
    ap.add_argument("--mitsuba", action="store_true", help="also Mitsuba 3's generators")
    ap.add_argument("--mis", action="store_true", help="MIS's two streams (needs --map)")
    args = ap.parse_args(argv)
    cpu = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True,
                         text=True).stdout.strip()
    print(f"# {cpu}; reps {args.reps} (a quarter above N = 256), grid M = {1 << args.level}")
    print(f"{'integrand':12s} {'method':14s} {'generator':12s} {'N':>5s} {'predicted':>11s} "
          f"{'brute force':>11s}   {'se':>8s} {'ratio':>7s} {'z':>6s} {'t_pred':>7s}")
    if args.mis:
        _mis_rows(args.map, args)
        return
    n_values = [int(v) for v in args.n.split(",")]
    generators = ["numpy"] + (sorted(MITSUBA) if args.mitsuba else [])
    cases = [(f, False) for f in INTEGRANDS.values()] if not args.map else \
        [(_map_integrand(args.map, args.height), True)]
    rng = np.random.default_rng(2026)
    for f, unbiased in cases:
        t = time.time()
        grid = DyadicGrid.from_callable(f.h, args.level, nodes=args.nodes)
        print(f"# {f.name}: grid in {time.time() - t:.1f} s", flush=True)
        _rows(f, grid, n_values, args.methods.split(","), generators, args.reps, rng, unbiased)


if __name__ == "__main__":
    main()

r"""Does the advisor's spp meet the target when rendered (issue 40)? For each map × renderer /
sampler × relative target: the spp N that ``envfit.advise_renderer`` recommends for the sphere
the harness renders (``sphere_pixels`` = ``--resolution``, the renderer's default strategy,
MIS), rendered at N and at the next smaller runnable spp, with the measured RMSE and its 95 %
interval set against the target.

    python bench/renderer_target_check.py /work/shared/envmaps/forest.exr \
        /work/shared/envmaps/city.exr sun-gp-1.5 --map-height 64 --resolution 32 \
        --renderers mitsuba3 cycles --targets 0.03 --threads 1 --json /tmp/rtc/check.json

(``--map-height 64``: the files resized to 128 × 64 in memory, :meth:`EnvMap.resized`; the
synthesized ``sun-gp-1.5`` of ``bench/render_check.py`` made at that height.) Mitsuba 3 runs
``ldsampler`` and ``independent`` (``--mitsuba-samplers``), Cycles ``tabulated_sobol``
(``--cycles-samplers``). Mitsuba and bpy are never loaded in one process: each renderer runs
in a child process of its own Python (``--mitsuba-python``, default this one;
``--cycles-python``, default ``$ENVFIT_CYCLES_PYTHON`` or ``/work/venv501/bin/python``, a venv
with ``bpy==5.0.1`` and envfit installed), one after the other, each appending its rows to
``--json``. Rows already there (same map, renderer, sampler, target, resolution) are skipped:
an interrupted run resumes. ``--table-only`` prints the table of ``--json`` and exits.

Per row:

1. the advisor (:func:`envfit.advise_renderer`, strategies ``("mis",)``, ``sphere_pixels`` =
   ``--resolution``, ``--renderer-level`` / ``--renderer-normals`` passed on when given) gives
   N, its predicted RMSE, the runnable spp below it (``below_spp``: N/2 for a sampler of
   powers of two — ``ldsampler``, and Cycles' Tabulated Sobol, whose footprint model is
   searched at powers of two — N − 1 for one that runs every spp) and the model error / spp
   span where it reports them;
2. where the spp below is N − 1 (a step no render can resolve: the RMSE differs by
   ~1/(2N)), a *clearly smaller* spp is rendered as well: ⌊N / ``--smaller-factor``⌋ (1.5),
   or the lower end of the answer's ``spp_span`` when that is smaller; its prediction is the
   advisor's (asked again with that spp listed);
3. each spp is rendered with the harness of ``bench/render_check.py`` (its session and
   reference cache: two references at ``--reference-spp``, the reference's own variance
   ¼(a − b)² subtracted, :func:`envfit.renderers._sphere.sphere_error`) by
   ``--min-renders`` to ``--max-renders`` independent renders of the six views, stopping once
   the 95 % interval's half-width is at most ``--precision`` of the RMSE: the MSE is the
   pixels' weighted mean of (mean over renders of (img − ref)²) − ¼(a − b)², its interval the
   percentile bootstrap over the kept pixels of that per-pixel term (every pixel is an
   independent estimate: each render randomises per pixel), so the reference's own noise is
   inside the interval too.

Verdicts (T the target, m the measured RMSE, [lo, hi] its 95 % interval):

* at N: **meets** when m ≤ T, **MISSES** otherwise; the interval's word: *below* (hi ≤ T: met
  with 95 % confidence — the strict reading), *straddles* (lo ≤ T < hi: the render cannot
  tell; the loose reading counts it as met when lo ≤ T), *above* (lo > T: missed for sure);
* at a smaller spp: **misses** when m > T, **MEETS** otherwise; *above* (lo > T) is the strict
  reading of "misses", *straddles* (hi > T ≥ lo) the loose.

N is a crossing of the prediction — predicted(N) ≤ T < predicted(below) — so at a sampler of
every spp, predicted(N) is within ~1/(2N) of T and m ≤ T is a coin toss even for an exact
model: there the acceptance is the strict reading at the clearly smaller spp and the loose
reading at N (and at N − 1).

The table: one line per rendered spp (role ``N``, ``below`` the runnable spp below N,
``smaller`` the clearly smaller one), the predicted and measured RMSE, measured/predicted,
the verdict, the interval's word, the renders taken and their seconds; then the counts of
each reading, the CPU (``lscpu`` model, AVX level) and the load averages before and after.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from render_check import _cpu, _session, load_map  # noqa: E402  (the bench's harness)

#: the samplers checked per renderer by default
DEFAULT_SAMPLERS = {"mitsuba3": ("ldsampler", "independent"), "cycles": ("tabulated_sobol",)}
#: the strategy rendered and advised: the renderers' default (both techniques, MIS)
STRATEGY = "mis"


# ----------------------------------------------------------------------------- pure helpers
def verdict_at_answer(m: float, lo: float, hi: float, target: float) -> tuple[str, str]:
    """(verdict, interval word) at the recommended spp (module docstring).

    >>> verdict_at_answer(0.9, 0.8, 0.95, 1.0), verdict_at_answer(0.9, 0.8, 1.1, 1.0)
    (('meets', 'below'), ('meets', 'straddles'))
    >>> verdict_at_answer(1.05, 0.9, 1.2, 1.0), verdict_at_answer(1.2, 1.1, 1.3, 1.0)
    (('MISSES', 'straddles'), ('MISSES', 'above'))
    """
    return ("meets" if m <= target else "MISSES"), _word(lo, hi, target)


def verdict_smaller(m: float, lo: float, hi: float, target: float) -> tuple[str, str]:
    """(verdict, interval word) at a spp below the recommendation (module docstring).

    >>> verdict_smaller(1.2, 1.1, 1.3, 1.0), verdict_smaller(0.9, 0.8, 1.1, 1.0)
    (('misses', 'above'), ('MEETS', 'straddles'))
    """
    return ("misses" if m > target else "MEETS"), _word(lo, hi, target)


def _word(lo: float, hi: float, target: float) -> str:
    return "below" if hi <= target else "above" if lo > target else "straddles"


def clearly_smaller(n: int, below: int | None, span: dict | None, factor: float) -> int | None:
    """The clearly smaller spp rendered besides ``below`` when ``below`` is N − 1 (or absent):
    ⌊N / factor⌋, or the lower end of the answer's spp span when that is smaller; None where
    ``below`` is already a clear step (N/2).

    >>> clearly_smaller(256, 128, None, 1.5) is None, clearly_smaller(300, 299, None, 1.5)
    (True, 200)
    >>> clearly_smaller(300, 299, {"spp": [180, 400]}, 1.5)
    180
    """
    if below is not None and below < n - 1:
        return None
    k = max(1, math.floor(n / factor))
    if span and span.get("spp"):
        k = min(k, int(span["spp"][0]))
    return k if k < n else None


def pooled_error(terms: list, reference_var: np.ndarray, weight: np.ndarray, rng,
                 resamples: int) -> tuple[float, float, float]:
    """(RMSE, low, high) of K renders: ``terms`` the per-pixel (img − ref)² of each render
    (RMS over channels), ``reference_var`` the per-pixel ¼(a − b)², ``weight`` the pixels'
    solid-angle weights; the interval a percentile bootstrap over the pixels of the per-pixel
    mean over renders minus the reference's variance (module docstring, step 3).

    >>> w = np.ones(4)
    >>> r = pooled_error([np.full(4, 0.02), np.full(4, 0.06)], np.full(4, 0.03), w,
    ...                  np.random.default_rng(0), 10)
    >>> [round(x, 12) for x in r]
    [0.1, 0.1, 0.1]
    """
    from envfit.renderers._sphere import _bootstrap     # internal: sphere_error's bootstrap
    d = np.mean(terms, axis=0) - reference_var
    mse = float(np.sum(weight * d) / np.sum(weight))
    lo, hi = _bootstrap(d, weight, rng, int(resamples))
    root = lambda v: float(np.sqrt(max(v, 0.0)))
    return root(mse), root(lo), root(hi)


def row_key(row: dict) -> tuple:
    return (row["map"], row["renderer"], row["sampler"], float(row["target_relative"]),
            int(row["resolution"]))


# ----------------------------------------------------------------------------- measurement
def _pixel_terms(imgs, ref, geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per kept pixel: (img − ref)², ¼(a − b)² (means over the channels) and the weight, in
    :func:`envfit.renderers._sphere.sphere_error`'s order (its raw and reference RMSE are
    checked against these by the caller)."""
    keep = geometry.keep
    a, b = np.asarray(ref.a, np.float64), np.asarray(ref.b, np.float64)
    r = 0.5 * (a + b)
    e2 = ((np.asarray(imgs, np.float64) - r) ** 2).mean(axis=-1)[:, keep].ravel()
    v = (0.25 * (a - b) ** 2).mean(axis=-1)[:, keep].ravel()
    w = np.broadcast_to(geometry.weight[keep], (len(imgs), int(keep.sum()))).ravel()
    return e2, v, np.ascontiguousarray(w)


def measure(session, sampler: str, spp: int, ref, rng, args) -> dict:
    """Independent renders of the six views at ``spp`` until the interval is narrow enough
    (module docstring, step 3): the pooled RMSE, its interval and the per-render values."""
    from envfit.renderers import BOOTSTRAP_RESAMPLES, sphere_error
    terms, per, offsets, secs = [], [], [], 0.0
    while True:
        imgs, s = session.render(STRATEGY, sampler, spp, rng)
        secs += float(sum(s))
        err = sphere_error(imgs, ref.a, ref.b, session.geometry, seed=rng)
        e2, v, w = _pixel_terms(imgs, ref, session.geometry)
        raw = math.sqrt(float(np.sum(w * e2) / np.sum(w)))
        if not math.isclose(raw, err.raw_rmse, rel_tol=1e-9, abs_tol=1e-15):
            raise RuntimeError(f"per-pixel terms disagree with sphere_error: {raw} vs "
                               f"{err.raw_rmse}")
        terms.append(e2)
        per.append(err.rmse)
        offsets.append(err.mean_offset)
        rmse, lo, hi = pooled_error(terms, v, w, rng, BOOTSTRAP_RESAMPLES)
        k = len(terms)
        half = 0.5 * (hi - lo) / rmse if rmse > 0 else math.inf
        if k >= args.max_renders or (k >= args.min_renders and half <= args.precision):
            break
    return {"spp": int(spp), "spp_used": int(session.spp_used(sampler, spp)),
            "measured_rmse": rmse, "low": lo, "high": hi, "renders": k,
            "per_render_rmse": per, "mean_offsets": offsets, "half_width": half,
            "reference_rmse": err.reference_rmse, "pixels": err.pixels, "seconds": secs}


# ----------------------------------------------------------------------------- the advisor
def _advise(env, renderer: str, sampler: str, target: float, args, spp=()):
    from envfit import advise_renderer
    kw = {k: v for k, v in (("level", args.renderer_level), ("normals", args.renderer_normals))
          if v is not None}
    return advise_renderer(env, renderer, sampler=sampler, strategies=(STRATEGY,),
                           target_relative=target, sphere_pixels=args.resolution,
                           spp=tuple(spp), cache_dir=args.advisor_cache, **kw)


def plan_row(env, name: str, renderer: str, sampler: str, target: float, args) -> dict:
    """The advisor's answer and the spp to render: [(role, spp, predicted)]."""
    t = time.perf_counter()
    adv = _advise(env, renderer, sampler, target, args)
    d = adv.to_dict()
    ans = next(a for a in d["answers"] if a["strategy"] == STRATEGY)
    row = {"map": name, "renderer": renderer, "sampler": sampler, "strategy": STRATEGY,
           "target_relative": float(target), "target_rmse": float(adv.target_rmse),
           "mean_radiance": float(adv.mean_radiance), "resolution": int(args.resolution),
           "reached": bool(ans["reached"]), "N": int(ans["spp"]),
           "predicted_at_N": float(ans["predicted_rmse"]), "below_spp": ans["below_spp"],
           "below_rmse": ans["below_rmse"], "model_se": ans.get("model_se"),
           "below_model_se": ans.get("below_model_se"), "spp_span": ans.get("spp_span"),
           "advisor_model": {k: d["model"].get(k) for k in
                             ("normals", "level", "shifts", "sized", "seconds")}}
    plan = [("N", row["N"], row["predicted_at_N"])]
    if ans["below_spp"] is not None:
        plan.append(("below", int(ans["below_spp"]), float(ans["below_rmse"])))
    small = clearly_smaller(row["N"], ans["below_spp"], ans.get("spp_span"),
                            args.smaller_factor)
    if small is not None:
        again = _advise(env, renderer, sampler, target, args, spp=(small,))
        plan.append(("smaller", small, float(again.cells[(STRATEGY, small)])))
    row["advisor_seconds"] = time.perf_counter() - t
    row["plan"] = plan
    return row


# ----------------------------------------------------------------------------- one renderer
def _load(spec: str, height: int):
    name, env = load_map(spec, height)
    if env.height > height:                     # a file: resized in memory (EnvMap.resized)
        env = env.resized(height)
        name = f"{name}{env.width}x{env.height}"
    return name, env


def _read(path: Path) -> dict:
    if path.exists():
        return json.loads(path.read_text())
    return {"meta": {}, "rows": []}


def _write(path: Path, data: dict) -> None:
    from envfit.base._atomic import atomic_write_json  # internal: the product's atomic writer
    atomic_write_json(path, data)


def run_renderer(renderer: str, args) -> None:
    """The rows of one renderer (a child process: its Python has the renderer)."""
    # Mitsuba keeps its own pool: drjit's set_thread_count(1) hangs its scene loading
    path = Path(args.json)
    samplers = args.mitsuba_samplers if renderer == "mitsuba3" else args.cycles_samplers
    for spec in args.maps:
        name, env = _load(spec, args.map_height)
        done = {row_key(r) for r in _read(path)["rows"]}
        todo = [(s, t) for s in samplers for t in args.targets
                if (name, renderer, s, float(t), args.resolution) not in done]
        if not todo:
            continue
        session = _session(renderer, env, args)
        try:
            t0 = time.perf_counter()
            ref = session["plain"].reference()
            print(f"[{renderer} {name}] reference {args.reference_spp} spp: "
                  f"{ref.seconds:.1f} s (0 when cached)", flush=True)
            for sampler, target in todo:
                row = plan_row(env, name, renderer, sampler, target, args)
                print(f"[{renderer} {name} {sampler} {target:g}] N = {row['N']}, rendering "
                      f"{[(r, n) for r, n, _ in row['plan']]} (advisor "
                      f"{row['advisor_seconds']:.0f} s)", flush=True)
                rng = np.random.default_rng([args.seed, zlib.crc32(f"{name} {sampler}".encode()),
                                             int(round(1e6 * target))])
                rendered = []
                for role, spp, pred in row["plan"]:
                    m = measure(session["plain"], sampler, spp, ref, rng, args)
                    judge = verdict_at_answer if role == "N" else verdict_smaller
                    v, word = judge(m["measured_rmse"], m["low"], m["high"],
                                    row["target_rmse"])
                    rendered.append({"role": role, "predicted": pred, **m, "verdict": v,
                                     "interval": word, "ratio": m["measured_rmse"] / pred
                                     if pred > 0 else math.inf})
                row["rendered"] = rendered
                row["reference_seconds"] = ref.seconds
                row["reference_spp"] = args.reference_spp
                row["threads"] = args.threads
                data = _read(path)
                data["rows"].append(row)
                data["meta"].setdefault("renderer_version", {})[renderer] = \
                    _version(renderer)
                _write(path, data)
                done.add(row_key(row))
            print(f"[{renderer} {name}] {time.perf_counter() - t0:.0f} s", flush=True)
        finally:
            for s in {id(x): x for x in session.values()}.values():
                s.close()


def _version(renderer: str) -> str:
    from envfit.renderers import get_renderer
    return get_renderer(renderer).harness_module().version()


# ----------------------------------------------------------------------------- the report
def cpu_line() -> str:
    """The CPU's model (``lscpu``), its widest AVX and the core count."""
    flags = ""
    try:
        flags = next((l for l in Path("/proc/cpuinfo").read_text().splitlines()
                      if l.startswith("flags")), "")
    except OSError:
        pass
    f = set(flags.split())
    avx = ("AVX-512" if "avx512f" in f else "AVX2" if "avx2" in f else "AVX" if "avx" in f
           else "no AVX")
    return f"{_cpu()}, {avx}, {os.cpu_count()} logical CPUs"


def _load_avg() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def print_table(rows: list) -> dict:
    """The table and the summary counts (returned)."""
    print(f"{'map':16s} {'renderer':8s} {'sampler':15s} {'target':>10s} {'role':7s} {'spp':>5s} "
          f"{'predicted':>10s} {'measured':>10s} {'95% interval':>23s} {'meas/pred':>9s} "
          f"{'verdict':8s} {'interval':9s} {'K':>2s} {'s':>6s}")
    counts = {k: [0, 0] for k in ("N point", "N strict", "N loose", "below point",
                                  "below strict", "below loose", "smaller point",
                                  "smaller strict", "smaller loose")}
    for row in rows:
        t = row["target_rmse"]
        tgt = f"{t:.4g} ({100 * row['target_relative']:g}%)"
        first = True
        for r in row["rendered"]:
            head = (f"{row['map']:16s} {row['renderer']:8s} {row['sampler']:15s} {tgt:>10s}"
                    if first else f"{'':16s} {'':8s} {'':15s} {'':>10s}")
            first = False
            flag = " !" if min(r["mean_offsets"]) < -0.05 else ""
            print(f"{head} {r['role']:7s} {r['spp']:5d} {r['predicted']:10.4g} "
                  f"{r['measured_rmse']:10.4g} [{r['low']:9.4g}, {r['high']:9.4g}] "
                  f"{r['ratio']:9.3f} {r['verdict']:8s} {r['interval']:9s} {r['renders']:2d} "
                  f"{r['seconds']:6.1f}{flag}")
            role = r["role"]
            good = {"point": r["verdict"] in ("meets", "misses"),
                    "strict": r["interval"] == ("below" if role == "N" else "above"),
                    "loose": r["interval"] != ("above" if role == "N" else "below")}
            for how, ok in good.items():
                c = counts[f"{role} {how}"]
                c[0] += bool(ok)
                c[1] += 1
        extra = []
        if row.get("model_se"):
            extra.append(f"model error ±{100 * row['model_se'][0]:.1f} %")
        if row.get("spp_span"):
            extra.append(f"spp span {row['spp_span']['spp'][0]}–{row['spp_span']['spp'][1]}")
        if extra:
            print(f"{'':16s} {'':8s} {'':15s} {'':>10s} ({'; '.join(extra)})")
    return counts


def summary_lines(counts: dict) -> list[str]:
    def c(k):
        a, n = counts[k]
        return f"{a}/{n}"
    out = [f"recommended spp N meets the target: {c('N point')} by the measured RMSE, "
           f"{c('N strict')} with the whole 95 % interval below (strict), {c('N loose')} "
           f"with the interval reaching it (loose)"]
    if counts["below point"][1]:
        out.append(f"the next smaller runnable spp misses: {c('below point')} by the measured "
                   f"RMSE, {c('below strict')} with the whole interval above (strict), "
                   f"{c('below loose')} with the interval reaching above (loose)")
    if counts["smaller point"][1]:
        out.append(f"the clearly smaller spp (where the runnable one below is N - 1) misses: "
                   f"{c('smaller point')} by the measured RMSE, {c('smaller strict')} strict, "
                   f"{c('smaller loose')} loose")
    return out


# ----------------------------------------------------------------------------- main
def _python_for(renderer: str, args) -> str:
    return args.cycles_python if renderer == "cycles" else args.mitsuba_python


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="*", help="map files, or sun-gp-1.5 / sun-gp-1.3")
    ap.add_argument("--renderers", nargs="+", default=["mitsuba3", "cycles"],
                    choices=("mitsuba3", "cycles"))
    ap.add_argument("--mitsuba-samplers", nargs="+", default=list(DEFAULT_SAMPLERS["mitsuba3"]))
    ap.add_argument("--cycles-samplers", nargs="+", default=list(DEFAULT_SAMPLERS["cycles"]))
    ap.add_argument("--targets", nargs="+", type=float, default=[0.03],
                    help="relative targets (of the map's mean radiance)")
    ap.add_argument("--map-height", type=int, default=64,
                    help="files resized to this height (width 2x); synthesized maps made at it")
    ap.add_argument("--resolution", type=int, default=32, help="pixels per view side")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference-sampler", default="ldsampler",
                    help="Mitsuba 3: the references' sampler")
    ap.add_argument("--min-renders", type=int, default=2)
    ap.add_argument("--max-renders", type=int, default=8)
    ap.add_argument("--precision", type=float, default=0.05,
                    help="stop rendering once the interval's half-width is at most this "
                         "fraction of the RMSE")
    ap.add_argument("--smaller-factor", type=float, default=1.5)
    ap.add_argument("--renderer-level", type=int, default=None,
                    help="the advisor's --renderer-level (default: its own)")
    ap.add_argument("--renderer-normals", type=int, default=None,
                    help="the advisor's --renderer-normals (default: its own)")
    ap.add_argument("--threads", type=int, default=1,
                    help="render threads (Cycles; Mitsuba keeps its own pool) and the "
                         "advisor's numba/BLAS threads")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default="renderer_target_check.json")
    ap.add_argument("--cache", default=None, help="reference cache (default: beside --json)")
    ap.add_argument("--advisor-cache", default=None,
                    help="the advisor's cache (default: beside --json)")
    ap.add_argument("--mitsuba-python", default=sys.executable)
    ap.add_argument("--cycles-python", default=os.environ.get(
        "ENVFIT_CYCLES_PYTHON", "/work/venv501/bin/python"))
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    path = Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    args.cache = args.cache or str(path.parent / "cache")
    args.advisor_cache = args.advisor_cache or str(path.parent / "advisor_cache")
    if args.worker:
        (renderer,) = args.renderers
        run_renderer(renderer, args)
        return 0
    t0, load0 = time.perf_counter(), _load_avg()
    if not args.table_only:
        if not args.maps:
            ap.error("give at least one map")
        env = dict(os.environ)
        if args.threads:
            for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                      "MKL_NUM_THREADS"):
                env[k] = str(args.threads)
        argv = list(sys.argv[1:] if argv is None else argv)
        for renderer in args.renderers:
            cmd = [_python_for(renderer, args), str(Path(__file__).resolve()), *argv,
                   "--renderers", renderer, "--worker"]
            rc = subprocess.run(cmd, env=env).returncode
            if rc:
                print(f"{renderer}: the child exited {rc}", file=sys.stderr)
                return rc
    data = _read(path)
    rows = [r for r in data["rows"]
            if args.table_only or not args.maps or r["renderer"] in args.renderers]
    counts = print_table(rows)
    print()
    for line in summary_lines(counts):
        print(line)
    data["meta"].update(cpu=cpu_line(), load_before=load0, load_after=_load_avg())
    if not args.table_only:
        data["meta"].setdefault("runs", []).append(
            {"argv": sys.argv[1:], "wall_seconds": time.perf_counter() - t0,
             "load_before": load0, "load_after": _load_avg(), "cpu": cpu_line()})
        _write(path, data)
    print(f"CPU: {cpu_line()}; load average (1, 5, 15 min) {load0} before, {_load_avg()} "
          f"after; wall {time.perf_counter() - t0:.0f} s this run")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

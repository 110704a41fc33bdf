"""Predicted vs measured peak memory and time of every stage of ``envfit advise`` on a map
(issue 22, item 1): the plan of :mod:`envfit.advisor._budget` beside the resident memory
sampled every 20 ms while each stage runs.

Usage::

    python bench/big_maps.py MAP.exr [advise options as keywords: renderer=1 nmax=4096 ...]
    python bench/big_maps.py --make 4096 OUT.exr     # an 8192x4096 float16 test map

``--make H`` writes city.exr-like content (a GP map of s = 1.5 times a sun and sky, from
:mod:`envfit.data_gen`) at H rows in float16 with 5 % pixel noise, so that the map has detail
at every scale. Prints one line per stage: predicted peak (process resident before the work +
the plan's resident + the stage), measured peak, predicted and measured seconds.
"""
from __future__ import annotations

import functools
import sys
import threading
import time

import numpy as np


def _rss() -> int:
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) * 1024 for l in fh if l.startswith("VmRSS:"))


class _Sampler:
    """The peak RSS of each named stage while it runs (sampled every 20 ms)."""

    def __init__(self):
        self.active, self.done, self.lock = {}, {}, threading.Lock()
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        while True:
            r = _rss()
            with self.lock:
                for v in self.active.values():
                    v[1] = max(v[1], r)
            time.sleep(0.02)

    def wrap(self, module, name: str, stage: str):
        f = getattr(module, name)

        @functools.wraps(f)
        def g(*a, **k):
            with self.lock:
                self.active[stage] = [time.perf_counter(), _rss()]
            try:
                return f(*a, **k)
            finally:
                with self.lock:
                    t0, peak = self.active.pop(stage)
                old = self.done.get(stage, (0.0, 0))
                self.done[stage] = (old[0] + time.perf_counter() - t0, max(old[1], peak, _rss()))
        setattr(module, name, g)


def make_map(height: int, path: str) -> None:
    """A float16 test map of ``height`` rows: GP s = 1.5 at 256 rows upsampled, a sun, noise."""
    from envfit.data_gen import gaussian_process_map
    from envfit.maps import save_envmap
    base = np.exp(gaussian_process_map(1.5, 256, seed=0, channels=3))
    f = height // 256
    data = np.repeat(np.repeat(base.astype(np.float32), f, 0), f, 1)
    rng = np.random.default_rng(0)
    for r in range(0, height, 256):                      # 5 % pixel noise, in blocks
        blk = data[r:r + 256]
        blk *= (1 + 0.05 * rng.standard_normal(blk.shape[:2], dtype=np.float32))[:, :, None]
    sr, sc, rad = height // 4, height // 3, max(2, height // 400)
    data[sr - rad:sr + rad, sc - rad:sc + rad] = 2000.0      # a sun ~1° wide
    save_envmap(path, data.astype(np.float16), half=True)


def main(argv: list[str]) -> None:
    if argv and argv[0] == "--make":
        make_map(int(argv[1]), argv[2])
        return
    from envfit.advisor import _advise as A, _model as M  # internal: the stages, instrumented
    from envfit.advisor._budget import prediction_height  # internal: the plan under test
    from envfit.advisor import AdviseOptions
    from envfit.maps import EnvMap, load_envmap
    kw = dict(a.split("=", 1) for a in argv[1:])
    opts = AdviseOptions(target_relative=float(kw.pop("target_relative", 0.01)),
                         renderer=bool(int(kw.pop("renderer", "1"))), cache=False,
                         quiet=False, **{k: int(v) for k, v in kw.items()})
    env = load_envmap(argv[0])
    smp = _Sampler()
    for mod, name, stage in [(EnvMap, "resized", "downsampling"),
                             (M, "cached_fit", "band-limited fit"),
                             (M, "cached_map_power", "map power"),
                             (A, "search_rules", "quadrature search"),
                             (A, "advise_renderer", "renderer spectra"),
                             (A, "check_rows", "check")]:
        smp.wrap(mod, name, stage)
    rss0, t0 = _rss(), time.perf_counter()
    h, plan = prediction_height(env, opts)
    adv = A.advise_with(env, opts)
    total = time.perf_counter() - t0
    print(f"map {env.width}x{env.height} -> predictions at {2 * h}x{h}; resident before "
          f"{rss0 / 1e9:.2f} GB; total {total:.0f} s (predicted ~{plan.seconds():.0f} s)")
    print(f"{'stage':20s} {'pred. peak':>10s} {'meas. peak':>10s} {'pred. s':>8s} {'meas. s':>8s}")
    for st in plan.stages:
        sec, peak = smp.done.get(st.name, (float("nan"), 0))
        pred = rss0 + plan.resident + st.nbytes
        print(f"{st.name:20s} {pred / 1e9:9.2f}G {peak / 1e9:9.2f}G {st.seconds:8.0f} {sec:8.1f}")
    evals = [(r.label, r.evaluations) for r in adv.rows if r.method == "quadrature"]
    print("error-power evaluations per rule:", ", ".join(f"{a} {b}" for a, b in evals))
    for note in adv.notes:
        print("note:", note)


if __name__ == "__main__":
    main(sys.argv[1:])

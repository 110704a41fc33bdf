"""The renderer model's time plan (envfit.advisor._budget.renderer_plan) against its measured
passes: for each renderer × sampler (and a microfacet BSDF), run the model on one map with the
cache off and print the measured seconds per pass beside the plan's, and their ratio.

The plan's rate constants (``envfit.advisor._budget.RENDERER_SECONDS_PER_POINT``, seconds
per integrand point of each randomisation) are calibrated from this table; a ratio far from 1 says a
constant is off on this machine.

    python bench/preset_plan_check.py /path/forest.exr --normals 16 --level 8
    python bench/preset_plan_check.py MAP --only cycles:tabulated_sobol mitsuba3:ldsampler
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from render_check import _cpu  # noqa: E402

from envfit.advisor._budget import renderer_passes, renderer_plan  # noqa: E402  # internal: the plan under test
from envfit.advisor._renderer_advice import advise_renderer_map  # noqa: E402  # internal: the model's own timings (passes, seconds)
from envfit.advisor import RendererAdviseOptions  # noqa: E402
from envfit.maps import load_envmap  # noqa: E402
from envfit.renderers import get_renderer  # noqa: E402

RENDERERS = ("mitsuba3", "pbrt4", "cycles", "envfit")


def cases(only: list[str], bsdfs: list[str]) -> list[tuple[str, str, str]]:
    """(renderer, sampler, bsdf) to time: every sampler of every renderer with a model, diffuse;
    ``bsdfs`` with each renderer's default sampler."""
    out = []
    for r in RENDERERS:
        p = get_renderer(r)
        for s in p.samplers:
            if not only or f"{r}:{s}" in only:
                out.append((r, s, "diffuse"))
        for b in bsdfs:
            if not only and r in ("mitsuba3", "cycles", "pbrt4"):
                out.append((r, p.default_sampler, b))
    return out


def time_one(env, renderer: str, sampler: str, bsdf: str, normals: int, level: int | None):
    """(planned seconds per pass, measured seconds per pass, passes) of one configuration."""
    kw = {"roughness": {"mitsuba3": 0.3, "pbrt4": 0.09, "cycles": 0.5477}[renderer]} \
        if bsdf != "diffuse" else {}
    try:
        opts = RendererAdviseOptions(renderer, sampler=sampler, normals=normals, level=level,
                                     bsdf=bsdf, **kw)
    except Exception as exc:  # noqa: BLE001 - a combination the model does not have
        return None, str(exc).split(":")[0]
    plan = (renderer_plan(env.width * env.height, opts).seconds()
            / renderer_passes(opts.record.sampler(opts.sampler).randomisation))
    t0 = time.perf_counter()
    adv = advise_renderer_map(env, opts.asking(cache=False))
    wall = time.perf_counter() - t0
    passes = max(1, adv.model["passes"])
    return (plan, adv.model["seconds_model"] / passes, passes, wall, opts.level), None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("map")
    ap.add_argument("--max-height", type=int, default=None)
    ap.add_argument("--normals", type=int, default=16)
    ap.add_argument("--level", type=int, default=None, help="default: each sampler's default")
    ap.add_argument("--only", nargs="*", default=[], metavar="RENDERER:SAMPLER")
    ap.add_argument("--bsdfs", nargs="*", default=["ggx"])
    a = ap.parse_args()
    env = load_envmap(a.map, max_height=a.max_height)
    print(f"# {_cpu()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}; map "
          f"{env.name} {env.width}x{env.height}; {a.normals} normals")
    print(f"{'renderer':9s} {'sampler':16s} {'bsdf':8s} {'L':>2s} {'passes':>6s} "
          f"{'plan s/pass':>11s} {'measured':>9s} {'ratio':>6s}")
    for r, s, b in cases(a.only, a.bsdfs):
        got, why = time_one(env, r, s, b, a.normals, a.level)
        if got is None:
            print(f"{r:9s} {s:16s} {b:8s} -- {why}")
            continue
        plan, meas, passes, _, level = got
        print(f"{r:9s} {s:16s} {b:8s} {level:2d} {passes:6d} {plan:11.2f} {meas:9.2f} "
              f"{plan / max(meas, 1e-9):6.2f}", flush=True)


if __name__ == "__main__":
    main()

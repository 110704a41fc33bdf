"""The sized renderer model at its tightest target runs within a 1 GB memory budget.

Run:  python bench/renderer_plan_sized_budget.py

``envfit advise`` on the 16 x 32 GP map of ``tests/test_renderer_plan.py`` with Mitsuba's
ldsampler, ``--renderer-model-error 0.01`` and ``ENVFIT_MEMORY_LIMIT=1G`` (which refuses the
unsized level-9 model): the sized default's pilot runs at level 7 and is followed by the
largest model the sizing allows (576 normals, 16 scrambles), which must run without a
refusal and whose plan (``renderer_plan``) must fit the budget. ~2 min of CPU on a quiet
machine. The suite runs the same path at a target of 0.03 (96 normals) and checks the
sizing's choice for 0.01 without running it.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path


def main() -> int:
    os.environ["ENVFIT_MEMORY_LIMIT"] = "1G"
    from envfit.advisor import RendererAdviseOptions
    from envfit.advisor._budget import renderer_plan  # internal: the plan the sizing checks
    from envfit.base._resources import memory_budget_bytes  # internal: the budget it checks
    from envfit.data_gen import gaussian_process_map
    from envfit.maps import EnvMap, save_envmap

    tmp = Path(tempfile.mkdtemp())
    env = EnvMap(gaussian_process_map(1.8, 16, seed=3, channels=3) + 2.0, name="gp16")
    path = save_envmap(tmp / "gp16.exr", env)
    out = tmp / "a.json"
    rc = subprocess.run([sys.executable, "-m", "envfit.cli", "advise", str(path), "--renderer",
                         "mitsuba3", "--sampler", "ldsampler", "--renderer-model-error", "0.01",
                         "--quiet", "--cache-dir", str(tmp / "cache"), "--json", str(out)],
                        env=os.environ, cwd=tmp).returncode
    m = json.loads(out.read_text())["renderer"]["model"] if rc == 0 else {}
    o = RendererAdviseOptions("mitsuba3", sampler="ldsampler", level=7,
                              normals=m.get("normals", 48))
    fits = rc == 0 and renderer_plan(32 * 16, replace(o, shifts=m["shifts"], reach=m["reach"]),
                                     resident=32 * 16 * 12).fits(memory_budget_bytes())
    ok = rc == 0 and m["sized"] and m["level"] == 7 and m["pilot"] is not None and fits
    print(f"exit {rc}; final model: {m.get('normals')} normals, {m.get('shifts')} scrambles, "
          f"level {m.get('level')}, reach {m.get('reach')}; plan fits 1G: {fits} "
          f"({'ok' if ok else 'FAIL'})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

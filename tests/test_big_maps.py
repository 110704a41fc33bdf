"""Big maps (issue 22, item 1): the advisor's memory and time plan is made before any work,
and an 8192x4096 map is downsampled (or refused in one line) before any big allocation.

The 8K maps are made on the fly in float16 (one channel: 67 MB, 134 MB as the EnvMap's
float32) and the checks run in a subprocess under an address-space limit (RLIMIT_AS), so a
regression fails with a MemoryError in seconds instead of filling the machine.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import textwrap
import tracemalloc

import numpy as np
import pytest

from envfit.advisor._budget import PREDICTION_MAX_HEIGHT, advise_plan, prediction_height
from envfit.advisor._options import AdviseOptions
from envfit.base._errors import MemoryBudgetError
from envfit.base._resources import Plan, Stage, format_bytes
from envfit.maps._envmap import EnvMap, solid_angle_variance, variance_kept
from envfit.shading._spectra import map_degree_power, sh_analysis_cost

_MAKE_8K = """
import numpy as np
from envfit.maps._envmap import EnvMap
x = np.linspace(0.0, 4.0, 8192, dtype=np.float32)
y = np.cos(np.linspace(0.0, 3.0, 4096, dtype=np.float32))
big = EnvMap((1.0 + 0.5 * np.sin(x)[None, :] * y[:, None]).astype(np.float16)[:, :, None],
             name="big8k")
"""


def _run_limited(body: str, gib: float, env_extra: dict | None = None) -> dict:
    """Run ``body`` (which sets ``out``, a JSON-able dict) in a fresh interpreter whose
    address space may grow by at most ``gib`` GiB once envfit is imported."""
    code = textwrap.dedent("""
        import json, resource, sys
        import envfit.advisor._advise, ducc0, numpy
        with open("/proc/self/status") as fh:
            vm = next(int(l.split()[1]) * 1024 for l in fh if l.startswith("VmSize:"))
        resource.setrlimit(resource.RLIMIT_AS, (vm + int(%r * 2 ** 30), resource.RLIM_INFINITY))
    """ % gib) + textwrap.dedent(_MAKE_8K) + textwrap.dedent(body) + \
        "\nprint('RESULT ' + json.dumps(out))\n"
    env = dict(os.environ)
    env.pop("ENVFIT_MEMORY_LIMIT", None)
    env.update(env_extra or {})
    # cwd away from the repository: there ``envfit`` would be the source folder, not the
    # installed package (envfit.theory and envfit.data_gen are mapped only when installed)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env=env, cwd=tempfile.gettempdir())
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = [l for l in proc.stdout.splitlines() if l.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def test_8k_map_is_downsampled_before_any_big_allocation_under_rlimit_as():
    """With 1.5 GiB of address space left, the 8K map's predictions are planned at a height
    whose every stage fits, and the block means are made without a MemoryError, in seconds
    (the run of issue 22 reached 19.9 GB in the map power to l = 8191)."""
    out = _run_limited("""
        import time
        from envfit.advisor._advise import _prediction_map
        from envfit.advisor._options import AdviseOptions
        from envfit.base._resources import memory_budget_bytes
        t = time.perf_counter()
        small, plan, notes = _prediction_map(big, AdviseOptions(target_rmse=0.01, renderer=True))
        out = {"h": small.height, "w": small.width, "peak": plan.peak(),
               "budget": memory_budget_bytes(), "notes": notes,
               "mean": [float(big.mean()[0]), float(small.mean()[0])],
               "seconds": time.perf_counter() - t}
    """, 1.5)
    assert out["h"] < PREDICTION_MAX_HEIGHT and out["w"] == 2 * out["h"]
    assert out["peak"] <= out["budget"]
    assert out["seconds"] < 60                                      # ~3 s unloaded
    assert abs(out["mean"][1] / out["mean"][0] - 1) < 1e-6          # block means keep it
    note = out["notes"][0]
    assert f"8192x4096 map downsampled to {out['w']}x{out['h']}" in note
    assert f"band limit l <= {out['h'] - 1}" in note and "memory budget" in note


def test_8k_map_refused_in_one_line_before_any_big_allocation(tmp_path):
    """A budget nothing fits: MemoryBudgetError naming the stage, raised after ~no
    allocation (tracemalloc peak under 40 MB, the block means of a 64-row map are 0.4 MB)."""
    out = _run_limited("""
        import tracemalloc
        from envfit.advisor._advise import advise_with
        from envfit.advisor._options import AdviseOptions
        from envfit.base._errors import MemoryBudgetError
        tracemalloc.start()
        try:
            advise_with(big, AdviseOptions(target_rmse=0.01, renderer=True, cache=False))
            out = {"error": None}
        except MemoryBudgetError as exc:
            out = {"error": str(exc)}
        out["traced_peak"] = tracemalloc.get_traced_memory()[1]
    """, 1.0, {"ENVFIT_MEMORY_LIMIT": "60M"})
    msg = out["error"]
    assert msg is not None and "\n" not in msg
    assert msg.startswith("advise on the 8192x4096 map even at 128x64: ")
    assert "can be used" in msg
    assert out["traced_peak"] < 40e6


def test_plan_peak_and_seconds():
    """Plan: peak = resident + the largest stage, seconds summed, check names the stage."""
    p = Plan("x", [Stage("a", 100, 1.0), Stage("b", 300, 2.5, "big")], resident=50)
    assert p.peak() == 350 and p.seconds() == 3.5 and p.worst().name == "b"
    assert p.to_dict()["stages"][1]["peak_bytes"] == 350


def test_plan_check_one_line(monkeypatch):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1000")
    p = Plan("advise", [Stage("map power", 10 ** 6, 3.0, "SH to l = 9")])
    with pytest.raises(MemoryBudgetError) as ei:
        p.check(hint="use --no-renderer")
    msg = str(ei.value)
    assert "\n" not in msg and "map power (SH to l = 9) needs 1.0 MB" in msg
    assert msg.endswith("; use --no-renderer") and f"only {format_bytes(800)}" in msg


def test_small_maps_are_not_downsampled():
    """Maps of at most PREDICTION_MAX_HEIGHT rows whose plan fits keep their size (the
    predictions on city.exr-sized maps are unchanged)."""
    env = EnvMap(np.ones((512, 1024, 3), np.float32))
    h, plan = prediction_height(env, AdviseOptions(target_rmse=0.01, renderer=True))
    assert h == 512 and plan.fits()


def test_prediction_height_follows_the_budget(monkeypatch):
    """The planned height is the largest factor of H whose plan fits: recomputed by brute
    force over the factors."""
    env = EnvMap(np.ones((768, 1536, 1), np.float32))
    opts = AdviseOptions(target_rmse=0.01)
    peaks = {h: advise_plan(h, 1, opts, resident=16 * h * h, source_height=768).peak()
             for h in (768, 384, 256, 192, 128, 96, 64)}
    limit = int(peaks[192] / 0.8) + 1024                 # 80 % of it: 192 rows fit, 256 not
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", str(limit))
    h, plan = prediction_height(env, opts)
    assert h == max(k for k, v in peaks.items() if v <= 0.8 * limit) == 192


def test_sh_analysis_cost_bounds_the_traced_peak():
    """The map power's predicted peak is above the peak numpy allocates (tracemalloc sees
    numpy's buffers, not ducc0's) and within 2.5x of it."""
    rng = np.random.default_rng(0)
    env = EnvMap(rng.random((128, 256, 2)))
    for lmax in (127, 255):
        tracemalloc.start()
        map_degree_power(env, lmax)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        pred = sh_analysis_cost(128, 2, lmax)[0]
        assert peak <= pred <= 2.5 * peak, (lmax, peak, pred)


def test_map_power_refused_beyond_budget(monkeypatch):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "2M")
    with pytest.raises(MemoryBudgetError, match="SH power of a 256x128 map to degree 255"):
        map_degree_power(EnvMap(np.ones((128, 256, 1))), 255)


def test_variance_kept_against_direct_sums():
    """variance_kept: the solid-angle variance of the block means over the original's,
    each recomputed here by direct weighted sums."""
    rng = np.random.default_rng(1)
    env = EnvMap(rng.random((16, 32, 2)))
    small = env.resized(4)

    def var(m):
        w = np.repeat(m.solid_angles()[:, :, None], m.channels, axis=2)
        mu = (w * m.data).sum(axis=(0, 1)) / w.sum(axis=(0, 1))
        return ((w * (m.data - mu) ** 2).sum(axis=(0, 1)) / w.sum(axis=(0, 1)))

    assert np.allclose(solid_angle_variance(env), var(env), rtol=1e-10)
    assert variance_kept(env, small) == pytest.approx(var(small).sum() / var(env).sum(),
                                                      rel=1e-10)
    assert variance_kept(env, env) == pytest.approx(1.0)


def test_cli_refuses_in_one_line(tmp_path):
    """envfit advise on a map whose smallest plan does not fit: exit 2, one line."""
    from envfit.maps._io import save_envmap
    path = save_envmap(tmp_path / "m.exr", np.random.default_rng(0).random((256, 512, 3)),
                       half=True)
    proc = subprocess.run([sys.executable, "-m", "envfit.cli", "advise", str(path), "-q",
                           "--no-cache"], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "ENVFIT_MEMORY_LIMIT": "30M"}, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "advise on the 512x256 map even at 128x64" in lines[0]


def test_lobe_rows_against_the_lobes_funk_hecke_factors():
    """lobe_rows: the fewest H with λ_2H <= 0.1, λ_l = sqrt(4π/(2l+1)) b_l from the lobe's
    own SH coefficients (a second algorithm: the quadrature of theory.brdf)."""
    from envfit.advisor._budget import lobe_rows
    from envfit.theory._brdf import Glossy
    for n in (300.0, 2000.0):
        h = lobe_rows(AdviseOptions(brdf="glossy", shininess=n, target_rmse=0.01))
        b = Glossy(n).sh_coefficients(2 * h + 2)
        lam = [np.sqrt(4 * np.pi / (2 * l + 1)) * abs(b[l]) for l in (2 * h - 2, 2 * h)]
        assert lam[1] <= 0.1 + 0.01 and lam[0] > 0.1 - 0.01, (n, h, lam)
    assert lobe_rows(AdviseOptions(target_rmse=0.01)) == 1


def test_sharp_lobe_keeps_the_rows_it_needs():
    """A glossy n = 1e6 lobe on a 4096-row map is planned at 2048 rows (>= 1073), not 1024."""
    env = EnvMap(np.ones((4096, 8192, 1), np.float16))
    h, _ = prediction_height(env, AdviseOptions(brdf="glossy", shininess=1e6,
                                                target_rmse=0.01))
    assert h == 2048


def test_refusal_names_the_option_that_fits(monkeypatch):
    """Nothing fits with the renderer rows, everything without: the one line says
    ``--no-renderer`` (both plans recomputed here)."""
    env = EnvMap(np.ones((128, 256, 3), np.float32))
    opts = AdviseOptions(target_rmse=0.01, renderer=True)
    res = 8 * 2 * 64 * 64 * 3
    with_r = advise_plan(64, 3, opts, resident=res, source_height=128).peak()
    without = advise_plan(64, 3, AdviseOptions(target_rmse=0.01), resident=res,
                          source_height=128).peak()
    assert without < with_r
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", str(int((without + with_r) / 2 / 0.8)))
    with pytest.raises(MemoryBudgetError) as ei:
        prediction_height(env, opts)
    msg = str(ei.value)
    assert msg.startswith("advise on the 256x128 map even at 128x64: renderer spectra")
    assert msg.endswith("it fits with --no-renderer")


def test_validate_refuses_the_map_power_before_the_fit(monkeypatch):
    """validate's spectral stages (the map power to H − 1, one rule's error power at the
    largest N) are planned before the fit: over budget, one line naming the stage and
    ``--max-height``, and the fit is never started."""
    import envfit.validate._pipeline as pipeline
    from envfit.validate._config import ValidateConfig

    def boom(*a, **k):
        raise AssertionError("the fit ran before the spectral plan was checked")

    monkeypatch.setattr(pipeline, "fit_both", boom)
    rng = np.random.default_rng(0)
    env = EnvMap(rng.random((2048, 4096, 1), dtype=np.float32) + 1.0, name="big.exr")
    cfg = ValidateConfig(n_values=[16, 64], fit_n=200, truncation=False)
    plan = pipeline._spectral_plan(env, cfg)
    # a budget between the earlier guards' needs and this plan's peak
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", str(int(plan.peak() / 0.8 * 0.6)))
    with pytest.raises(MemoryBudgetError, match=r"^validate: map power .* --max-height"):
        pipeline.run_validation(env, cfg)
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", str(int(plan.peak() / 0.8 * 1.05)))
    with pytest.raises(AssertionError, match="the fit ran"):   # fits: on to the fit
        pipeline.run_validation(env, cfg)

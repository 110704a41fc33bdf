"""Every sampler of every renderer answers ``envfit advise MAP --renderer R --sampler S`` with
its defaults (issue 38: envfit's ``sobol`` asked its Cranley-Patterson model for N = 1 on a
2 × 2 grid, ``jitter`` and pbrt-v4's ``stratified`` for r × r strata at a non-square N, pbrt-v4's
``pmj02bn`` as ``sobol``): a real answer (the spp meeting the target, or "no spp up to X
meets" with the reason), or, for a sampler the model lacks, one line that names only samplers
which answer themselves.

The answer is checked against a second path: a fresh
:class:`~envfit.predict.renderer._diffuse_model.DiffuseModel` with the CLI's default level for
the sampler predicts the answer (it meets the target) and the runnable spp below it (it
misses). The model runs on 1 normal (``--renderer-normals 1``; the level and the spp searched
are the defaults) and a 16-row map, so each case takes seconds.
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from envfit.advisor._renderer_options import default_level
from envfit.data_gen import gaussian_process_map
from envfit.maps import EnvMap, load_envmap, save_envmap
from envfit.predict.renderer._diffuse_model import DiffuseModel, RendererModelOptions
from envfit.renderers import get_renderer

RENDERERS = ("envfit", "mitsuba3", "pbrt4", "cycles")
#: samplers the noise model lacks (refused in one line before the map is read)
NO_MODEL = {("envfit", "lp"), ("envfit", "sf"), ("envfit", "bnot"), ("pbrt4", "halton"),
            ("pbrt4", "sobol")}
CASES = [(r, s) for r in RENDERERS for s in get_renderer(r).samplers]


@pytest.fixture(scope="module")
def gp_file(tmp_path_factory):
    env = EnvMap(gaussian_process_map(1.8, 16, seed=3, channels=3) + 2.0, name="gp16")
    path = tmp_path_factory.mktemp("maps") / "gp16.exr"
    save_envmap(path, env)
    return path


def _run(capsys, tmp_path, *args):
    from envfit.cli import main
    out = tmp_path / "a.json"
    rc = main(["advise", *map(str, args), "--renderer-normals", "1",
               "--cache-dir", str(tmp_path / "cache"), "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err.strip().splitlines(), d


def test_every_sampler_is_covered():
    assert len(CASES) >= 20 and NO_MODEL <= set(CASES)


@pytest.mark.parametrize("renderer, sampler", [c for c in CASES if c not in NO_MODEL])
def test_sampler_answers_at_its_defaults(renderer, sampler, gp_file, tmp_path, capsys):
    rc, lines, err, d = _run(capsys, tmp_path, gp_file, "--renderer", renderer,
                             "--sampler", sampler)
    assert rc == 0, err
    lines = [x for x in lines if not x.startswith("note: ")]      # the map's notes first
    rec = d["renderer"]["recommendation"]
    spec = get_renderer(renderer).sampler(sampler)
    opts = RendererModelOptions(normals=1, max_level=default_level(spec.randomisation))
    m = DiffuseModel(load_envmap(gp_file), get_renderer(renderer), options=opts)
    target, s = rec["target_rmse"], rec["strategy"]
    if rec["reached"]:
        n = rec["spp"]
        assert f": spp = {n} for an RMSE of at most" in lines[0]
        assert m.predict(s, sampler, n).rmse <= target
        assert rec["predicted_rmse"] == pytest.approx(m.predict(s, sampler, n).rmse, rel=1e-9)
        below = re.search(r", \S+ at (\d+) spp \(misses\)", lines[0])
        if below:
            assert m.predict(s, sampler, int(below.group(1))).rmse > target
    else:
        top = d["renderer"]["spp_cap"]
        assert f"no spp up to {top} meets" in lines[0]
        assert m.predict(s, sampler, top).rmse > target


@pytest.mark.parametrize("renderer, sampler", sorted(NO_MODEL))
def test_sampler_without_model_is_one_line_naming_samplers_that_answer(renderer, sampler,
                                                                         tmp_path, capsys):
    rc, _, err, _ = _run(capsys, tmp_path, tmp_path / "absent.exr", "--renderer", renderer,
                         "--sampler", sampler)
    assert rc == 2 and len(err) == 1 and "no noise model" in err[0]
    named = re.search(r"choose --sampler (.*)$", err[0])
    if named:
        for other in re.split(r", | or ", named.group(1)):
            assert (renderer, other) in CASES and (renderer, other) not in NO_MODEL


def test_jitter_layouts_against_brute_force():
    """envfit's rows and pbrt-v4's x × y strata at non-square N: the model's MSE against
    stratified points drawn here (independently of the model's moments)."""
    from envfit.predict.renderer.randomisation import DyadicGrid, randomised_mse
    from envfit.renderers.pbrt4._light import pbrt_strata
    from envfit.theory import stratified_jitter

    def f(u):
        return np.exp(-20 * ((u[:, 0] - 0.3) ** 2 + (u[:, 1] - 0.6) ** 2)) + (u[:, 0] > 0.5)

    g = DyadicGrid.from_callable(f, 7, nodes=2)
    exact = float(g.integral[0])
    rng = np.random.default_rng(0)
    for n in (7, 30, 40):
        x, y = pbrt_strata(n)
        cells = np.stack(np.meshgrid(np.arange(x), np.arange(y), indexing="ij"), -1)
        cells = cells.reshape(-1, 2)
        draws = {"rows": [f(stratified_jitter(n, seed=s)).mean() for s in range(4000)],
                 "pbrt": [f((cells + rng.random((n, 2))) / [x, y]).mean()
                          for _ in range(4000)]}
        for layout, est in draws.items():
            opts = {"layout": "rows"} if layout == "rows" else {"strata": (x, y)}
            mse = float(randomised_mse("jittered", g, n, **opts).mse[0])
            brute = float(np.mean((np.asarray(est) - exact) ** 2))
            assert brute == pytest.approx(mse, rel=0.12), (n, layout)

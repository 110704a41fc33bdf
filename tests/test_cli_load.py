"""The API and the CLI read and write the same maps: ``load_envmap(path, convention=,
max_height=)`` is what ``envfit CMD MAP --convention C --max-height H`` works on (convention
first, then the downscale), and ``envfit synth`` writes ``synthesize_envmap``'s map. Oracles:
the steps composed by hand (convention.to_internal, EnvMap.resized), the CLI's own output
(``info --json``, the written file)."""
from __future__ import annotations

import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.base import ParameterError
from envfit.base._atomic import to_jsonable
from envfit.cli._common import load_map_from_args
from envfit.maps import (convention, describe_envmap, list_sources, load_envmap, save_envmap,
                         synthesize_envmap)

H = 16


@pytest.fixture
def mitsuba_file(tmp_path):
    data = np.random.default_rng(7).gamma(2.0, 1.0, (H, 2 * H, 3)).astype(np.float32)
    return save_envmap(tmp_path / "m.exr", data), data


def test_convention_then_max_height(mitsuba_file):
    path, data = mitsuba_file
    conv = convention("mitsuba3")
    api = load_envmap(path, convention="mitsuba3", max_height=8)
    by_hand = conv.to_internal(load_envmap(path, up="y")).resized(8)
    np.testing.assert_array_equal(api.data, by_hand.data)
    assert api.up == "y" and api.height == 8 and any("Mitsuba 3" in n for n in api.notes)
    # the order matters: converting the downscaled map is another map (Mitsuba's rows are
    # on the poles: the resampling sees other pixels)
    other = conv.to_internal(load_envmap(path, max_height=8))
    assert not np.allclose(api.data, other.data)
    # a convention object works as its name; an exact permutation (Blender) stays exact
    np.testing.assert_array_equal(load_envmap(path, convention=conv).data,
                                  conv.to_internal(load_envmap(path)).data)
    blender = load_envmap(path, convention="blender")
    assert blender.up == "z" and sorted(blender.data.ravel()) == sorted(data.ravel())


def test_convention_refusals(mitsuba_file):
    path, _ = mitsuba_file
    with pytest.raises(ParameterError, match="exclude each other"):
        load_envmap(path, up="y", convention="mitsuba3")
    with pytest.raises(ParameterError, match="pbrt4"):
        load_envmap(path, convention="pbrt4")
    with pytest.raises(ParameterError, match="unknown --convention 'maya'"):
        load_envmap(path, convention="maya")


def test_cli_reads_the_api_map(mitsuba_file, tmp_path, monkeypatch):
    path, _ = mitsuba_file
    monkeypatch.setattr(cli, "COMMANDS", ("info",))
    argv = ["info", str(path), "--convention", "mitsuba3", "--max-height", "8"]
    args = cli.build_parser("info").parse_args(argv)
    api = load_envmap(path, convention="mitsuba3", max_height=8)
    np.testing.assert_array_equal(load_map_from_args(args).data, api.data)
    js = tmp_path / "info.json"
    assert cli.main([*argv, "--json", str(js), "--quiet"]) == 0
    got = json.loads(js.read_text())
    conv = convention("mitsuba3")
    want = json.loads(json.dumps(to_jsonable(describe_envmap(api, conv, list_sources(api, conv)))))
    assert {k: got[k] for k in want} == want


def test_cli_synth_writes_the_api_map(tmp_path, monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("synth",))
    for kind, extra in (("marker", ["--convention", "blender"]),
                        ("sun-gp", ["--convention", "mitsuba3", "--seed", "3"]),
                        ("gp", ["--up", "z", "--channels", "1"])):
        out, js = tmp_path / f"{kind}.exr", tmp_path / f"{kind}.json"
        assert cli.main(["synth", str(out), "--kind", kind, "--height", str(H), *extra,
                         "--json", str(js), "--quiet"]) == 0
        kw = {"convention": extra[1]} if extra[0] == "--convention" else {"up": "z"}
        made = synthesize_envmap(kind, H, seed=3 if kind == "sun-gp" else 0,
                                 **kw, **({"channels": 1} if kind == "gp" else {}))
        written = load_envmap(out, **({"up": made.envmap.up}))
        np.testing.assert_array_equal(written.data, made.envmap.data)
        info = json.loads(js.read_text())
        assert {k: info[k] for k in made.synth.to_dict()} == json.loads(
            json.dumps(made.synth.to_dict()))
        assert info["up"] == made.envmap.up and info["max"] == float(made.pixels.max())

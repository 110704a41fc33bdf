"""Issue 23, point 3: one key of s (envfit.base._keys), the warped spectrum's cache format on
its class, one Stage — each checked against the bytes that earlier versions stored."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from envfit.base._errors import ParameterError
from envfit.base._keys import s_key, s_value
from envfit.base._resources import Plan, Stage
from envfit.predict.warped._warped_spectrum import SPECTRUM_FORMAT, WarpedSpectrum
from envfit.validate._cells import cell_is_current, rule_from_cell

DATA = Path(__file__).parent / "data"

#: the keys stores written before issue 23 hold (typed out, not computed)
OLD_KEYS = {1.1: "1.1000", 1.15: "1.1500", 1.5: "1.5000", 1.9999999: "2.0000",
            1.23456: "1.2346", 2: "2.0000", 1.00005: "1.0001", 3.14159: "3.1416"}


@pytest.mark.parametrize("s,key", sorted(OLD_KEYS.items()))
def test_s_key_is_the_stored_string(s, key):
    assert s_key(s) == key
    assert s_key(np.float64(s)) == key and s_key(np.float32(s)) == f"{float(np.float32(s)):.4f}"


def test_s_key_equals_the_old_format_on_a_sweep():
    # the old code's two spellings: validate's f"{float(s):.4f}", table2's f"s{s:.4f}_n{n}"
    for s in np.concatenate([np.linspace(1.0, 3.0, 2001), np.random.default_rng(5).uniform(
            1.0, 3.0, 2000)]):
        assert s_key(s) == f"{float(s):.4f}" == f"{s:.4f}"


def test_s_value_rounds_to_a_micro():
    assert s_value(1.9999999) == 2.0 and s_value(1.15) == 1.15
    assert s_value(1.23456789) == 1.234568 and isinstance(s_value(np.float32(1.5)), float)


def test_a_validate_cell_stored_before_is_current_and_read():
    old = {"n": 16, "band_lmax": 7, "error_power": [0.0, 1.0], "weight_sum": 1.0,
           "wce": {"1.1000": 0.3, "1.1500": 0.2, "2.0000": 0.1},
           "wce_bandlimited_by_s": {"1.1000": 0.3, "1.1500": 0.2, "2.0000": 0.1}}
    assert cell_is_current(old, 7, [s_key(s) for s in (1.1, 1.15, 1.9999999)])
    assert not cell_is_current(old, 7, [s_key(1.5)])
    assert rule_from_cell(old, 1.15).wce == 0.2 and rule_from_cell(old, 1.9999999).wce == 0.1


def test_table2_cells_keep_their_file_names(tmp_path):
    from envfit.fit._table2 import run_table2
    from envfit.maps._envmap import EnvMap
    data = 1.0 + np.random.default_rng(2).random((8, 16, 1))
    run_table2(EnvMap(data.astype(np.float32)), [1.15, 1.5], [12], scale="linear", out=tmp_path,
               save_reconstructions=False, quiet=True)
    names = sorted(p.name for p in (tmp_path / "cells").glob("*.json"))
    assert names == ["s1.1500_n12.json", "s1.5000_n12.json"]


# ----------------------------------------------------------------------------- spectrum

def test_a_spectrum_cached_by_the_old_code_loads_and_writes_back_the_same_bytes():
    # written by envfit.advisor._rule_rows.spectrum_to_json before it moved onto the class
    # (MIS, glossy 20, grid 8, 4 axes on a random 16x8 map; SPECTRUM_FORMAT 2)
    text = (DATA / "warped_spectrum_format2.json").read_text().strip()
    assert SPECTRUM_FORMAT == 2
    spec = WarpedSpectrum.from_json(json.loads(text))
    assert (spec.technique, spec.brdf, spec.shininess, spec.band) == ("mis", "glossy", 20.0, 2)
    assert spec.power.shape == (2, 5, 3) and spec.cross.dtype == np.complex128
    assert spec.cross[1] == complex(-0.0007608850635713407, -0.001933962681825534)
    assert json.dumps(spec.to_json(), sort_keys=True, separators=(",", ":")) == text


def test_spectrum_round_trip_is_exact_and_a_bad_one_refused():
    rng = np.random.default_rng(1)
    spec = WarpedSpectrum("map", "diffuse", None, "balance", 0.5, 3, 12, rng.random(1),
                          rng.random((1, 7, 4)), np.zeros(7, complex) + 1j * rng.random(7),
                          0.7, 8)
    back = WarpedSpectrum.from_json(json.loads(json.dumps(spec.to_json())))
    for name in ("variance", "power", "cross"):
        assert np.array_equal(getattr(back, name), getattr(spec, name))
    assert back.to_dict() == spec.to_dict() and back.shininess is None
    bad = spec.to_json()
    bad["power"] = [[row[:2] for row in part] for part in bad["power"]]
    with pytest.raises(ParameterError, match="not a stored warped spectrum"):
        WarpedSpectrum.from_json(bad)


# ----------------------------------------------------------------------------- stage

def test_the_sh_plan_stages_are_the_plan_stages():
    from envfit.sh._plan import Rates, sh_stages
    rates = Rates(basis=1e-8, flop=1e-10, synthesis=1e-9, rotation=1e-9)
    stages = sh_stages(16, 3, 4, 6, rates=rates)
    assert all(type(s) is Stage for s in stages)
    assert [s.option for s in stages] == ["--lmax", "--table-lmax", "--check-height",
                                          "--check-axes"]
    p = Plan("sh", stages)
    assert p.peak() == max(s.nbytes for s in stages) and p.worst() in stages
    assert Stage("fit", 10).option == ""

"""Every command that writes ``--out`` writes at least one PNG a person looks at first.

One case per command, each in its quickest mode on a 32x16 map, through ``envfit.cli.main``;
the PNG must be a real image (signature, IHDR, a plausible size) and the command's output
must name it. Commands whose PNG an existing test already asserts are not repeated here:
``table2`` (tests/test_table2.py, ``table2_rmse.png``; libraries: tests/test_library.py,
``library_s_best.png``), ``fit`` (tests/test_fit.py, ``fit_likelihood.png``; libraries:
``library_fit_s.png``), ``theory figures`` (tests/test_cli_theory.py), ``validate``
(tests/test_validate.py, ``validate_*.png``) and ``advise`` with the renderer rows
(tests/test_advise_renderer.py, ``advise.png``).
"""
from __future__ import annotations

import numpy as np
import pytest

import envfit.cli as cli
from envfit.data_gen import SunSkyMap
from envfit.maps._io import save_envmap

ADVISE_QUICK = ["--brdf", "diffuse", "--no-renderer", "--no-cache", "--pointsets", "sf",
                "--weights", "equal", "--bases", "sh", "--fit-n", "100", "--nmax", "256",
                "--target-relative", "0.05"]

CASES = {
    "synth": (["synth", "{tmp}/m.exr", "--kind", "sun", "--height", "16"], "m_preview.png"),
    "info": (["info", "{map}"], "sun_preview.png"),
    "theory wce": (["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--weights", "equal",
                    "--n", "32"], "wce_spectrum.png"),
    "theory table1": (["theory", "table1"], "table1.png"),
    "advise --no-renderer": (["advise", "{map}", *ADVISE_QUICK], "advise_rules.png"),
}


@pytest.fixture(scope="module")
def sun_exr(tmp_path_factory):
    m = SunSkyMap(sun_theta=0.7, sun_phi=2.0, sun_radius=0.2, sun_radiance=50.0, sky=(0.3, 0.4, 0.8))
    return save_envmap(tmp_path_factory.mktemp("maps") / "sun.exr", m.render(16).astype(np.float32))


@pytest.mark.parametrize("case", sorted(CASES))
def test_out_writes_a_png(case, sun_exr, tmp_path, capsys):
    argv, png = CASES[case]
    out = tmp_path / "out"
    argv = [a.format(tmp=tmp_path, map=sun_exr) for a in argv] + ["--out", str(out)]
    assert cli.main(argv) == 0
    path = out / png
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    w, h = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert 300 <= w <= 3000 and 150 <= h <= 3000
    assert str(path) in capsys.readouterr().out                      # the command names it

"""``examples/quickstart.py`` runs end to end (its own process, cwd a temporary folder, a
time limit), exits 0, prints each step's result and writes every PNG it names."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "quickstart.py"
PNGS = ("preview.png", "fit_likelihood.png", "table2_rmse.png", "advise_rules.png",
        "validate_quadrature_glossy.png", "validate_absolute_glossy.png",
        "validate_truncation.png", "validate_s_choice.png")


@pytest.mark.skipif(not SCRIPT.exists(), reason="examples/ is not part of this installation")
def test_quickstart_runs_and_writes_its_pngs(tmp_path):
    run = subprocess.run([sys.executable, str(SCRIPT)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=240)
    assert run.returncode == 0, run.stderr[-2000:]
    out = tmp_path / "quickstart_out"
    for name in PNGS:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    text = run.stdout
    assert "map builtin:gp(s0=1.5,height=32,seed=0): 64x32" in text
    assert "recommendation:" in text and "validate sf/equal N = 64" in text
    assert f"wrote {len(PNGS)} PNGs to quickstart_out" in text

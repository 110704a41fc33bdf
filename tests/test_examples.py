"""``examples/quickstart.py`` runs end to end (its own process, cwd a temporary folder, a
time limit), exits 0, prints each step's result and writes every PNG it names; and
``examples/quickstart.ipynb`` holds exactly the script's cells (``examples/make_notebook.py``),
so the notebook runs the code this test ran."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPT = EXAMPLES / "quickstart.py"
PNGS = ("preview.png", "fit_likelihood.png", "table2_rmse.png", "advise_rules.png",
        "validate_quadrature_glossy.png", "validate_absolute_glossy.png",
        "validate_truncation.png", "validate_s_choice.png")

pytestmark = pytest.mark.skipif(not SCRIPT.exists(), reason="examples/ is not in this checkout")


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


def test_notebook_is_the_script():
    spec = importlib.util.spec_from_file_location("make_notebook", EXAMPLES / "make_notebook.py")
    mk = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mk)
    committed = (EXAMPLES / "quickstart.ipynb").read_text()
    assert committed == mk.notebook_text(SCRIPT), "run python examples/make_notebook.py"
    code = "\n".join("".join(c["source"]) for c in json.loads(committed)["cells"]
                     if c["cell_type"] == "code")
    script_code = [ln for ln in SCRIPT.read_text().splitlines()
                   if ln.strip() and not ln.startswith("#")]
    assert [ln for ln in code.splitlines() if ln.strip() and not ln.startswith("#")] == script_code

"""Write ``examples/quickstart.ipynb`` from ``examples/quickstart.py`` (the notebook is
generated, never edited by hand): ``python examples/make_notebook.py [--check]``.

The script is in the percent format of Jupytext and VS Code: ``# %%`` starts a code cell,
``# %% [markdown]`` a markdown cell whose lines are comments (``# `` stripped). The notebook
is nbformat 4.4 JSON written with the standard library (no Jupyter needed to build it), no
outputs, a ``python3`` kernel. ``--check`` exits 1 if the committed notebook differs from
what the script gives (``tests/test_examples.py`` runs the same comparison).

>>> cells = split_cells("# %% [markdown]\\n# # Title\\n\\n# %%\\nx = 1\\nx\\n")
>>> [(c["cell_type"], "".join(c["source"])) for c in cells]
[('markdown', '# Title'), ('code', 'x = 1\\nx')]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCRIPT, NOTEBOOK = HERE / "quickstart.py", HERE / "quickstart.ipynb"


def _cell(kind: str, lines: list[str]) -> dict:
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    if kind == "markdown":
        lines = [ln[2:] if ln.startswith("# ") else ln.lstrip("#") for ln in lines]
    source = [ln + "\n" for ln in lines[:-1]] + lines[-1:]
    cell = {"cell_type": kind, "metadata": {}, "source": source}
    if kind == "code":
        cell.update(execution_count=None, outputs=[])
    return cell


def split_cells(text: str) -> list[dict]:
    """The notebook cells of a percent-format script (module docstring)."""
    cells, kind, lines = [], None, []
    for line in text.splitlines():
        if line.startswith("# %%"):
            if kind is not None:
                cells.append(_cell(kind, lines))
            kind, lines = ("markdown" if "[markdown]" in line else "code"), []
        elif kind is not None and (lines or line.strip()):
            lines.append(line)
    if kind is not None:
        cells.append(_cell(kind, lines))
    return cells


def notebook_text(script: Path = SCRIPT) -> str:
    """The ``.ipynb`` JSON of ``script``."""
    nb = {"cells": split_cells(script.read_text()),
          "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python",
                                      "name": "python3"},
                       "language_info": {"name": "python"}},
          "nbformat": 4, "nbformat_minor": 4}
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    text = notebook_text()
    if "--check" in sys.argv[1:]:
        same = NOTEBOOK.exists() and NOTEBOOK.read_text() == text
        print(f"{NOTEBOOK.name} {'is' if same else 'is NOT'} up to date with {SCRIPT.name}")
        sys.exit(0 if same else 1)
    NOTEBOOK.write_text(text)
    print(f"wrote {NOTEBOOK}")

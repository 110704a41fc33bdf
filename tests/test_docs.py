"""The documentation: the README stays a page whose first block holds the two commands CI runs,
every ``bench/`` script the docs name exists, and the Sphinx site (``docs/``: guides, API
reference from the docstrings, errata, validation) builds with warnings as errors."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"


def _first_fenced_block(text: str) -> list[str]:
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("```"))
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("```"))
    return lines[start + 1:end]


def test_readme_is_a_page_that_starts_with_the_two_commands():
    text = README.read_text()
    assert len(text.splitlines()) <= 200
    commands = [ln.split("#")[0].strip() for ln in _first_fenced_block(text)]
    assert commands == ['pip install . && envfit table2 --quick',
                        'pip install ".[test]" && pytest -q']


def test_ci_runs_the_readmes_test_command():
    ci = ROOT / ".ci" / "run"
    assert ci.exists(), "the repository's CI script .ci/run is missing"
    second = _first_fenced_block(README.read_text())[1].split("#")[0].strip()
    assert second in [ln.strip() for ln in ci.read_text().splitlines()]


def test_every_bench_script_the_docs_name_exists():
    named = set()
    for page in [README, *DOCS.rglob("*.md")]:
        if "_build" in page.parts:
            continue
        named |= set(re.findall(r"bench/[\w.-]+\.(?:py|sh)\b", page.read_text()))
    assert named, "the docs name no bench/ script"
    assert sorted(n for n in named if not (ROOT / n).is_file()) == []


def _python_imports(text: str) -> list[str]:
    """The ``import``/``from … import`` lines of the ```python blocks of a Markdown text."""
    found, inside = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            inside = line.strip() == "```python"
            continue
        code = line.split("#")[0].rstrip()
        if inside and re.match(r"(from|import) envfit\b", code):
            found.append(code)
    return found


def test_the_docs_python_imports_resolve():
    """Every import the README and the docs show works (a module moved or a name renamed
    makes the page wrong)."""
    lines = [ln for page in [README, *DOCS.rglob("*.md")] if "_build" not in page.parts
             for ln in _python_imports(page.read_text())]
    assert "import envfit" in lines
    for line in lines:
        exec(line, {})                                # noqa: S102 — the page's own line


def test_the_checker_sees_a_missing_block():
    with pytest.raises(StopIteration):
        _first_fenced_block("# envfit\nno block here\n")


@pytest.mark.slow
def test_sphinx_site_builds_without_warnings(tmp_path):
    for module in ("sphinx", "numpydoc", "myst_parser"):
        pytest.importorskip(module)
    out = tmp_path / "html"
    # cwd outside the repository: the installed envfit is documented (envfit.theory and
    # envfit.data_gen exist only as installed), warnings are errors, one process
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-j", "1", "-q",
                          "-b", "html", str(DOCS), str(out)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=420)
    assert run.returncode == 0, (run.stdout + run.stderr)[-4000:]
    assert "UserWarning" not in run.stderr, run.stderr[-4000:]     # numpydoc: unknown sections
    index = (out / "index.html").read_text()
    for page in ("guides/synth", "guides/advise", "guides/libraries", "conventions", "ERRATA",
                 "validation", "architecture", "changelog", "reliability", "api/index"):
        assert f'href="{page}.html"' in index, page
    api = (out / "api" / "envfit.html").read_text()
    import envfit
    for name in ("load_envmap", "fit_smoothness", "advise"):
        assert name in envfit.__all__ and f"envfit.{name}" in api, name
    assert "usage: envfit advise" in (out / "guides" / "advise.html").read_text()

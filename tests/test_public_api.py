"""The public API: every sub-package's ``__all__`` resolves (lazily, PEP 562), importing a
sub-package loads none of its modules, and the README, the docs and the examples import
envfit names only from ``envfit`` or ``envfit.<sub-package>`` — never from a module."""
from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

import envfit

ROOT = Path(__file__).resolve().parents[1]


def _sub_packages() -> list[str]:
    found = sorted(".".join(("envfit",) + p.parent.relative_to(ROOT / "envfit").parts)
                   for p in (ROOT / "envfit").rglob("__init__.py") if p.parent != ROOT / "envfit")
    return [f for f in found if f != "envfit.cli"]          # the entry point: main only


PACKAGES = _sub_packages()


@pytest.mark.parametrize("name", PACKAGES)
def test_every_public_name_resolves(name):
    pkg = importlib.import_module(name)
    assert pkg.__doc__ and len(pkg.__doc__.split()) > 10, f"{name} has no role docstring"
    assert pkg.__all__, f"{name} declares no public names"
    for attr in pkg.__all__:
        value = getattr(pkg, attr)
        assert not isinstance(value, type(envfit)), f"{name}.{attr} is a module, not a name"


def test_envfit_names_resolve():
    for attr in envfit.__all__:
        getattr(envfit, attr)


def test_importing_a_sub_package_loads_none_of_its_modules():
    """Only the errors (envfit/__init__), the record of when envfit was imported (the dask
    workers' code check) and the lazy-export helper every package uses."""
    code = ("import sys, importlib\n"
            f"for name in {PACKAGES!r}:\n"
            "    importlib.import_module(name)\n"
            "loaded = sorted(m for m in sys.modules if m.startswith('envfit.') and m not in "
            f"{PACKAGES!r} and m not in ('envfit.base._errors', 'envfit.base._lazy',\n"
            "'envfit.base._code'))\n"
            "print(loaded)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _python_blocks(path: Path) -> list[str]:
    text = path.read_text()
    if path.suffix == ".py":
        return [text]
    return re.findall(r"```(?:python|py|pycon)\n(.*?)```", text, re.S)


#: the mark that lets a benchmark import an internal, with the reason: ``# internal: <why>``
INTERNAL_MARK = "# internal:"


def _deep_imports(code: str, allow_marked: bool = False) -> list[str]:
    """The implementation modules (and private names) ``code`` imports from envfit; with
    ``allow_marked``, imports whose lines carry :data:`INTERNAL_MARK` are allowed."""
    bad = []
    lines = [ln[4:] if ln.startswith((">>> ", "... ")) else ln for ln in code.splitlines()]
    try:
        tree = ast.parse("\n".join(lines))
    except SyntaxError:                 # a fragment: look at the import lines alone
        lines = [ln for ln in lines if ln.lstrip().startswith(("from ", "import "))
                 and not ln.rstrip().endswith(("(", ","))]
        tree = ast.parse("\n".join(lines))
    public = set(PACKAGES) | {"envfit", "envfit.theory", "envfit.data_gen"}
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module]
            if node.module in public:   # ``from envfit.x import _module``: private all the same
                names += [f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        if allow_marked and names and any(INTERNAL_MARK in ln for ln in
                                          lines[node.lineno - 1:node.end_lineno]):
            continue
        for n in names:
            parts = n.split(".")
            if parts[0] == "envfit" and n not in public:
                bad.append(n)
    return bad


DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
        *sorted((ROOT / "examples").glob("*.py"))]


@pytest.mark.parametrize("path", [p for p in DOCS if "_build" not in p.parts],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_docs_import_only_public_names(path):
    bad = [n for block in _python_blocks(path) for n in _deep_imports(block)]
    assert bad == [], f"{path.name} imports from implementation modules: {bad}"


def test_the_checker_sees_a_deep_import():
    assert _deep_imports("from envfit.sampling._map_sampler import MapSampler") == \
        ["envfit.sampling._map_sampler"]
    assert _deep_imports(">>> from envfit.sampling import MapSampler") == []
    assert _deep_imports("from envfit.shading import _estimators as E") == \
        ["envfit.shading._estimators"]
    marked = "from envfit.theory._cholesky import (  # internal: timed bare\n    cholesky_inplace)"
    assert _deep_imports(marked) == ["envfit.theory._cholesky"]
    assert _deep_imports(marked, allow_marked=True) == []
    assert _deep_imports("from envfit.theory._sh import x  # internal\n", allow_marked=True) == \
        ["envfit.theory._sh"]                                  # a mark needs its reason


BENCH = sorted((ROOT / "bench").glob("*.py"))


@pytest.mark.parametrize("path", BENCH, ids=lambda p: str(p.relative_to(ROOT)))
def test_bench_imports_only_public_names(path):
    """The benchmarks regenerate the docs' tables with the public API; an internal they
    truly need (a kernel timed bare, an instrumented stage) is imported on a line marked
    ``# internal: <why>``."""
    bad = _deep_imports(path.read_text(), allow_marked=True)
    assert bad == [], (f"{path.name} imports from implementation modules without an "
                       f"'{INTERNAL_MARK} <why>' mark: {bad}")


#: the modules that are public by design: the CLI's ``python -m envfit.cli`` entry and the one
#: table of defaults and vocabularies (docs/architecture.md)
PUBLIC_MODULES = {"envfit/defaults.py", "envfit/cli/__main__.py"}


def test_implementation_modules_are_private():
    """As scipy.stats.qmc: the public surface is ``envfit`` and each sub-package's ``__all__``;
    every module that implements them is private (``_name.py``)."""
    public = []
    for top in ("envfit", "theory", "data_gen"):
        for p in (ROOT / top).rglob("*.py"):
            rel = p.relative_to(ROOT).as_posix()
            if p.name == "__init__.py" or p.name.startswith("_") or rel in PUBLIC_MODULES:
                continue
            public.append(rel)
    assert public == [], f"implementation modules with public names: {sorted(public)}"

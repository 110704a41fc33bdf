"""The examples in the docstrings of envfit, theory and data_gen run and print what they say
(``doctest.testmod`` on every module of the installed packages)."""
from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import envfit
import envfit.data_gen as data_gen
import envfit.theory as theory


def _modules() -> list[str]:
    names = []
    for pkg in (envfit, theory, data_gen):
        names.append(pkg.__name__)
        names += [m.name for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + ".")
                  if not m.name.endswith("__main__")]
    return sorted(names)


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                     # an example that writes, writes here
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path / "cache"))
    module = importlib.import_module(name)
    with np.printoptions(legacy=False):
        result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                                 verbose=False, report=True)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


ORACLES = sorted(p.stem for p in (Path(__file__).parent / "oracles").glob("*.py")
                 if p.stem != "__init__")


@pytest.mark.parametrize("name", ORACLES)
def test_oracle_docstring_examples(name, tmp_path, monkeypatch):
    """The test oracles (tests/oracles/, second algorithms not shipped) keep their examples."""
    test_docstring_examples(f"oracles.{name}", tmp_path, monkeypatch)

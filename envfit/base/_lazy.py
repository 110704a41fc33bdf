"""Lazy re-exports of a package's public names (PEP 562), so that importing a sub-package
loads none of its modules until a name is used.

>>> import types, sys
>>> pkg = types.ModuleType("envfit_demo_pkg"); pkg.__path__ = []
>>> sys.modules["envfit_demo_pkg"] = pkg
>>> pkg.__getattr__, pkg.__dir__ = lazy_exports("envfit_demo_pkg", {"x": "mod"})
>>> "x" in pkg.__dir__()
True
>>> del sys.modules["envfit_demo_pkg"]
"""
from __future__ import annotations

import importlib
import sys
from typing import Callable

__all__ = ["lazy_exports"]


def lazy_exports(package: str, table: dict[str, str]) -> tuple[Callable, Callable]:
    """The module-level ``__getattr__`` and ``__dir__`` of ``package`` whose names ``table``
    maps to the submodule (relative to the package) that defines each; a name is imported on
    first use and then cached in the package's namespace.

    Use in a package's ``__init__.py``::

        _LAZY = {"EnvMap": "envmap", "load_envmap": "io"}
        __all__ = sorted(_LAZY)
        __getattr__, __dir__ = lazy_exports(__name__, _LAZY)
    """
    def __getattr__(name: str):
        mod = table.get(name)
        if mod is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{mod}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__

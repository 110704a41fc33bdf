"""Sphinx configuration of envfit's documentation (``sphinx-build -b html docs docs/_build``).

The pages are Markdown (MyST); the API reference is generated from the docstrings
(numpydoc) of the public names: ``envfit.__all__`` and the ``__all__`` of every sub-package
that declares one. Its pages are written at configuration time into ``docs/api/``, and each
command's ``--help`` into ``docs/_generated/`` (both git-ignored), so a sub-package that gains
or changes its ``__all__``, or a command that gains an option, is documented without editing
these files.
"""
from __future__ import annotations

import contextlib
import importlib
import io
import os
import pkgutil
from pathlib import Path

import envfit

project = "envfit"
author = "envfit developers"
copyright = "envfit developers"
release = version = envfit.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated", "Thumbs.db", ".DS_Store"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": False}
# numpydoc: the member lists of classes would each need their own autosummary stub pages
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()

html_theme = "alabaster"
html_title = f"envfit {release}"

HERE = Path(__file__).resolve().parent
API = HERE / "api"
GENERATED = HERE / "_generated"
#: the commands whose ``--help`` the guides include (``_generated/help_<name>.txt``)
HELP_COMMANDS = ("synth", "info", "fit", "table2", "theory", "theory wce", "theory table1",
                 "theory figures", "validate", "advise", "sh", "frame")


def public_packages() -> list[str]:
    """envfit, then every sub-package (sorted) whose ``__init__`` declares ``__all__``."""
    names = ["envfit"]
    for info in pkgutil.walk_packages(envfit.__path__, "envfit."):
        if info.ispkg and hasattr(importlib.import_module(info.name), "__all__"):
            names.append(info.name)
    for extra in ("envfit.theory", "envfit.data_gen"):    # installed from theory/ and data_gen/
        if extra not in names and hasattr(importlib.import_module(extra), "__all__"):
            names.append(extra)
    return names[:1] + sorted(names[1:])


def package_page(name: str, seen: dict | None = None) -> str:
    """The reStructuredText of one package: its docstring and an autosummary of its ``__all__``.

    A name re-exported by several packages (``envfit.EnvMap`` is ``envfit.maps.EnvMap``) is
    documented once, where it is first met (``envfit``, then the sub-packages in order);
    the later packages link to that page."""
    module = importlib.import_module(name)
    seen = {} if seen is None else seen
    public = [n for n in module.__all__ if not (n.startswith("__") and n.endswith("__"))]
    own, also = [], []
    for n in public:
        obj = getattr(module, n)
        key = (getattr(obj, "__module__", None), getattr(obj, "__qualname__", None))
        if key[1] is not None and key in seen:
            also.append(f"``{n}`` (:obj:`{seen[key]}.{n}`)")
            continue
        if key[1] is not None:
            seen[key] = name
        own.append(n)
    lines = [name, "=" * len(name), "", f".. automodule:: {name}", "   :no-members:", "",
             f".. currentmodule:: {name}", "", ".. autosummary::", "   :toctree: generated", ""]
    lines += [f"   {n}" for n in own]
    if also:
        lines += ["", "Also here: " + ", ".join(also) + "."]
    return "\n".join(lines) + "\n"


def write_api_pages() -> None:
    """Write ``api/<package>.rst`` and ``api/index.rst`` (only where the text changed)."""
    API.mkdir(exist_ok=True)
    seen: dict = {}
    pages = {f"{name}.rst": package_page(name, seen) for name in public_packages()}
    toc = ["API reference", "=============", "",
           "The supported names: ``envfit.__all__`` and each sub-package's ``__all__``",
           "(generated from the docstrings; implementation modules are not listed).", "",
           ".. toctree::", "   :maxdepth: 1", ""]
    pages["index.rst"] = "\n".join(toc + [f"   {p[:-4]}" for p in pages]) + "\n"
    for stale in API.glob("*.rst"):
        if stale.name not in pages:
            stale.unlink()
    # autosummary's pages of names no longer listed (a name now documented elsewhere)
    listed = {f"{p[:-4]}.{ln.strip()}.rst" for p, text in pages.items()
              for ln in text.splitlines() if ln.startswith("   ") and not ln.strip().startswith(":")}
    for stale in (API / "generated").glob("*.rst"):
        if stale.name not in listed:
            stale.unlink()
    for fname, text in pages.items():
        _write_if_changed(API / fname, text)


def _write_if_changed(path: Path, text: str) -> None:
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def write_cli_help() -> None:
    """``envfit CMD --help`` of every command, as the CLI prints it (80 columns; in this process:
    one interpreter start instead of one per command)."""
    from envfit.cli import main

    GENERATED.mkdir(exist_ok=True)
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "80"
    try:
        for cmd in HELP_COMMANDS:
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                rc = main([*cmd.split(), "--help"])
            if rc != 0 or not buf.getvalue().startswith("usage: envfit"):
                raise RuntimeError(f"envfit {cmd} --help: exit {rc}, printed {buf.getvalue()[:200]!r}")
            _write_if_changed(GENERATED / f"help_{cmd.replace(' ', '_')}.txt", buf.getvalue())
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns


write_api_pages()
write_cli_help()

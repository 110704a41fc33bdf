"""The import-layer contract of envfit, checked on the source (every import statement, also
the ones inside functions), and the one-import-name install.

Layers, lowest first; a module may import its own sub-package and any lower layer, never a
higher one nor another sub-package of its own layer (one pipeline leaning on another)::

    theory
    defaults                      (the module envfit/defaults.py: default numbers, vocabularies)
    data_gen                      (synthetic maps: theory only)
    base                          (errors, checks, atomic writes, store, memory guard, progress)
    maps, plots                   (maps: also bright-source detection and the preview)
    sobolev, shading              (the Sobolev kernel; ground truth, the paper's estimators)
    sampling                      (how a renderer draws: map sampler, MIS, sources, rules)
    renderers                     (one folder per renderer: its technique, samplers, harness)
    measure                       (adaptive RMSE, axis proposal, renderer rules' measurement)
    fit
    predict                       (named predictors: use fitted s and σ̂; renderer/ sub-package)
    sh, validate, advisor,        (sh: SH coefficients, formats, ringing, the sh report)
    frame                         (a user's frame, read from the renderer's scene file)
    batch
    cli

A sub-package's own sub-packages (``predict/renderer``) count as the sub-package; the one
layered top-level module, ``envfit/defaults.py``, counts as a package of its own (it imports
theory only, so every sub-package may import it; theory never imports envfit).

``envfit/__init__.py`` only re-exports names lazily and is not part of any layer.

No module imports another package's private module (``from envfit.maps._io import …``): a
package gives what others use from its ``__init__`` (public names in ``__all__``, names
shared inside envfit in ``_SHARED``), so a package's modules can be rearranged without
touching its users.

Renderers are plug-ins (issue 39): predict, advisor, validate, cli and batch never import a
renderer's folder nor branch on a renderer's name, and predict and validate do not name one at
all, docstrings included (but an example's look-up by name, ``get_renderer("mitsuba3")``).
"""
from __future__ import annotations

import ast
import importlib.metadata
import re
from pathlib import Path

import pytest

import envfit


LAYERS = [("theory",), ("defaults",), ("data_gen",), ("base",), ("maps", "plots"),
          ("sobolev", "shading"),
          ("sampling",), ("renderers",), ("measure",), ("fit",), ("predict",), ("sh", "validate", "advisor", "frame"),
          ("batch",), ("cli",)]
RANK = {pkg: i for i, group in enumerate(LAYERS) for pkg in group}


def _package_dirs() -> dict[str, Path]:
    import envfit.data_gen
    import envfit.theory
    dirs = {p.name: p for p in Path(envfit.__file__).parent.iterdir()
            if p.is_dir() and (p / "__init__.py").exists()}
    dirs["theory"] = Path(envfit.theory.__file__).parent
    dirs["data_gen"] = Path(envfit.data_gen.__file__).parent
    dirs["defaults"] = Path(envfit.__file__).parent / "defaults.py"     # a module, not a folder
    return dirs


def _imports(path: Path, package: str) -> set[str]:
    """envfit sub-packages imported by the module at ``path`` (of sub-package ``package``)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        names = []
        if isinstance(node, ast.ImportFrom):
            if node.level == 1:
                names = [package]
            elif node.level > 1:
                names = [(node.module or "").split(".")[0] or "?"]
            elif node.module:
                names = [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        for name in names:
            parts = name.split(".")
            if node.__class__ is ast.ImportFrom and node.level > 1:
                found.add(parts[0])
            elif parts[0] == "envfit" and len(parts) > 1:
                found.add(parts[1])
            elif parts[0] == "envfit" and isinstance(node, ast.ImportFrom):
                found.update(a.name for a in node.names if a.name in RANK)
    return found


def _violations() -> list[str]:
    bad = []
    for pkg, folder in _package_dirs().items():
        assert pkg in RANK, f"envfit.{pkg} is in no layer: add it to LAYERS and docs/architecture.md"
        for path in [folder] if folder.is_file() else sorted(folder.rglob("*.py")):
            for dep in sorted(_imports(path, pkg) - {pkg}):
                if dep not in RANK:
                    continue                       # __version__, lazy names of envfit/__init__
                if RANK[dep] > RANK[pkg]:
                    bad.append(f"{path.name} (envfit.{pkg}) imports the higher layer envfit.{dep}")
                elif RANK[dep] == RANK[pkg]:
                    bad.append(f"{path.name} (envfit.{pkg}) imports its sibling envfit.{dep}")
    return bad


def test_import_layers():
    assert _violations() == []


def test_the_checker_sees_a_violation(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def g():\n    from envfit.cli._common import say\n    from ..advisor import advise\n")
    assert _imports(f, "fit") == {"cli", "advisor"}


def test_defaults_sits_below_every_sub_package(tmp_path):
    """envfit.defaults is importable by every sub-package (data_gen up) and imports only
    theory; theory importing it is a violation."""
    assert all(RANK["defaults"] < RANK[p] for p in RANK if p not in ("theory", "defaults"))
    assert _imports(Path(envfit.__file__).parent / "defaults.py", "defaults") <= {"theory"}
    f = tmp_path / "m.py"
    f.write_text("from envfit.defaults import DEFAULT_SHININESS\n")
    assert _imports(f, "theory") == {"defaults"} and RANK["defaults"] > RANK["theory"]


def test_one_top_level_package_installed():
    dist = importlib.metadata.distribution("envfit")
    top = dist.read_text("top_level.txt")
    assert top is not None, "the installed metadata names no top-level package"
    assert top.split() == ["envfit"]
    with pytest.raises(ModuleNotFoundError):
        __import__("theory")
    with pytest.raises(ModuleNotFoundError):
        __import__("data_gen")


def test_pyproject_lists_every_sub_package():
    """setuptools installs exactly the packages pyproject.toml lists (the package-dir mapping
    of theory/ and data_gen/ rules out automatic discovery): a sub-package missing there
    works in an editable install and is absent from a real one."""
    tomllib = pytest.importorskip("tomllib")
    root = Path(__file__).resolve().parents[1]
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"envfit"} | {"envfit." + ".".join(p.parent.relative_to(root / "envfit").parts)
                          for p in (root / "envfit").rglob("__init__.py") if p.parent != root / "envfit"}
    found |= {"envfit.theory", "envfit.data_gen"}
    assert listed == found


# ---- size rules (issues 23, 39): a concept stays whole; what grows past a screen is reported ----
#: hard limits: lines per module (one whole technique, as Mitsuba's envmap.cpp's 611 lines),
#: per function; parameters of a private / public function (``self``/``cls`` not counted;
#: beyond them an options dataclass)
MAX_MODULE_LINES, MAX_FUNCTION_LINES, MAX_PRIVATE_PARAMS, MAX_PUBLIC_PARAMS = 1000, 100, 8, 12
#: the lines past which a module or a function is *reported* (test_size_report: a note of
#: what grew, not a wall to cut at: split by concept, never to meet a number)
REPORT_MODULE_LINES, REPORT_FUNCTION_LINES = 500, 60


def size_violations(path: Path, text: str | None = None, module_lines: int = MAX_MODULE_LINES,
                    function_lines: int = MAX_FUNCTION_LINES) -> list[str]:
    """The size rules ``path`` breaks, one line each (with the report's lines: what it
    reports)."""
    text = path.read_text() if text is None else text
    out = []
    lines = text.count("\n")
    if lines > module_lines:
        out.append(f"{path.name}: {lines} lines > {module_lines}")
    for node in ast.walk(ast.parse(text)):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        length = node.end_lineno - node.lineno + 1
        if length > function_lines:
            out.append(f"{path.name}:{node.lineno} {node.name}: {length} lines")
        a = node.args
        n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
        n -= bool(a.args and a.args[0].arg in ("self", "cls"))
        private = node.name.startswith("_") and not node.name.endswith("__")
        limit = MAX_PRIVATE_PARAMS if private else MAX_PUBLIC_PARAMS
        if n > limit:
            out.append(f"{path.name}:{node.lineno} {node.name}: {n} parameters > {limit}")
    return out


def _product_sources() -> list[Path]:
    root = Path(__file__).resolve().parents[1]
    return sorted(p for top in ("envfit", "theory", "data_gen") for p in (root / top).rglob("*.py"))


def test_size_rules():
    bad = [v for p in _product_sources() for v in size_violations(p)]
    assert bad == [], "\n".join(bad)


def test_size_report():
    """What grew past a screen (a module over 500 lines, a function over 60), reported as a
    warning in the suite's summary: read it, and split a module only where it holds two
    concepts."""
    import warnings
    root = Path(__file__).resolve().parents[1]
    grown = [str(p.relative_to(root)) + v[len(p.name):] for p in _product_sources()
             for v in size_violations(p, None, REPORT_MODULE_LINES, REPORT_FUNCTION_LINES)
             if "parameters" not in v]
    if grown:
        warnings.warn("past a screen (a report, not a rule):\n" + "\n".join(grown),
                      stacklevel=1)


def test_the_size_checker_sees_each_rule(tmp_path):
    long_fn = "def f():\n" + "    x = 1\n" * 101
    many = "def _g(a, b, c, d, e, f, g, h, i):\n    pass\n"
    public = "def g(" + ", ".join(f"a{i}" for i in range(13)) + "):\n    pass\n"
    ok = "class C:\n    def m(self, a, b, c, d, e, f, g, h):\n        pass\n"
    f = tmp_path / "m.py"
    got = size_violations(f, long_fn + many + public + ok + "\n" * 893)
    assert [g.split(": ")[-1] for g in got] == ["1002 lines > 1000", "102 lines",
                                                "9 parameters > 8", "13 parameters > 12"]
    got = size_violations(f, long_fn + "\n" * 400, REPORT_MODULE_LINES, REPORT_FUNCTION_LINES)
    assert [g.split(": ")[-1] for g in got] == ["502 lines > 500", "102 lines"]


# ---- renderers are plug-ins (issue 39): one folder each, no names outside them ----
#: the packages that must not know any renderer by name (they go through the registry)
RENDERER_FREE = ("predict", "advisor", "validate", "cli", "batch", "shading")


def renderer_name_uses(path: Path, text: str | None = None, names=None) -> list[str]:
    """Where the module at ``path`` imports a renderer's folder (``envfit.renderers.<name>``)
    or compares a value with a renderer's name (``x == "cycles"``, ``x in ("mitsuba3", …)``,
    a dict keyed by renderer names): one line each. Docstrings and comments citing a
    renderer's source are not uses."""
    from envfit.renderers import RENDERERS
    names = set(RENDERERS) if names is None else set(names)
    tree = ast.parse(path.read_text() if text is None else text)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            parts = node.module.split(".")
            if parts[:2] == ["envfit", "renderers"] and len(parts) > 2 and parts[2] in names:
                out.append(f"{path.name}:{node.lineno} imports {node.module}")
        elif isinstance(node, ast.Compare):
            consts = [c for c in [node.left, *node.comparators] if isinstance(c, ast.Constant)]
            for c in [*node.comparators]:
                if isinstance(c, (ast.Tuple, ast.List, ast.Set)):
                    consts += [e for e in c.elts if isinstance(e, ast.Constant)]
            if any(c.value in names for c in consts):
                out.append(f"{path.name}:{node.lineno} compares with a renderer's name")
        elif isinstance(node, ast.Dict):
            if any(isinstance(k, ast.Constant) and k.value in names for k in node.keys):
                out.append(f"{path.name}:{node.lineno} a table keyed by renderer names")
    return out


def test_no_renderer_is_named_outside_its_folder():
    """predict, advisor, validate, cli and batch reach every renderer through the registry
    (``get_renderer(name)``, the record's fields): none imports a renderer's folder or
    branches on a renderer's name."""
    root = Path(envfit.__file__).parent
    bad = [v for pkg in RENDERER_FREE for p in sorted((root / pkg).rglob("*.py"))
           for v in renderer_name_uses(p)]
    assert bad == [], "\n".join(bad)


def test_the_renderer_name_checker_sees_each_use(tmp_path):
    f = tmp_path / "m.py"
    src = ('from envfit.renderers.cycles._render import version\n'
           'def f(r):\n    """mitsuba3 cited in a docstring is fine."""\n'
           '    if r == "cycles" or r in ("pbrt4",):\n        return {"mitsuba3": 1}\n'
           '    return get_renderer(r).display\n')
    got = renderer_name_uses(f, src)
    assert [g.split(" ", 1)[1] for g in got] == [
        "imports envfit.renderers.cycles._render", "compares with a renderer's name",
        "compares with a renderer's name", "a table keyed by renderer names"]


# ---- predict and validate name no renderer at all, docstrings included (issue 39) ----
#: the packages whose source never names a renderer, in code, comments or docstrings: what
#: envfit assumes a renderer does (its technique, its samplers' variants, its microfacet
#: conventions, the file:function citations of its source) is in the renderer's folder alone;
#: ``shading`` holds the microfacet techniques by what they are, each renderer's choice of
#: them is its folder's ``_bsdf``
RENDERER_SILENT = ("predict", "validate", "shading")


def _renderer_words(names=None) -> list[str]:
    """The stems a renderer is named by (``mitsuba3`` → ``mitsuba``, ``pbrt4`` → ``pbrt``,
    ``cycles``): every registry key but envfit's own, its trailing digits dropped."""
    from envfit.renderers import RENDERERS
    keys = set(RENDERERS) if names is None else set(names)
    return sorted({k.rstrip("0123456789") for k in keys if k != "envfit"})


def renderer_mentions(path: Path, text: str | None = None, names=None) -> list[str]:
    """Every line of the module at ``path`` that names a renderer (case-insensitive: code,
    comment or docstring), one line each. The one allowance (each a look-up by name): a
    registry key quoted as a call's argument on a doctest line (``>>> get_renderer("mitsuba3")``,
    ``>>> RenderValidationOptions("mitsuba3", …)``) — an example must pick some renderer."""
    from envfit.renderers import RENDERERS
    keys = set(RENDERERS) if names is None else set(names)
    words = re.compile("|".join(map(re.escape, _renderer_words(keys))), re.I)
    lookup = re.compile(r"""([(,]\s*)(["'])(%s)\2(?=\s*[,)])"""
                        % "|".join(map(re.escape, sorted(keys))))
    out = []
    src = path.read_text() if text is None else text
    for i, line in enumerate(src.splitlines(), 1):
        scan = line
        if re.match(r"\s*(>>>|\.\.\.) ", line):
            scan = lookup.sub(r"\1", line)
        if words.search(scan):
            out.append(f"{path.name}:{i} names a renderer: {line.strip()}")
    return out


def test_predict_and_validate_name_no_renderer():
    """``grep -ril "mitsuba\\|cycles\\|pbrt" envfit/{predict,validate}`` finds only examples'
    look-ups by name: a renderer's variants reach predict through its record (a sampler's
    options, its microfacet conventions), never by its name."""
    root = Path(envfit.__file__).parent
    bad = [v for pkg in RENDERER_SILENT for p in sorted((root / pkg).rglob("*.py"))
           for v in renderer_mentions(p)]
    assert bad == [], "\n".join(bad)


def test_the_renderer_mention_checker_sees_each_name(tmp_path):
    f = tmp_path / "m.py"
    src = ('"""Kensler\'s hash, as Mitsuba 3 draws it (``random.h``)."""\n'
           "X = 1  # pbrt-v4's strata\n"
           "def f(r):\n"
           '    """\n    >>> get_renderer("mitsuba3").sampler("ldsampler").spp(4)\n'
           '    4\n    >>> Options("cycles", brdf="ggx").brdf\n    \'ggx\'\n'
           '    >>> r == "cycles"\n    False\n    """\n'
           '    return {"permutations": "mitsuba"}\n')
    got = [g.split(" ", 1)[0] for g in renderer_mentions(f, src)]
    assert got == ["m.py:1", "m.py:2", "m.py:9", "m.py:12"]
    assert renderer_mentions(f, "def f():\n    return get_renderer(name).display\n") == []
    assert _renderer_words() == ["cycles", "mitsuba", "pbrt"]


def _private_imports(path: Path, package: str) -> list[str]:
    """``from envfit.X._y import …`` (or ``from envfit.X import _y``) lines of the module at
    ``path`` (of top-level package ``package``) where X is another package."""
    bad = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if not isinstance(node, ast.ImportFrom) or node.level or not node.module:
            continue
        parts = node.module.split(".")
        if parts[0] != "envfit" or len(parts) < 2 or parts[1] == package:
            continue
        if any(p.startswith("_") for p in parts[2:]) or \
                any(a.name.startswith("_") for a in node.names):
            bad.append(f"{path}:{node.lineno}: from {node.module} import "
                       f"{', '.join(a.name for a in node.names)}")
    return bad


def test_no_private_module_is_imported_across_packages():
    """Every name another package uses comes from the package's ``__init__`` (issue 39)."""
    bad = []
    for pkg, folder in _package_dirs().items():
        files = [folder] if folder.is_file() else sorted(folder.rglob("*.py"))
        for f in files:
            bad += _private_imports(f, pkg)
    assert not bad, "private modules imported across packages:\n" + "\n".join(bad)


def test_the_private_import_checker_sees_each_form(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from envfit.maps._io import load_envmap\n"
                 "def g():\n    from envfit.theory import _claims\n"
                 "from envfit.maps import load_envmap\nfrom envfit.fit._search import x\n")
    bad = _private_imports(f, "fit")
    assert [b.split(":")[1] for b in bad] == ["1", "3"]

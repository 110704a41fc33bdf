"""envfit.defaults: every default number and vocabulary defined once, imported, never re-typed.

An AST scan of envfit/, theory/ and data_gen/: no tuple or list literal equal to a registered
vocabulary (the point sets of theory.pointsets.POINTSETS, the BRDF names, the weightings)
outside its defining module, and the default glossy shininess 30 typed only in
envfit/defaults.py and theory (theory never imports envfit). Also: the commands' defaults
are the module's, and the report's Spearman ρ (scipy) against an exact rational one."""
from __future__ import annotations

import ast
from fractions import Fraction
from pathlib import Path

import pytest

import envfit
import envfit.data_gen
import envfit.theory
from envfit import defaults as D
from envfit.theory._pointsets import POINTSETS

ENVFIT = Path(envfit.__file__).parent
THEORY = Path(envfit.theory.__file__).parent
DATA_GEN = Path(envfit.data_gen.__file__).parent

#: vocabulary -> the module that defines it (the one place its literal may appear)
VOCABULARIES = {
    "point sets": (tuple(POINTSETS), THEORY / "_pointsets.py"),
    "BRDFs": (D.BRDFS, THEORY / "_brdf.py"),
    "weightings": (D.WEIGHTINGS, THEORY / "_weights.py"),
    "default point sets": (D.DEFAULT_POINTSETS, ENVFIT / "defaults.py"),
    "advise's renderer point sets": (D.ADVISE_RENDERER_POINTSETS, ENVFIT / "defaults.py"),
    "validate's renderer point sets": (D.VALIDATE_RENDERER_POINTSETS, ENVFIT / "defaults.py"),
    "up axes": (D.UPS, ENVFIT / "defaults.py"),
    "solvers": (D.SOLVERS, ENVFIT / "defaults.py"),
    "fit methods": (D.FIT_METHODS, ENVFIT / "defaults.py"),
    "executors": (D.EXECUTORS, ENVFIT / "defaults.py"),
    "predictor choices": (D.PREDICTOR_CHOICES, ENVFIT / "defaults.py"),
}
#: literals that are another vocabulary's permutation on purpose: (file, assigned name) -> why
ALLOWED = {(THEORY / "_figures.py", "POINTSET_ORDER"): "the paper's figure order (Sec. 7.1)"}


def _sources() -> list[Path]:
    return sorted(p for d in (ENVFIT, THEORY, DATA_GEN) for p in d.rglob("*.py"))


def _string_tuples(tree: ast.AST):
    """(lineno, values, assigned name or None) of every tuple/list literal of ≥ 2 strings."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                if isinstance(t, ast.Name) and isinstance(node.value, (ast.Tuple, ast.List)):
                    names[id(node.value)] = t.id
    for node in ast.walk(tree):
        if isinstance(node, (ast.Tuple, ast.List)) and len(node.elts) >= 2 and all(
                isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts):
            yield node.lineno, tuple(e.value for e in node.elts), names.get(id(node))


def retyped_vocabularies(path: Path, text: str | None = None) -> list[str]:
    """Where the module at ``path`` re-types a registered vocabulary (same names, any order)."""
    tree = ast.parse(path.read_text() if text is None else text)
    bad = []
    for lineno, values, name in _string_tuples(tree):
        for what, (vocab, home) in VOCABULARIES.items():
            if sorted(values) == sorted(vocab) and path != home and (path, name) not in ALLOWED:
                bad.append(f"{path.name}:{lineno} re-types the {what} {values}")
    return bad


def _is_30(node) -> bool:
    return (isinstance(node, ast.Constant) and type(node.value) in (int, float)
            and node.value == 30)


def typed_shininess(path: Path, text: str | None = None) -> list[str]:
    """Where the module at ``path`` types the number 30 as a shininess: a default of an
    argument or field named ``shininess``, a ``shininess=30`` keyword, or a 30 on a line that
    names the shininess (``.get("shininess", 30)``, ``opts.shininess or 30.0``)."""
    text = path.read_text() if text is None else text
    tree, lines = ast.parse(text), text.splitlines()
    bad = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.arguments):
            args = node.posonlyargs + node.args
            pairs = list(zip(args[len(args) - len(node.defaults):], node.defaults))
            pairs += [(a, d) for a, d in zip(node.kwonlyargs, node.kw_defaults) if d is not None]
            bad.update(d.lineno for a, d in pairs if a.arg == "shininess" and _is_30(d))
        elif isinstance(node, ast.keyword) and node.arg == "shininess" and _is_30(node.value):
            bad.add(node.value.lineno)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) \
                and node.target.id == "shininess" and _is_30(node.value):
            bad.add(node.lineno)
        elif _is_30(node) and "shin" in lines[node.lineno - 1].lower():
            bad.add(node.lineno)
    return [f"{path.name}:{n} types the shininess 30" for n in sorted(bad)]


def test_no_module_retypes_a_vocabulary():
    bad = [b for p in _sources() for b in retyped_vocabularies(p)]
    assert bad == []


def test_the_default_shininess_is_typed_only_in_defaults_and_theory():
    bad = [b for p in _sources() if p != ENVFIT / "defaults.py" and THEORY not in p.parents
           for b in typed_shininess(p)]
    assert bad == []
    # theory types it once, beside the lobes, and the rest of theory imports it
    in_theory = {p.name: typed_shininess(p) for p in THEORY.rglob("*.py") if typed_shininess(p)}
    assert list(in_theory) == ["_brdf.py"] and len(in_theory["_brdf.py"]) == 1


def test_the_scans_see_a_violation(tmp_path):
    f = tmp_path / "m.py"
    src = ('SETS = ["jitter", "random", "bnot", "lp", "sobol", "sf"]\n'
           'def g(x, shininess: float = 30.0, *, n=1):\n'
           '    return h(shininess=30, lobes=("diffuse", "glossy"), w=("osw", "equal"))\n'
           'n = cfg.get("shininess", 30)\nm = 30\n')
    assert len(retyped_vocabularies(f, src)) == 3
    assert typed_shininess(f, src) == ["m.py:2 types the shininess 30",
                                       "m.py:3 types the shininess 30",
                                       "m.py:4 types the shininess 30"]


def test_the_commands_take_their_defaults_from_the_module():
    from envfit.advisor._options import AdviseOptions
    from envfit.theory._brdf import Glossy
    from envfit.theory._table1 import PAPER_SHININESS
    from envfit.validate._config import ValidateConfig, quick_config
    from envfit.validate._renderer import RendererValidationConfig, renderer_quick_config
    assert D.DEFAULT_SHININESS == PAPER_SHININESS == Glossy().shininess == 30.0
    assert D.ALL_POINTSETS == ("sf", "sobol", "lp", "bnot", "random", "jitter")
    v, q = ValidateConfig(), quick_config()
    assert (tuple(v.pointsets), tuple(v.brdfs), v.shininess) == (D.ALL_POINTSETS, D.BRDFS, 30.0)
    assert tuple(v.n_values) == D.VALIDATE_N == tuple(2 ** k for k in range(4, 13))
    assert tuple(q.n_values) == D.QUICK_N and tuple(q.pointsets) == D.DEFAULT_POINTSETS
    r, rq = RendererValidationConfig(), renderer_quick_config()
    assert (r.grid, r.spectrum_axes, tuple(r.pointsets)) == (512, 256, ("random", "sobol", "sf"))
    assert (rq.grid, rq.spectrum_axes) == (D.QUICK_RENDERER_GRID, D.QUICK_SPECTRUM_AXES)
    assert (rq.grid, rq.spectrum_axes) == (256, 32)
    a = AdviseOptions()
    assert (a.renderer_grid, a.renderer_spectrum_axes) == (512, 32)
    assert AdviseOptions(brdf="glossy").shininess == 30.0
    assert tuple(a.pointsets) == ("sf", "sobol", "lp", "random", "jitter")
    assert (a.renderer_axes_start, a.renderer_max_axes) == (rq.axes_start, rq.max_axes) == (250, 4000)


def test_the_registries_are_the_modules_own():
    """The modules that check a name hold the very tuple of envfit.defaults."""
    from envfit.advisor import _options as options
    from envfit.base import _resources as resources
    from envfit.batch import _executor as executor
    from envfit.fit import _smoothness as smoothness
    from envfit.maps import _latlong as latlong
    from envfit.theory import _figures as figures
    assert latlong.UPS is D.UPS and resources.SOLVERS is D.SOLVERS
    assert smoothness.METHODS is D.FIT_METHODS and executor.EXECUTORS is D.EXECUTORS
    assert options.PREDICTOR_CHOICES is D.PREDICTOR_CHOICES and options.BRDFS is D.BRDFS
    assert figures.BRDFS is D.BRDFS and figures.WEIGHTINGS is D.WEIGHTINGS


def _exact_spearman(x, y) -> Fraction:
    """sign(ρ)·ρ² in exact rationals, from average ranks counted by brute force."""
    def ranks(v):
        return [Fraction(sum(w < a for w in v) * 2 + sum(w == a for w in v) + 1, 2) for a in v]
    rx, ry = ranks(x), ranks(y)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx, syy = sum((a - mx) ** 2 for a in rx), sum((b - my) ** 2 for b in ry)
    return (1 if sxy >= 0 else -1) * sxy * sxy / (sxx * syy)


@pytest.mark.parametrize("y", [[0.1, 0.5, 0.4], [1.0, 3.0, 2.0, 5.0, 4.0], [2, 2, 1, 3, 3, 0],
                               [5, 4, 3, 2, 1], [0.3, 0.3, 0.9, 0.1, 0.8, 0.7, 0.2]])
def test_spearman_is_scipys_and_exact(y):
    from envfit.validate._report_predicates import spearman
    rho = spearman(list(range(len(y))), y)
    signed_sq = (1 if rho >= 0 else -1) * rho * rho
    assert signed_sq == pytest.approx(float(_exact_spearman(list(range(len(y))), y)), abs=1e-14)


def test_spearman_constant_and_an_exact_threshold():
    from envfit.validate._report_predicates import RISE_MIN_SPEARMAN, rises_with_degree, spearman
    assert spearman([0, 1, 2], [1.0, 1.0, 1.0]) == 0.0
    ratios = [1.0, 3.0, 2.0, 5.0, 4.0]           # ranks 0 2 1 4 3: ρ = 1 − 6·4/120 = 0.8
    assert _exact_spearman(list(range(5)), ratios) == Fraction(16, 25)
    assert RISE_MIN_SPEARMAN == 0.8 and rises_with_degree(ratios)      # ρ ≥ 0.8: rising
    below = [1.0, 4.0, 2.0, 3.0, 5.0]            # ranks 0 3 1 2 4: ρ = 1 − 6·6/120 = 0.7
    assert _exact_spearman(list(range(5)), below) == Fraction(49, 100)
    assert not rises_with_degree(below)         # last/first = 5, but ρ < 0.8

"""A sweep over ``envfit advise``'s options (issue 38), walking the parser's actions, with and
without ``--renderer``: every numeric option is a :class:`~envfit.cli._ranges.Ranged` (the one
range type of every command, ``--workers`` and _common's ``--seed``/``--max-height`` too), its
``--help`` states its range in the words ``str(range)``, and a value just outside it is one line
naming that flag in the same words, exit 2, before the map is read (the map given does
not exist, so a check after loading it would name the map instead); every list option refuses
a repeat; every list of names in ``--help`` is its registry's; ``--help`` has no ``%%``; the
roughness range is stated and checked in each renderer's own units.

The ends themselves are checked against the models' own checks (AdviseOptions,
RendererModelOptions), a second path, so the parser's ranges cannot drift from them.
"""
from __future__ import annotations

import re
import time

import pytest

from envfit.cli import build_parser, main
from envfit.cli._common import str_list
from envfit.cli._parse import finite_float
from envfit.cli._ranges import Ranged, distinct_names, ranged_actions


def _parser():
    return build_parser("advise")._subparsers._group_actions[0].choices["advise"]


def _help() -> str:
    return " ".join(_parser().format_help().split())


def _flag(a) -> str:
    return next(o for o in a.option_strings if o.startswith("--"))


def _range(a) -> Ranged:
    return a.type


_PARSER = _parser()
_ACTIONS = [a for a in _PARSER._actions if a.option_strings]
_NUMERIC = ranged_actions(_PARSER)
_LISTS = [a for a in _ACTIONS if a.type in (distinct_names, str_list)
          or (isinstance(a.type, Ranged) and a.type.many)]


def _one_line(capsys, argv, tmp_path):
    t0 = time.perf_counter()
    rc = main(["advise", str(tmp_path / "absent.exr"), "--no-cache", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, (argv, err)
    assert err[0].startswith("envfit advise: error:") and "absent.exr" not in err[0]
    assert time.perf_counter() - t0 < 10.0
    return err[0]


def test_every_typed_option_has_a_range_or_is_a_name_list():
    """No numeric option escapes the sweep: each typed option is a Ranged (_common's number
    types included: state_common_ranges gives them theirs), a list of names, a path,
    --roughness, or --bsdf-param (NAME=VALUE: the renderer's BSDF checks the name and the
    range, test_advise_renderer_terms' principled test)."""
    from pathlib import Path

    from envfit.cli._advise_renderer import bsdf_param
    for a in _ACTIONS:
        if a.type is None or a.type is Path or a in _NUMERIC or a in _LISTS:
            continue
        if _flag(a) == "--bsdf-param":
            assert a.type is bsdf_param
            continue
        assert _flag(a) == "--roughness" and a.type is finite_float, _flag(a)
    assert len(_NUMERIC) >= 18
    assert {"--workers", "--seed", "--max-height"} <= {_flag(a) for a in _NUMERIC}


@pytest.mark.parametrize("flag", [_flag(a) for a in _NUMERIC])
def test_numeric_help_states_the_range(flag):
    a = next(x for x in _NUMERIC if _flag(x) == flag)
    help_text = " ".join((a.help % {}).split())
    assert str(_range(a)) in help_text, (flag, help_text)


_OUTSIDE = [(_flag(a), v) for a in _NUMERIC for v in _range(a).outside()]


@pytest.mark.parametrize("renderer", [None, "mitsuba3"])
@pytest.mark.parametrize("flag, value", _OUTSIDE)
def test_outside_the_range_is_one_line_naming_the_flag(flag, value, renderer, tmp_path,
                                                       capsys):
    extra = ["--renderer", renderer] if renderer else []
    line = _one_line(capsys, [*extra, flag, value], tmp_path)
    assert f"argument {flag}: {value} is outside {_range_of(flag)} (see " in line, line


def _range_of(flag: str) -> Ranged:
    return _range(next(a for a in _NUMERIC if _flag(a) == flag))


@pytest.mark.parametrize("flag", [_flag(a) for a in _NUMERIC])
def test_the_ends_of_each_range_are_accepted(flag):
    a = next(x for x in _NUMERIC if _flag(x) == flag)
    rng = _range(a)
    for end, open_ in ((rng.lo, rng.lo_open), (rng.hi, rng.hi_open)):
        if end is not None and not open_:
            v = rng(repr(end) if isinstance(end, float) else str(end))
            assert (v[0] if rng.many else v) == end


def test_the_parser_ranges_are_the_models():
    """The ends the parser states are the ends AdviseOptions and RendererModelOptions accept
    (a second path: their own checks)."""
    from envfit.advisor._options import AdviseOptions
    from envfit.base._errors import ParameterError
    from envfit.cli._advise_renderer import _MODEL_RANGES
    from envfit.predict.renderer import RendererModelOptions
    by = {_flag(a): _range(a) for a in _NUMERIC}
    for flag, field in (("--fit-n", "fit_n"), ("--realisations", "seeds"), ("--axes", "axes"),
                        ("--renderer-grid", "renderer_grid"),
                        ("--renderer-spectrum-axes", "renderer_spectrum_axes"),
                        ("--renderer-axes-start", "renderer_axes_start")):
        r = by[flag]
        AdviseOptions(**{field: r.lo})
        with pytest.raises(ParameterError):
            AdviseOptions(**{field: r.lo - (r.multiple or 1)})
        if r.hi is not None:
            AdviseOptions(**{field: r.hi, **({"renderer_max_axes": r.hi}
                                             if field == "renderer_axes_start" else {})})
            with pytest.raises(ParameterError):
                AdviseOptions(**{field: r.hi + 1})
    for field, (lo, hi) in _MODEL_RANGES.items():
        for v in (lo, hi):
            RendererModelOptions(**{field: v, **({"pool": v} if field == "normals" else {})})
        for v in (lo - 1, hi + 1):
            with pytest.raises(ParameterError):
                RendererModelOptions(**{field: v, **({"pool": v} if field == "normals" else {})})


@pytest.mark.parametrize("renderer", [None, "mitsuba3"])
@pytest.mark.parametrize("flag", [_flag(a) for a in _LISTS])
def test_list_options_refuse_repeats(flag, renderer, tmp_path, capsys):
    a = next(x for x in _LISTS if _flag(x) == flag)
    assert a.type is not str_list, f"{flag} merges repeats silently"
    first = a.metavar.split(",")[0]
    extra = ["--renderer", renderer] if renderer else []
    for value in (f"{first},{first}", f"{first},{first.upper()}"):
        if value.endswith(first.upper()) and first.isdigit():
            continue
        line = _one_line(capsys, [*extra, flag, value], tmp_path)
        assert f"argument {flag}: " in line and ("given twice" in line or "same value" in line)


def test_repeated_strategies_and_spp_are_refused_alike(tmp_path, capsys):
    a = _one_line(capsys, ["--renderer", "mitsuba3", "--strategies", "mis,mis"], tmp_path)
    b = _one_line(capsys, ["--renderer", "mitsuba3", "--spp", "16,16"], tmp_path)
    assert "mis is given twice in 'mis,mis'" in a and "16 is given twice in '16,16'" in b


def _segment(text: str, head: str) -> list[str]:
    """The comma list after ``head`` in ``text``, up to ';' or ')' (names' '(default)' off)."""
    m = re.search(re.escape(head) + r"((?:[\w-]+(?: \(default\))?(?:, )?)+)", text)
    assert m, head
    return [x.replace(" (default)", "") for x in m.group(1).rstrip(", ").split(", ")]


def test_help_lists_are_the_registries():
    from envfit.advisor._options import BASES
    from envfit.defaults import ALL_POINTSETS, BRDFS, MICROFACET_BSDFS, WEIGHTINGS
    from envfit.sampling._rules import STRATEGIES
    from envfit.renderers import RENDERERS, STRATEGY_NAMES
    text = _help()
    assert [p.display for p in RENDERERS.values()] == ["Mitsuba 3", "pbrt-v4", "Cycles",
                                                        "envfit"]
    for name, p in RENDERERS.items():
        assert _segment(text, f"{p.display}: ") == list(p.samplers), name
        assert f"{p.default_sampler} (default)" in text
    assert "orthogonal" in _segment(text, "Mitsuba 3: ")
    assert _segment(text, "weight function: ") == list(BRDFS)
    for b in MICROFACET_BSDFS:
        assert f" {b} (" in text
    brdf = next(a for a in _ACTIONS if _flag(a) == "--brdf")
    assert tuple(brdf.choices) == tuple(BRDFS) + tuple(MICROFACET_BSDFS)
    assert _segment(text, "renderer strategies to size, among ") == list(STRATEGIES)
    assert _segment(text, "with --renderer among ") == list(STRATEGY_NAMES)
    assert _segment(text, "--pointsets sf,sobol,… point sets among ") == list(ALL_POINTSETS)
    assert _segment(text, "point sets of the renderer rules among ") == list(ALL_POINTSETS)
    assert _segment(text, "weightings among ") == list(WEIGHTINGS)
    assert _segment(text, "truncations to size among ") == list(BASES)
    assert "--renderer " + "|".join(RENDERERS) in text


def test_brdf_error_with_a_renderer_lists_every_microfacet_bsdf(tmp_path, capsys):
    from envfit.defaults import MICROFACET_BSDFS
    line = _one_line(capsys, ["--renderer", "cycles", "--brdf", "glossy"], tmp_path)
    assert all(b in line for b in MICROFACET_BSDFS), line


def test_help_has_no_doubled_percent(capsys):
    rc = main(["advise", "--help"])
    out = capsys.readouterr().out
    assert rc in (0, None) and "%%" not in out and "--renderer-normals" in out
    assert "(default: 1% of the map's mean shading value" in " ".join(out.split())
    assert "95% interval" in " ".join(out.split())          # a help's %% became one %


@pytest.mark.parametrize("renderer", ["mitsuba3", "pbrt4", "cycles"])
def test_roughness_is_stated_and_checked_in_the_renderers_units(renderer, tmp_path, capsys):
    """The help says each renderer's range in its units; the bound, typed as printed or
    rounded from the exact bound (Cycles: sqrt(0.05) = 0.2236068), is accepted, with alpha
    0.05 within rounding; 1e-4 beyond either end is one line with the help's words."""
    import math
    from envfit.advisor._renderer_options import RendererAdviseOptions
    from envfit.renderers import get_renderer
    convention = get_renderer(renderer).roughness
    words = convention.words()
    assert words in _help()
    lo, hi = convention.range()
    exact = {"mitsuba3": 0.05, "pbrt4": 0.05 ** 2, "cycles": math.sqrt(0.05)}[renderer]
    for r in (lo, hi, float(f"{exact:.7g}"), exact):
        o = RendererAdviseOptions(renderer, bsdf="ggx", roughness=r)
        assert 0.05 * (1 - 1e-5) <= o.conductor().alpha <= 1.0
    for r in (lo * (1 - 1e-4), hi * (1 + 1e-4)):
        line = _one_line(capsys, ["--renderer", renderer, "--brdf", "ggx", "--roughness",
                                  repr(r)], tmp_path)
        assert f"--roughness {r:.12g} is outside {words}" in line
        assert "is alpha =" not in line

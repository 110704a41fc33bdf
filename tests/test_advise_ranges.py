"""The advisor's option ranges (issue 22: every model's valid range stated and enforced): the
check's axes, the renderer spectra's axes and the realisations per N have an upper bound,
refused in one line (exit 2 in the CLI) before any work; the bound itself is accepted."""
from __future__ import annotations

import pytest

from envfit.advisor._options import MAX_AXES, MAX_SEEDS, MAX_SPECTRUM_AXES, AdviseOptions
from envfit.base._errors import ParameterError

CASES = [("axes", MAX_AXES, "axes (--axes) must be <= 100000"),
         ("check_hsh_axes", MAX_AXES, "check_hsh_axes must be <= 100000"),
         ("renderer_max_axes", MAX_AXES, "renderer_max_axes must be <= 100000"),
         ("renderer_spectrum_axes", MAX_SPECTRUM_AXES, "spectra's axes (--renderer-spectrum-axes) "
                                                      "must be <= 1024"),
         ("seeds", MAX_SEEDS, "seeds (--realisations) must be <= 256")]


@pytest.mark.parametrize("name, top, msg", CASES)
def test_upper_bounds_both_ways(name, top, msg):
    o = AdviseOptions(target_rmse=0.01, **{name: top})
    assert getattr(o, name) == top
    with pytest.raises(ParameterError) as e:
        AdviseOptions(target_rmse=0.01, **{name: top + 1})
    assert msg in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("argv, words", [(["--axes", "1000000000", "--check"], "2 <= M <= 100000"),
                                         (["--renderer-spectrum-axes", "100000000"],
                                          "1 <= K <= 1024"),
                                         (["--renderer-max-axes", "200000"], "2 <= M <= 100000"),
                                         (["--realisations", "100000"], "1 <= K <= 256")])
def test_cli_out_of_range_is_one_line_exit_2(argv, words, tmp_path, monkeypatch, capsys):
    from envfit.cli import main
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path))
    rc = main(["advise", "--max-height", "16", "--target-rmse", "0.01", "--quiet", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("envfit advise: error:")
    assert f"argument {argv[0]}: {argv[1]} is outside {words} (see " in err[0], err[0]
    assert _in_help(argv[0], words)


def _in_help(flag: str, words: str) -> bool:
    """The error's words are the words of ``flag``'s --help."""
    from envfit.cli import build_parser
    p = build_parser("advise")._subparsers._group_actions[0].choices["advise"]
    a = next(a for a in p._actions if flag in a.option_strings)
    return words in " ".join(a.help.split())

"""``envfit --help`` without importing the subcommands: the summary table
(:data:`envfit.cli.SUMMARIES`) against each module's own registered help, the two top-level
help texts against each other, and a fresh process that prints the help with none of the
subcommand modules (nor numba, scipy) imported."""
from __future__ import annotations

import argparse
import subprocess
import sys

from envfit import cli


def _subcommand_helps(parser: argparse.ArgumentParser) -> dict:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {a.dest: a.help for a in sub._choices_actions}


def test_summaries_are_the_modules_own_help():
    assert list(cli.SUMMARIES) == list(cli.COMMANDS)
    assert _subcommand_helps(cli.build_parser()) == cli.SUMMARIES


def test_summary_help_is_the_full_help():
    assert cli.build_parser(summary=True).format_help() == cli.build_parser().format_help()


def test_help_imports_no_subcommand_module(tmp_path):
    code = ("import sys\n"
            "from envfit.cli import main\n"
            "rc = main(['--help'])\n"
            "heavy = sorted(m for m in sys.modules if m.startswith('envfit.cli._')\n"
            "               or m in ('numba', 'scipy', 'envfit.defaults'))\n"
            "print('RC', rc, 'HEAVY', heavy)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    last = p.stdout.strip().splitlines()[-1]
    assert last == "RC 0 HEAVY []", last
    assert "advise" in p.stdout and "usage: envfit" in p.stdout


def test_a_known_command_still_loads_its_module(capsys):
    rc = cli.main(["advise", "--help"])
    out = capsys.readouterr().out
    assert rc == 0 and "--renderer" in out and "envfit.cli._advise" in sys.modules

"""The ``envfit`` command line: parse, call the Python API, print, exit codes.

Each subcommand lives in its own module ``envfit/cli/_<name>.py`` exposing
``register(subparsers)``, which adds its parser and sets ``func`` to a
``run(args, output) -> int``: ``args`` the parsed options (read, never written), ``output``
the run's :class:`~envfit.cli._output.CommandOutput` (printing, the result, the writes that
failed, the notes said before the work).
The CLI holds no logic of its own. Any :class:`envfit.base._errors.EnvfitError` (or a theory
parameter error) becomes a one-line message on stderr and exit code 2.

Reliability (one line on stderr, exit 2, never a traceback for what the user or the machine
caused):

* a bad option value, a missing or unknown argument: ``envfit CMD: error: WHAT (see
  'envfit CMD --help')``, one line (:class:`OneLineParser`), not argparse's usage block;
  ``--help`` prints the full help (exit 0);
* a subcommand module that is missing or fails to import is an error, not a silently
  absent command: ``envfit --help`` lists the commands by :data:`SUMMARIES` without importing
  their modules (0.2 s instead of ~1 s) but looks each one up, and a command whose module
  fails to import says so when it runs;
* every output (``--out``, ``--json``, synth's file, the advisor cache) is checked before any
  work (:func:`envfit.cli._common.preflight_outputs`), and none may name an input
  (:mod:`envfit.cli._overlap`);
* a write that fails after the work (disk full, EIO) does not lose the results: they are
  printed (the JSON goes to stdout if its file failed, or if ``--quiet`` printed nothing),
  then "could not write PATH: REASON (the results above are complete)", exit 2;
* any other ``OSError`` (e.g. a resumable cell that could not be saved mid-run) is one line.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import signal
import sys
import threading

from envfit import __version__
from envfit.base import os_reason
from envfit.base import EnvfitError

#: subcommands, in the order ``envfit --help`` lists them
COMMANDS = ("synth", "info", "fit", "table2", "theory", "validate", "advise", "sh", "frame")

#: each subcommand's one-line help as its module registers it, so that ``envfit --help`` (and
#: ``envfit``, ``envfit --version``, an unknown command) lists them without importing the
#: modules and what they import (numpy, scipy, numba: ~1 s); ``tests/test_cli_help.py`` checks
#: that the two agree
SUMMARIES = {
    "synth": "write a synthetic lat-long map (gp, sun-gp, constant, sky, sun, step, marker)",
    "info": "describe an environment map (size, channels, range, brightest direction)",
    "fit": "estimate the Sobolev smoothness s of a map (with a 95%% interval and sigma)",
    "table2": "reconstruct a map from N samples for a grid of s (the paper's Table 2)",
    "theory": "worst-case errors, the paper's Table 1 and Figs. 1-5",
    "validate": "check predicted quadrature / truncation errors against measured ones on a map",
    "advise": "smallest N per point set / weighting and smallest SH/HSH degree for a target "
              "error",
    "sh": "real SH coefficients for engines (irradiance, windows, ringing predictor)",
    "frame": "predict the noise of a frame from the renderer's scene file",
}


class OneLineParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose errors are one line on stderr, exit 2:
    ``envfit CMD: error: WHAT (see 'envfit CMD --help')`` instead of the usage block.

    ``add_subparsers`` makes the subcommands' parsers (and theirs: ``theory wce``) of the
    parser's own class, so every level reports this way; ``--help`` still prints the full
    help (exit 0)."""

    def error(self, message: str):
        what = " ".join(str(message).split())
        self.exit(2, f"{self.prog}: error: {what} (see '{self.prog} --help')\n")


def build_parser(only: str | None = None, *, summary: bool = False) -> argparse.ArgumentParser:
    """The argument parser; ``only`` registers just that subcommand (``main`` does so when the
    command is known, so ``envfit advise …`` does not import the modules of the others);
    ``summary``: every subcommand by its one-line help only (:data:`SUMMARIES`, no module
    imported), for ``main`` when no known command is named."""
    parser = OneLineParser(
        prog="envfit",
        description="Sobolev smoothness of environment maps, and predicted vs measured "
                    "errors of shading-integral estimators (Marques, Bouville, Bouatouch).")
    parser.add_argument("--version", action="version", version=f"envfit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        if only is not None and name != only:
            continue
        modname = f"{__name__}._{name}"
        if summary:                   # looked up, not imported: present, not yet loaded
            if importlib.util.find_spec(modname) is None:
                raise SubcommandImportError(
                    f"cannot load the '{name}' subcommand: {modname} is missing; the "
                    "installation of envfit is incomplete or broken (reinstall it)")
            sub.add_parser(name, help=SUMMARIES[name])
            continue
        try:
            module = importlib.import_module(modname)
        except Exception as exc:  # missing or broken: say so instead of dropping the command
            raise SubcommandImportError(
                f"cannot load the '{name}' subcommand: {modname} failed to import "
                f"({type(exc).__name__}: {' '.join(str(exc).split())}); the installation of "
                "envfit is incomplete or broken (reinstall it)") from exc
        module.register(sub)
    return parser


class SubcommandImportError(EnvfitError):
    """A subcommand module of :data:`COMMANDS` is missing or raises on import."""


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived (a scheduler, ``kill``, a container stop): unwound like Ctrl-C, so the
    stores' locks are released and every finished cell stays on disk."""


def _raise_terminated(signum, frame):
    raise Terminated()


def _install_sigterm_handler():
    """Turn SIGTERM into :class:`Terminated` while a command runs (main thread only, and only
    where nobody else installed a handler); returns the handler to restore, or None.

    Exit status 143 = 128 + SIGTERM, as shells, systemd and batch schedulers expect of a
    process ended by that signal (Ctrl-C: 130)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def _innermost_parser(parser: argparse.ArgumentParser,
                      args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the (sub-)subcommand ``args`` selected (``envfit theory wce``), so an
    error names it; ``parser`` itself without a command."""
    for dest in ("command", "theory_command"):
        chosen = getattr(args, dest, None)
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)
                    and a.dest == dest), None)
        if chosen is None or sub is None or chosen not in sub.choices:
            break
        parser = sub.choices[chosen]
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    first = next((a for a in argv if not a.startswith("-")), None)
    try:
        parser = build_parser(first if first in COMMANDS else None,
                              summary=first not in COMMANDS)
    except SubcommandImportError as exc:
        print(f"envfit{'' if first not in COMMANDS else ' ' + first}: error: {exc}",
              file=sys.stderr)
        return 2
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:                # named by the (sub)command they were given to
            _innermost_parser(parser, args).error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # argparse: one error line (exit 2), or --help / --version (0)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    from envfit.theory import TheoryParameterError

    from envfit.cli._common import preflight_outputs
    from envfit.cli._output import CommandOutput, command_name
    previous = _install_sigterm_handler()
    output = CommandOutput.for_args(args)   # the run's output: result, failed writes, notes
    try:
        preflight_outputs(args, output)     # before any work: an unwritable output fails now
        rc = int(args.func(args, output) or 0)
        if output.write_failures:
            return output.report_write_failures()
        return rc
    except (EnvfitError, TheoryParameterError) as exc:
        print(f"envfit {command_name(args)}: error: {' '.join(str(exc).split())}",
              file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and closed: not an error of ours
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:  # pragma: no cover
            pass
        return 0
    except Terminated:
        print(f"envfit {command_name(args)}: terminated (SIGTERM); finished results are kept",
              file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print(f"envfit {command_name(args)}: interrupted (finished results are kept)", file=sys.stderr)
        return 130
    except OSError as exc:  # a write of the pipeline itself (e.g. a resumable cell) failed
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"envfit {command_name(args)}: error: {where}{os_reason(exc)}", file=sys.stderr)
        return 2
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The ``envfit`` command line: parse, call the Python API, print, exit codes.

Each subcommand lives in its own module ``envfit/cli/<name>.py`` exposing
``register(subparsers)``, which adds its parser and sets ``func`` to a ``run(args) -> int``.
The CLI holds no logic of its own. Any :class:`envfit.errors.EnvfitError` (or a theory
parameter error) becomes a one-line message on stderr and exit code 2.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import sys

from .. import __version__
from ..errors import EnvfitError

#: subcommands, in the order ``envfit --help`` lists them
COMMANDS = ("synth", "info", "fit", "table2", "theory", "validate", "advise")


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The argument parser; ``only`` registers just that subcommand (``main`` does so when the
    command is known, so ``envfit advise …`` does not import the modules of the others)."""
    parser = argparse.ArgumentParser(
        prog="envfit",
        description="Sobolev smoothness of environment maps, and predicted vs measured "
                    "errors of shading-integral estimators (Marques, Bouville, Bouatouch).")
    parser.add_argument("--version", action="version", version=f"envfit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        if only is not None and name != only:
            continue
        modname = f"{__name__}.{name}"
        if importlib.util.find_spec(modname) is None:
            continue
        importlib.import_module(modname).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from theory.errors import TheoryParameterError

    argv = sys.argv[1:] if argv is None else list(argv)
    first = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(first if first in COMMANDS else None)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (EnvfitError, TheoryParameterError) as exc:
        print(f"envfit {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and closed: not an error of ours
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:  # pragma: no cover
            pass
        return 0
    except KeyboardInterrupt:
        print(f"envfit {args.command}: interrupted (finished results are kept)", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

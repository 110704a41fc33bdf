"""What a command run puts out besides its exit code: :class:`CommandOutput`, passed to every
subcommand's ``run(args, output)`` by ``main`` (the argparse Namespace holds the options
only).

It prints the human-readable lines (:meth:`CommandOutput.say`, silent with ``--quiet`` or
``--json -``), holds the machine-readable result (:meth:`~CommandOutput.emit_json`), records
every write that failed after the work (:meth:`~CommandOutput.guarded_write`,
:meth:`~CommandOutput.record_unwritten`: the results are still printed, then ``main`` names
the first file not written and exits 2, :meth:`~CommandOutput.report_write_failures`) and
the notes said on stderr before the work (:meth:`~CommandOutput.note`), each with a
:class:`~envfit.base._notes.NoteKind` that the command asks for by kind
(:meth:`~CommandOutput.has_note`).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from envfit.base import atomic_write_json, os_reason, to_jsonable
from envfit.base import Note, NoteKind

__all__ = ["CommandOutput", "WriteFailure", "command_name", "print_json"]


def command_name(args: argparse.Namespace) -> str:
    """``"table2"``, ``"theory figures"``: how messages name the command."""
    sub = getattr(args, "theory_command", None)
    return f"{args.command} {sub}" if sub else str(args.command)


def print_json(result: dict[str, Any]) -> None:
    """``result`` as indented JSON on stdout."""
    json.dump(to_jsonable(result), sys.stdout, indent=2)
    sys.stdout.write("\n")
    sys.stdout.flush()


@dataclass(frozen=True)
class WriteFailure:
    """A file that could not be written after the work, and why (one line)."""

    path: str
    reason: str


@dataclass
class CommandOutput:
    """The output of one command run.

    Attributes
    ----------
    command : how messages name the command (``"synth"``, ``"theory wce"``)
    json_path : ``--json`` (``-``: stdout), or None
    quiet : ``--quiet``
    result : the machine-readable result, once :meth:`emit_json` was called
    json_on_stdout : whether that JSON went to stdout (``--json -``, or its file failed)
    write_failures : the writes that failed after the work, in order
    notes : the notes said before the work (on stderr), each with its kind
    """

    command: str
    json_path: Path | None = None
    quiet: bool = False
    result: dict | None = None
    json_on_stdout: bool = False
    write_failures: list[WriteFailure] = field(default_factory=list)
    notes: list[Note] = field(default_factory=list)

    @classmethod
    def for_args(cls, args: argparse.Namespace) -> "CommandOutput":
        """The empty output of the command ``args`` selected."""
        return cls(command=command_name(args), json_path=getattr(args, "json", None),
                   quiet=bool(getattr(args, "quiet", False)))

    @property
    def json_to_stdout(self) -> bool:
        """``--json -``: stdout carries the JSON only."""
        return str(self.json_path) == "-"

    # ---------------------------------------------------------------- printing
    def say(self, *lines: str) -> None:
        """Print human-readable lines unless ``--quiet`` (or ``--json -`` owns stdout)."""
        if self.quiet or self.json_to_stdout:
            return
        for line in lines:
            print(line)

    def answer(self, *lines: str) -> None:
        """The command's answer, the lines ``--quiet`` still prints (already printed by
        :meth:`say` without it; never with ``--json -``)."""
        if self.quiet and not self.json_to_stdout:
            for line in lines:
                print(line)

    def note(self, kind: NoteKind, text: str) -> None:
        """Say ``text`` on stderr now ("envfit CMD: note: …") and record it with ``kind``."""
        self.notes.append(Note(text, kind))
        print(f"envfit {self.command}: note: {text}", file=sys.stderr)

    def has_note(self, kind: NoteKind) -> bool:
        """Whether a note of ``kind`` was said."""
        return any(n.kind is kind for n in self.notes)

    # ---------------------------------------------------------------- results and writes
    def emit_json(self, result: dict[str, Any]) -> None:
        """Hold ``result`` and write it where ``--json`` says (atomically), or to stdout for
        ``--json -``. A failed write is recorded (:meth:`guarded_write`) and the JSON goes
        to stdout instead, so the machine-readable result is not lost."""
        self.result = result
        if self.json_path is None:
            return
        if self.json_to_stdout or self.guarded_write(
                self.json_path, atomic_write_json, self.json_path, result) is None:
            print_json(result)
            self.json_on_stdout = True

    def guarded_write(self, path, write: Callable[..., Any], *a, **kw) -> Any:
        """``write(*a, **kw)`` (an atomic write or a plot save of ``path``); an ``OSError``
        (disk full, EIO, permission lost meanwhile) is recorded and gives None, so the
        command goes on printing its results."""
        try:
            return write(*a, **kw)
        except OSError as exc:
            self.record_write_failure(path, exc)
            return None

    def record_write_failure(self, path, exc: BaseException) -> None:
        """Record that ``path`` could not be written (``exc``'s reason, without a leading
        ``"PATH: "``, as an EnvMapFileError's "p: write failed: …" has)."""
        reason = os_reason(exc)
        prefix = f"{path}: "
        if reason.startswith(prefix):
            reason = reason[len(prefix):]
        self.write_failures.append(WriteFailure(str(path), reason))

    def record_unwritten(self, unwritten) -> None:
        """Record the ``(path, reason)`` pairs a pipeline could not write mid-run (its
        result's ``unwritten``)."""
        self.write_failures.extend(WriteFailure(str(p), str(r)) for p, r in unwritten or ())

    def report_write_failures(self) -> int:
        """After a run whose writes (partly) failed: make sure the result reached stdout,
        then one line on stderr naming the first file that could not be written; returns
        the exit code, 2."""
        if self.result is not None and (self.quiet or self.json_to_stdout) \
                and not self.json_on_stdout:
            print_json(self.result)             # --quiet: the results would be nowhere else
        first = self.write_failures[0]
        n = len(self.write_failures)
        more = f"; {n - 1} more file(s) not written" if n > 1 else ""
        sys.stdout.flush()
        print(f"envfit {self.command}: error: could not write {first.path}: {first.reason}"
              f"{more} (the results above are complete)", file=sys.stderr)
        return 2

"""What every library run reports, whatever it computes per map: the maps' labels and slugs,
the value scale and sampling, the shared factorisations, time, executor, notes, unwritten
cells and the files written; one summary row and one result per map. And how every library
run reads its maps and where its tasks run (:class:`LibraryOptions`).

:class:`LibraryResult` is the base of :class:`envfit.batch._library.LibraryTable2Result` (Table 2
per map) and :class:`envfit.batch._library_fit.LibraryFitResult` (s per map); both runs,
:func:`envfit.batch._library.run_table2_library` and
:func:`envfit.batch._library_fit.fit_smoothness_library`, take a :class:`LibraryOptions`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from envfit.base import ParameterError
from envfit.base import html_result
from envfit.maps import LoadOptions

__all__ = ["LibraryResult", "LibraryOptions", "distinct_labels"]


def distinct_labels(sources) -> list:
    """Give maps that share a label (``a/forest.exr`` and ``b/forest.exr`` are both
    ``forest.exr``) the shortest trailing part of their path that tells them apart
    (``a/forest.exr``, ``b/forest.exr``), so the printed table, the summary CSV/JSON and the
    plots name each map once; returns ``sources`` (their ``label`` set in place).

    >>> from envfit.maps._lazy_maps import MapSource
    >>> s = [MapSource(label="f.exr", slug="f-1", path="/x/a/f.exr"),
    ...      MapSource(label="f.exr", slug="f-2", path="/x/b/f.exr"),
    ...      MapSource(label="g.exr", slug="g", path="/x/a/g.exr")]
    >>> [m.label for m in distinct_labels(s)]
    ['a/f.exr', 'b/f.exr', 'g.exr']
    """
    import os
    groups: dict = {}
    for src in sources:
        groups.setdefault(src.label, []).append(src)
    for same in (g for g in groups.values() if len(g) > 1):
        parts = [os.path.normpath(src.path or src.label).split(os.sep) for src in same]
        tails = [src.label for src in same]         # in memory, one name: the slugs differ
        for k in range(2, max(len(p) for p in parts) + 1):
            tails = ["/".join(p[-k:]) for p in parts]
            if len(set(tails)) == len(tails):
                break
        for src, tail in zip(same, tails):
            src.label = tail if len(set(tails)) == len(tails) else f"{tail} ({src.slug})"
    return sources


@dataclass(frozen=True)
class LibraryOptions:
    """How a library run reads its maps and where its tasks run; what it computes is the
    run's own parameters.

    Attributes
    ----------
    executor : ``"local"``, ``"dask"`` or an executor object (:mod:`envfit.batch._executor`;
        an object is used as is and left open).
    workers : the size of a local process pool or dask ``LocalCluster`` (None: planned from
        the cores and the memory per task, :func:`envfit.batch._executor.plan_workers`;
        1: every task inline, in this process).
    scheduler : the address of a running dask scheduler (``tcp://HOST:PORT``), with
        ``executor="dask"``.
    load_options : how files and folders of the library are read
        (:class:`envfit.maps._lazy_maps.LoadOptions`; None: as they are).
    quiet : no progress bars.

    >>> LibraryOptions(workers=1)
    LibraryOptions(executor='local', workers=1, scheduler=None, load_options=None, quiet=True)
    """

    executor: Any = "local"
    workers: int | None = None
    scheduler: str | None = None
    load_options: LoadOptions | None = None
    quiet: bool = True

    @staticmethod
    def of(options: "LibraryOptions | None") -> "LibraryOptions":
        """``options``, or the defaults for None; anything else is refused (ParameterError)."""
        if options is None:
            return LibraryOptions()
        if not isinstance(options, LibraryOptions):
            raise ParameterError(f"options must be a LibraryOptions, got "
                                 f"{type(options).__name__}")
        return options

    def make_executor(self, *, max_useful: int, bytes_per_task: int) -> tuple[Any, list[str]]:
        """The executor and its notes (:func:`envfit.batch._executor.make_executor`), the
        local pool sized for ``max_useful`` tasks of ``bytes_per_task`` each."""
        from envfit.batch._executor import make_executor
        return make_executor(self.executor, workers=self.workers, scheduler=self.scheduler,
                             max_useful=max_useful, bytes_per_task=bytes_per_task)

    def close(self, ex) -> None:
        """Close ``ex`` unless it is the executor object given in :attr:`executor`."""
        if ex is not None and ex is not self.executor:
            ex.close()


@dataclass(kw_only=True)
class LibraryResult:
    """The common part of a library run's result (module docstring).

    Subclasses hold the per-map results and name them in :meth:`per_map`, add their own
    fields to :meth:`to_dict` by :meth:`_header`, and define :meth:`summary_rows`.
    """
    #: the maps' display names and folder names under ``out``, in input order
    labels: list[str]
    slugs: list[str]
    scale: str
    pointset: str
    seed: int
    #: Cholesky factorisations run (each shared by every map that needed it)
    factorizations: int = 0
    seconds: float = 0.0
    #: :meth:`envfit.batch._executor.Executor.describe` of the executor used ("" if none)
    executor: str = ""
    notes: list[str] = field(default_factory=list)
    #: ``(path, reason)`` of cells that could not be written (kept in memory, reported)
    unwritten: list[tuple[str, str]] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)

    def per_map(self) -> list:
        """The per-map results, in the order of :attr:`slugs` (each with ``to_dict()``)."""
        raise NotImplementedError

    def summary_rows(self) -> list[dict]:
        """One row per map (the library's summary CSV)."""
        raise NotImplementedError

    def _header(self) -> dict:
        """The subclass's own fields of :meth:`to_dict`, after scale, pointset and seed."""
        return {}

    def _map_dict(self, label: str, result) -> dict:
        """One map's entry of ``to_dict()["maps"]``."""
        return result.to_dict()

    def _repr_html_(self) -> str:
        """Jupyter: the run's fields and the summary, one row per map (:meth:`summary_rows`)."""
        rows = self.summary_rows()
        header = list(rows[0]) if rows else []
        return html_result(f"{type(self).__name__}: {len(self.labels)} maps", [
            ("scale, point set, seed", (self.scale, self.pointset, self.seed)),
            ("factorisations", self.factorizations), ("seconds", self.seconds),
            *(("note", n) for n in self.notes)], (header, [list(r.values()) for r in rows]))

    def to_dict(self) -> dict:
        """Everything, JSON-ready: the run's fields, ``summary`` rows, ``maps`` by slug."""
        return {"scale": self.scale, "pointset": self.pointset, "seed": self.seed,
                **self._header(), "factorizations": self.factorizations,
                "seconds": self.seconds, "executor": self.executor, "notes": self.notes,
                "summary": self.summary_rows(),
                "maps": {slug: self._map_dict(label, r)
                         for slug, label, r in zip(self.slugs, self.labels, self.per_map())},
                "files": self.files}

"""What every library run reports, whatever it computes per map: the maps' labels and slugs,
the value scale and sampling, the shared factorisations, time, executor, notes, unwritten
cells and the files written; one summary row and one result per map.

:class:`LibraryResult` is the base of :class:`envfit.batch._library.LibraryTable2Result` (Table 2
per map) and :class:`envfit.batch._library_fit.LibraryFitResult` (s per map).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from envfit.base._html import html_result

__all__ = ["LibraryResult"]


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

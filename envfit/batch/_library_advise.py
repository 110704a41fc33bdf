r"""A library of maps advised in a renderer's terms: ``envfit advise DIR|GLOB|FILE…
--renderer NAME`` — one row per map (the spp of every strategy, the recommendation and its
predicted RMSE) and the spp that meets the target on 50, 90 and 100 % of the maps.

Each map is one task (:func:`_advise_map`: load the map, :func:`envfit.advisor.advise_with`
of the renderer's options on it, return its row) run where :class:`~envfit.batch.LibraryOptions` says:
inline, on a local process pool or on a dask cluster (:mod:`envfit.batch._executor`, the
driver :func:`envfit.batch._scheduler.drive`). The options are checked once, before any map
is read (:class:`~envfit.advisor._renderer_options.RendererAdviseOptions`); the maps are
resolved without being read (:func:`envfit.maps._lazy_maps.resolve_map_sources`), so a
missing file, an empty folder or a pattern matching nothing is one line before the work.

Resumable: with ``out`` every finished map is written at once, atomically and with a
checksum, to ``out/cells/<slug>.json`` (:class:`~envfit.base._store.ResultStore`, kind
``advise_library``, whose config is the renderer options and the target); a rerun with the
same options reads the maps already done and computes only the others. A stored map whose
file has changed since (size or modification time) is computed again. A killed worker loses
its map only; the run then says how many were lost (:class:`~envfit.base.ExecutorError`),
and the rerun completes them.

The target. ``target_rmse`` is one absolute RMSE for every map; ``target_relative``
(default 1 %) is a fraction of *each map's* mean radiance, so each map has its own absolute
target (the row's ``target_rmse``).

Coverage (:func:`coverage`): for a fraction q of the maps, the smallest spp of the
recommended strategy that meets its target on at least ⌈q·n⌉ maps: the ⌈q·n⌉-th smallest
recommended spp. A map whose search reached no spp counts as needing more than its largest
spp searched; a fraction that needs such a map has no spp (``spp`` None, ``more_than`` the
largest spp searched).

Example
-------
>>> import numpy as np, tempfile
>>> from envfit.maps import EnvMap
>>> from envfit.advisor._renderer_options import RendererAdviseOptions
>>> from envfit.batch import LibraryOptions
>>> rng = np.random.default_rng(0)
>>> maps = [EnvMap(rng.random((8, 16, 3)) + 0.5, name=f"m{k}.exr") for k in range(3)]
>>> from envfit.renderers import RENDERERS
>>> name = next(n for n, r in RENDERERS.items() if "independent" in r.samplers)
>>> opts = RendererAdviseOptions(name, sampler="independent", normals=4, level=3)
>>> lib = advise_library(maps, opts, target_relative=0.05, cache_dir=tempfile.mkdtemp(),
...                      library=LibraryOptions(workers=1))
>>> [r.slug for r in lib.rows], [c["fraction"] for c in lib.coverage]
(['m0', 'm1', 'm2'], [0.5, 0.9, 1.0])
>>> all(r.predicted_rmse <= r.target_rmse for r in lib.rows if r.reached)
True
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from envfit.base import ParameterError
from envfit.base import html_result
from envfit.base import ResultStore, number

__all__ = ["MapRow", "LibraryAdvice", "advise_library", "coverage", "COVERAGE_FRACTIONS"]

#: the fractions of the maps the coverage names
COVERAGE_FRACTIONS = (0.5, 0.9, 1.0)
#: the stored row's numbers and their ranges (a forged cell with a valid checksum is refused)
_CHECKS = {"mean_radiance": number(0.0, open_=True), "target_rmse": number(0.0, open_=True),
           "predicted_rmse": number(0.0), "spp": number(1.0), "searched_max": number(1.0)}


@dataclass
class MapRow:
    """One map's answer: the recommendation (the renderer's default strategy) and every
    strategy's spp (``answers``: strategy → ``{"spp", "reached", "predicted_rmse",
    "searched_max"}``)."""
    label: str
    slug: str
    width: int
    height: int
    mean_radiance: float
    target_rmse: float
    strategy: str
    spp: int
    reached: bool
    predicted_rmse: float
    searched_max: int
    answers: dict
    seconds: float = 0.0
    resumed: bool = False
    model_se: list | None = None       # [total, normals', scrambles'] relative SE, or None

    def needs(self) -> float:
        """The spp this map needs: its recommended spp, or infinity if none searched meets."""
        return float(self.spp) if self.reached else math.inf


@dataclass
class LibraryAdvice:
    """The library's answer: one :class:`MapRow` per map (input order), the coverage, what
    the run cost and where it ran."""
    renderer: str
    sampler: str
    strategies: tuple
    target_rmse: float | None
    target_relative: float | None
    rows: list[MapRow]
    coverage: list[dict]
    computed: int = 0
    resumed: int = 0
    seconds: float = 0.0
    executor: str = ""
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)

    def table_lines(self) -> list[str]:
        """The printed table: a row per map, then the coverage."""
        strategies = list(self.strategies)
        head = f"  {'map':<28s} {'target':>10s}" + "".join(f" {s:>9s}" for s in strategies)
        out = [f"{len(self.rows)} maps, {self.renderer} sampler {self.sampler}: the spp that "
               f"meets each map's target (the recommended strategy first; '>N': none up to N)",
               head + f" {'predicted':>10s} {'model error':>11s}"]
        for r in self.rows:
            cells = "".join(f" {_spp_text(r.answers[s]):>9s}" for s in strategies)
            err = f"±{100 * r.model_se[0]:.1f} %" if r.model_se else "-"
            out.append(f"  {r.label[:28]:<28s} {r.target_rmse:>10.4g}{cells} "
                       f"{r.predicted_rmse:>10.4g} {err:>11s}")
        for c in self.coverage:
            what = (f"{c['spp']} spp" if c["spp"] is not None
                    else f"more than {c['more_than']} spp (not reached)")
            out.append(f"{c['fraction']:.0%} of the maps ({c['maps']} of {len(self.rows)}) "
                       f"meet their target with {self.strategies[0]} at {what}")
        return out

    def to_dict(self) -> dict:
        """JSON: the run, every row, the coverage."""
        return {"renderer": self.renderer, "sampler": self.sampler,
                "strategies": list(self.strategies), "target_rmse": self.target_rmse,
                "target_relative": self.target_relative,
                "maps": [asdict(r) for r in self.rows], "coverage": self.coverage,
                "computed": self.computed, "resumed": self.resumed, "seconds": self.seconds,
                "executor": self.executor, "notes": self.notes, "files": self.files}

    def csv_rows(self) -> tuple[list[str], list[list[Any]]]:
        """The library table as CSV columns and rows (one per map)."""
        cols = ["map", "width", "height", "mean_radiance", "target_rmse", "strategy", "spp",
                "reached", "predicted_rmse", "model_se"] + [f"spp_{s}" for s in self.strategies]
        rows = [[r.label, r.width, r.height, r.mean_radiance, r.target_rmse, r.strategy,
                 r.spp, r.reached, r.predicted_rmse, r.model_se[0] if r.model_se else ""]
                + [_spp_text(r.answers[s]) for s in self.strategies] for r in self.rows]
        return cols, rows

    def _repr_html_(self) -> str:
        cols, rows = self.csv_rows()
        return html_result(f"LibraryAdvice: {len(self.rows)} maps", [
            ("renderer, sampler", (self.renderer, self.sampler)),
            *((f"{c['fraction']:.0%} of the maps", c["spp"] or f"> {c['more_than']}")
              for c in self.coverage),
            ("seconds", self.seconds), *(("note", n) for n in self.notes)], (cols, rows))


def _spp_text(answer: dict) -> str:
    """``"256"``, or ``">4096"`` where no spp up to the largest searched meets the target."""
    return str(answer["spp"]) if answer["reached"] else f">{answer['searched_max']}"


def coverage(rows: Sequence[MapRow],
             fractions: Sequence[float] = COVERAGE_FRACTIONS) -> list[dict]:
    """For each fraction q: ``{"fraction", "maps", "spp", "more_than"}``, the smallest
    recommended spp that meets the target on ``maps`` = ⌈q·n⌉ of the n maps (module
    docstring); ``spp`` None where one of those maps reached no spp.

    >>> r = lambda spp, ok=True: MapRow("m", "m", 8, 4, 1.0, 0.01, "mis", spp, ok, 0.01,
    ...                                 4096, {})
    >>> [c["spp"] for c in coverage([r(64), r(16), r(256), r(1024)])]
    [64, 1024, 1024]
    >>> coverage([r(64), r(4096, ok=False)])[-1]
    {'fraction': 1.0, 'maps': 2, 'spp': None, 'more_than': 4096}
    """
    if not rows:
        return []
    needs = sorted(rows, key=MapRow.needs)
    out = []
    for q in fractions:
        k = max(1, math.ceil(q * len(rows) - 1e-9))
        r = needs[k - 1]
        out.append({"fraction": q, "maps": k, "spp": r.spp if r.reached else None,
                    "more_than": None if r.reached else r.searched_max})
    return out


def _advise_map(source, opts, target_rmse, target_relative, cache: bool, cache_dir) -> dict:
    """The task of one map (runs on a worker): load it, advise it, return its row (a dict)."""
    from envfit.advisor import advise_with
    from dataclasses import replace
    t0 = time.perf_counter()
    env = source.load()
    adv = advise_with(env, replace(                             # the driver's bar is over maps
        opts, quiet=True, target_rmse=target_rmse, target_relative=target_relative,
        filename=source.path or source.label, cache=cache, cache_dir=cache_dir))
    rec = adv.recommendation
    answers = {a["strategy"]: {k: a[k] for k in ("spp", "reached", "predicted_rmse",
                                                 "searched_max")}
               for a in adv.to_dict()["answers"]}
    return {"label": source.label, "slug": source.slug, "width": env.width,
            "height": env.height, "mean_radiance": adv.mean_radiance,
            "target_rmse": adv.target_rmse, "strategy": rec["strategy"], "spp": rec["spp"],
            "reached": rec["reached"], "predicted_rmse": rec["predicted_rmse"],
            "searched_max": rec["searched_max"], "answers": answers,
            "model_se": (adv.model.get("model_se") or {}).get(rec["strategy"]),
            "seconds": time.perf_counter() - t0, "notes": [*env.notes, *adv.notes]}


def _run_config(opts, target_rmse, target_relative) -> dict:
    """What a stored row depends on besides its map: the store's config."""
    return {"options": opts.key(), "strategies": list(opts.strategies), "max_spp": opts.max_spp,
            "mis_compensation": opts.mis_compensation, "sized": opts.auto,
            "model_error": opts.model_error, "target_rmse": target_rmse,
            "target_relative": target_relative}


def _stored(store: ResultStore, src) -> dict | None:
    """The stored row of ``src`` if it is sound and of this very file, else None."""
    cell = store.get(src.slug, fields=("identity", "row"))
    if cell is None:
        return None
    row = cell["row"]
    if cell["identity"] != src.identity() or not isinstance(row, dict):
        return None
    if any(k not in row or check(row[k], k) for k, check in _CHECKS.items()):
        return None
    return row


def advise_library(maps: Sequence, opts, *, target_rmse: float | None = None,
                   target_relative: float | None = None, library=None,
                   out: str | Path | None = None, cache: bool = True, cache_dir=None,
                   on_map: Callable[[MapRow], None] | None = None) -> LibraryAdvice:
    """Advise every map of ``maps`` in the renderer's terms (module docstring).

    Parameters
    ----------
    maps : sequence
        Files, folders, glob patterns or :class:`~envfit.maps.EnvMap` objects
        (:func:`~envfit.maps._lazy_maps.resolve_map_sources`).
    opts : RendererAdviseOptions
        The renderer, sampler, strategies and model resolution, one for every map.
    target_rmse, target_relative : float, optional
        The target (at most one; default 1 % of each map's mean radiance).
    library : LibraryOptions, optional
        Where the maps' tasks run and how the files are read (default: a local pool planned
        from the cores).
    out : path, optional
        The resumable store of finished maps (``out/cells/<slug>.json``).
    cache, cache_dir
        The advisor's per-map cache of predicted cells (shared by every worker).
    on_map : callable, optional
        Called in this process with each :class:`MapRow` as it is finished or resumed.
    """
    from envfit.batch import LibraryOptions
    from envfit.maps import resolve_map_sources
    t0 = time.perf_counter()
    if target_rmse is not None and target_relative is not None:
        raise ParameterError("give the target once: target_rmse or target_relative")
    if target_rmse is None and target_relative is None:
        from envfit.defaults import DEFAULT_TARGET_RELATIVE
        target_relative = DEFAULT_TARGET_RELATIVE     # said as given, in the table and JSON
    library = LibraryOptions.of(library)
    sources = resolve_map_sources(maps, library.load_options)
    config = _run_config(opts, target_rmse, target_relative)
    lib = LibraryAdvice(opts.renderer, opts.sampler, tuple(opts.strategies), target_rmse,
                        target_relative, rows=[], coverage=[])
    with ResultStore(Path(out) if out is not None else None, config, kind="advise_library",
                     on_note=lib.notes.append) as store:
        rows: dict[str, MapRow] = {}
        for src in sources:
            row = _stored(store, src)
            if row is not None:
                rows[src.slug] = _row(row, resumed=True)
                _report(rows[src.slug], on_map)
        missing = [s for s in sources if s.slug not in rows]
        lib.resumed, lib.computed = len(rows), len(missing)
        _compute(missing, (opts, target_rmse, target_relative, cache, cache_dir), library,
                 lambda src, d: _finished(store, src, d, rows, lib, on_map), lib)
    lib.rows = [rows[s.slug] for s in sources]
    lib.coverage = coverage(lib.rows)
    lib.seconds = time.perf_counter() - t0
    return lib


def _row(d: dict, *, resumed: bool) -> MapRow:
    fields = {k: d[k] for k in MapRow.__dataclass_fields__ if k in d and k != "resumed"}
    return MapRow(**fields, resumed=resumed)


def _report(row: MapRow, on_map) -> None:
    if on_map is not None:
        on_map(row)


def _finished(store: ResultStore, src, d: dict, rows: dict, lib: LibraryAdvice, on_map) -> None:
    """A map's row arrived (in the driver): store it at once, keep its notes, report it."""
    lib.notes.extend(f"{src.label}: {n}" for n in d.pop("notes", []))
    store.put(src.slug, {"identity": src.identity(), "row": d})
    rows[src.slug] = _row(d, resumed=False)
    _report(rows[src.slug], on_map)


def _compute(missing: list, args: tuple, library, done: Callable, lib: LibraryAdvice) -> None:
    """Run one :func:`_advise_map` task per missing map on the library's executor, a
    progress bar over the maps (``library.quiet`` hides it)."""
    if not missing:
        return
    from envfit.base import progress_bar
    from envfit.batch._scheduler import Task, drive
    ex, notes = library.make_executor(max_useful=len(missing),
                                      bytes_per_task=_task_bytes(args[0], missing))
    lib.notes.extend(notes)
    lib.executor = ex.describe()
    bar = progress_bar(len(missing), desc="maps advised", quiet=library.quiet, unit="map")

    def on_done(src, d):
        done(src, d)
        bar.update(1)

    tasks = [Task(0, _advise_map, (src, *args), label=f"advise {src.label}",
                  on_done=lambda d, src=src: on_done(src, d)) for src in missing]
    try:
        drive(ex, tasks)
    finally:
        bar.close()
        library.close(ex)


def _task_bytes(opts, missing) -> int:
    """The peak of one map's task: the renderer model's plan
    (:func:`envfit.advisor._budget.renderer_plan`) on the largest missing map, with the map
    itself resident (float32, 4 channels at most)."""
    from envfit.advisor import renderer_plan
    pixels = max((s.pixels() for s in missing), default=0)
    return renderer_plan(pixels, opts, resident=16 * pixels).peak()

"""Files of a library run: per-map CSV, a summary across maps (CSV + JSON), a histogram of s.

Table 2 (:func:`write_table2_library`)::

    OUT/library_table2.csv      one row per (map, s, N): RMSEs, seconds
    OUT/library_summary.csv     one row per map: best s at the largest N, RMSE there per s
    OUT/library_table2.json     everything (LibraryTable2Result.to_dict)
    OUT/library_s_best.png      how often each s of the grid is the best one
    OUT/<slug>/table2.csv       the map's own table (as ``envfit table2 MAP`` writes it)

Fit (:func:`write_fit_library`)::

    OUT/library_fit.csv         one row per map: s, interval, sigma per channel
    OUT/library_fit.json        everything (LibraryFitResult.to_dict)
    OUT/library_fit_s.png       histogram of s, and every map's s with its interval

All writes are atomic (:mod:`envfit.base._atomic`).
"""
from __future__ import annotations

from pathlib import Path

from envfit.base import atomic_write_csv, atomic_write_json

__all__ = ["write_table2_library", "write_fit_library"]


def write_table2_library(lib, out: str | Path) -> dict[str, str]:
    """Write the Table 2 library files (module docstring) and record them in ``lib.files``."""
    from envfit.plots import plot_s_histogram
    out = Path(out)
    rows = [(slug, r.map, c.s, c.n, c.rmse, c.rmse_solid_angle, c.seconds)
            for slug, r in zip(lib.slugs, lib.maps) for c in r.cells]
    files = {"library_table2.csv": atomic_write_csv(
        out / "library_table2.csv",
        ("slug", "map", "s", "n", "rmse", "rmse_solid_angle", "seconds"), rows)}
    summary = lib.summary_rows()
    files["library_summary.csv"] = atomic_write_csv(
        out / "library_summary.csv", tuple(summary[0]), [tuple(r.values()) for r in summary])
    for slug, r in zip(lib.slugs, lib.maps):
        atomic_write_csv(out / slug / "table2.csv",
                         ("s", "n", "rmse", "rmse_solid_angle", "seconds"),
                         [(c.s, c.n, c.rmse, c.rmse_solid_angle, c.seconds) for c in r.cells])
    files["library_s_best.png"] = plot_s_histogram(
        lib.s_best(), out / "library_s_best.png", grid=lib.s_values,
        title=f"best s at N = {lib.n_values[-1]} across {len(lib.maps)} maps ({lib.scale} scale)")
    lib.files.update({k: str(v) for k, v in files.items()})
    files["library_table2.json"] = atomic_write_json(out / "library_table2.json", lib.to_dict())
    lib.files["library_table2.json"] = str(files["library_table2.json"])
    return lib.files


def write_fit_library(lib, out: str | Path) -> dict[str, str]:
    """Write the fit library files (module docstring) and record them in ``lib.files``."""
    from envfit.plots import plot_s_histogram
    out = Path(out)
    nch = max(len(f.sigma) for f in lib.fits)
    header = ("slug", "map", "s", "s_low", "s_high", *[f"sigma_{c}" for c in range(nch)])
    rows = [(slug, label, f.s, f.s_interval[0], f.s_interval[1],
             *(list(f.sigma) + [""] * (nch - len(f.sigma))))
            for slug, label, f in zip(lib.slugs, lib.labels, lib.fits)]
    files = {"library_fit.csv": atomic_write_csv(out / "library_fit.csv", header, rows)}
    files["library_fit_s.png"] = plot_s_histogram(
        [f.s for f in lib.fits], out / "library_fit_s.png",
        intervals=[f.s_interval for f in lib.fits], labels=lib.labels,
        title=f"fitted s ({lib.method}, N = {lib.n}, {lib.scale} scale) across {len(lib.fits)} maps")
    lib.files.update({k: str(v) for k, v in files.items()})
    files["library_fit.json"] = atomic_write_json(out / "library_fit.json", lib.to_dict())
    lib.files["library_fit.json"] = str(files["library_fit.json"])
    return lib.files

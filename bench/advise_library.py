"""Benchmark: a library of HDRIs advised in a renderer's terms (``envfit advise DIR
--renderer NAME``, issue 40's acceptance): one map alone, the whole library on the local pool,
optionally the same through dask, and a killed run resumed.

Run:  python bench/advise_library.py [--maps 100] [--height 512] [--renderer mitsuba3]
      [--sampler S] [--workers 2] [--dask] [--kill-after 30] [--folder DIR] [--json F]

Phases (each a child process running the installed CLI, so that its wall time is its own;
the 1-minute load average recorded before and after):

* **one**: ``envfit advise MAP --renderer R`` on the first map (fresh cache);
* **library**: ``envfit advise FOLDER --renderer R --out OUT --workers K`` (fresh cache):
  target ≤ maps × one;
* **dask** (``--dask``): the same with ``--executor dask`` (a LocalCluster of K worker
  processes): its rows must equal the library's;
* **kill** (``--kill-after T``): the library run killed with SIGKILL after T seconds, then
  rerun on the same ``--out``: the rerun must compute only the maps the killed run had not
  finished (``resumed + computed = maps``) and give the same rows.

The maps are synthesized suns on Gaussian-process skies (``data_gen.sun_gp_map``: seeds,
sun positions and strengths differ per map), H x 2H, written once to ``--folder``.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from render_check import _cpu  # noqa: E402


def load() -> float:
    return round(os.getloadavg()[0], 2)


def synthesize(folder: Path, count: int, height: int) -> list[Path]:
    """``count`` sun-on-GP maps of ``height`` rows in ``folder`` (kept between runs)."""
    import numpy as np
    sys.path.insert(0, str(ROOT))
    from data_gen import sun_gp_map
    from envfit.maps import save_envmap
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(40)
    paths = []
    for i in range(count):
        p = folder / f"sky{i:03d}.exr"
        theta, phi = rng.uniform(0.2, 1.4), rng.uniform(0, 2 * np.pi)
        if not p.exists():
            sun = float(10 ** rng.uniform(2.5, 4.5))
            data, _ = sun_gp_map(height, seed=1000 + i, sun_theta=theta, sun_phi=phi,
                                 sun_radius=0.02 + 0.03 * rng.random(),
                                 sun_radiance=(sun, 0.95 * sun, 0.9 * sun), channels=3)
            save_envmap(p, data.astype(np.float32))
        paths.append(p)
    return paths


def cli(argv: list[str], kill_after: float | None = None) -> dict:
    """Run ``envfit`` in a child process: wall seconds, exit code, load before/after."""
    before, t0 = load(), time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from envfit.cli import main; "
                             "sys.exit(main(sys.argv[1:]))", *argv],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=kill_after)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
    return {"wall_s": time.perf_counter() - t0, "rc": proc.returncode, "load_before": before,
            "load_after": load(), "stdout": out}


def rows(out: Path) -> list[tuple]:
    d = json.loads((out / "advise_library.json").read_text())
    return [(m["label"], m["strategy"], m["spp"]) for m in d["maps"]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=100)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--renderer", default="mitsuba3")
    ap.add_argument("--sampler", default=None)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--dask", action="store_true")
    ap.add_argument("--kill-after", type=float, default=None)
    ap.add_argument("--folder", type=Path, default=Path(tempfile.gettempdir()) / "envfit_hdri")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    paths = synthesize(a.folder / f"{a.height}", a.maps, a.height)
    work = Path(tempfile.mkdtemp(prefix="advise_library_"))
    base = ["--renderer", a.renderer, *(["--sampler", a.sampler] if a.sampler else [])]
    res = {"cpu": _cpu(), "cores": os.cpu_count(), "maps": a.maps,
           "size": f"{2 * a.height}x{a.height}", "renderer": a.renderer, "sampler": a.sampler}
    res["one"] = cli(["advise", str(paths[0]), *base, "--cache-dir", str(work / "c1"), "-q"])
    folder = str(paths[0].parent)
    lib = ["advise", folder, *base, "--workers", str(a.workers), "-q"]
    res["library"] = cli([*lib, "--out", str(work / "o1"), "--cache-dir", str(work / "c2")])
    res["library"]["per_one"] = res["library"]["wall_s"] / res["one"]["wall_s"]
    reference = rows(work / "o1")
    if a.dask:
        res["dask"] = cli([*lib, "--executor", "dask", "--out", str(work / "o2"),
                           "--cache-dir", str(work / "c3")])
        res["dask"]["same_rows"] = rows(work / "o2") == reference
    if a.kill_after:
        killed = cli([*lib, "--out", str(work / "o3"), "--cache-dir", str(work / "c4")],
                     kill_after=a.kill_after)
        rerun = cli([*lib, "--out", str(work / "o3"), "--cache-dir", str(work / "c5"),
                     "--json", str(work / "rerun.json")])
        d = json.loads((work / "rerun.json").read_text())
        res["kill"] = {"killed_rc": killed["rc"], "rerun_wall_s": rerun["wall_s"],
                       "computed": d["computed"], "resumed": d["resumed"],
                       "same_rows": rows(work / "o3") == reference}
    for k in ("one", "library", "dask"):
        res.get(k, {}).pop("stdout", None)
    print(json.dumps(res, indent=1))
    if a.json:
        a.json.write_text(json.dumps(res, indent=1))
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

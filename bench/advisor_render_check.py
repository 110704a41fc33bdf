"""The sized advisor's predictions set against rendered rows of ``bench/render_check.py``.

``envfit.advise_renderer`` (``envfit advise MAP --renderer R --spp 64,256``) runs the
default model — sized to ``--renderer-model-error`` — while ``render_check.py`` predicts
with the bench's own model; this compares the advisor's predictions at the rendered spp with the measured RMSE
and its 95 % interval, by the same rule ([0.8 × low, 1.25 × high]).

    python bench/render_check.py --renderer mitsuba3 forest64.exr sun-gp-1.5 \\
        --synth-height 64 --samplers ldsampler independent --strategies mis \\
        --spp 64 256 --resolution 32 --out /tmp/rc
    python bench/advisor_render_check.py --renderer mitsuba3 /tmp/rc/render_check_mitsuba3.json \\
        --maps forest64.exr --synth-height 64

Maps are matched by name: a file's stem (``--maps``) or a synthesized map's name
(``sun-gp-1.5``, made again at ``--synth-height``).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from envfit import advise_renderer
from envfit.advisor._renderer_options import SIZED_RANDOMISATIONS  # internal: which samplers have scrambles

sys.path.insert(0, str(Path(__file__).parent))
from render_check import _cpu, load_map  # noqa: E402  (bench helpers: CPU name, maps)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("rows", nargs="+", help="render_check JSON files")
    ap.add_argument("--renderer", required=True, choices=["mitsuba3", "cycles"])
    ap.add_argument("--maps", nargs="*", default=[], help="the map files rendered")
    ap.add_argument("--synth-height", type=int, default=64)
    ap.add_argument("--cache", default=None, help="the advisor's cache folder")
    args = ap.parse_args()
    files = {Path(p).stem: p for p in args.maps}
    rows = []
    for path in args.rows:
        data = json.loads(Path(path).read_text())
        rows += data["rows"] if isinstance(data, dict) else data
    spps: dict = {}
    for r in rows:
        spps.setdefault((r["map"], r["sampler"], r["strategy"]), set()).add(int(r["spp"]))
    advice, inside, total = {}, 0, 0
    for r in rows:
        key = (r["map"], r["sampler"], r["strategy"])
        if key not in advice:                  # one advisor run per map, sampler, strategy
            _, env = load_map(files.get(r["map"], r["map"]), args.synth_height)
            advice[key] = advise_renderer(env, args.renderer, sampler=r["sampler"],
                                          spp=tuple(sorted(spps[key])),
                                          strategies=(r["strategy"],), cache_dir=args.cache)
        adv = advice[key]
        p = adv.cells[(r["strategy"], r.get("spp_used", r["spp"]))]
        ok = 0.8 * r["low"] <= p <= 1.25 * r["high"]
        inside, total = inside + ok, total + 1
        m = adv.model
        print(f"{r['map']:12s} {r['sampler']:16s} {r['strategy']:5s} {r['spp']:5d} measured "
              f"{r['measured_rmse']:.5g} [{r['low']:.5g}, {r['high']:.5g}] advisor {p:.5g} "
              f"({p / r['measured_rmse']:.3f}; bench model {r['predicted'] / r['measured_rmse']:.3f})"
              f" {'inside' if ok else 'OUTSIDE'}; {m['normals']} {m.get('unit', 'normals')}"
              + (f", {m['shifts']} scrambles" if adv.options.record.sampler(r["sampler"])
                 .randomisation in SIZED_RANDOMISATIONS else ""))
    print(f"inside {inside} of {total}; CPU {_cpu()}")
    return 0 if inside == total else 1


if __name__ == "__main__":
    raise SystemExit(main())

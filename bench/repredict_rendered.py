"""Predict the cells of a saved ``envfit validate --renderer`` run again with the current
model (no rendering): each row keeps its measurement, and gets the new prediction beside
the saved one (``predicted_before``) with its ratio and whether it is inside [0.8 × low,
1.25 × high]; per view-angle band likewise.

    python bench/repredict_rendered.py OUT/rendered.json MAP.exr [--samplers ldsampler]
        [--strategies mis] --out OUT/repredicted.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from envfit.base._atomic import atomic_write_json  # internal: the product's atomic writer
from envfit.maps import load_envmap
from envfit.validate import RenderValidationOptions
from envfit.validate._rendered import is_inside  # internal: the acceptance rule of the run
from envfit.validate._rendered import _model  # internal: the run's own step 1, the model


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rendered", type=Path)
    ap.add_argument("map")
    ap.add_argument("--samplers", nargs="*", default=None)
    ap.add_argument("--strategies", nargs="*", default=None)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    saved = json.loads(a.rendered.read_text())
    fields = {f.name for f in dataclasses.fields(RenderValidationOptions)}
    o = saved["options"]
    opts = RenderValidationOptions(**{k: (tuple(v) if isinstance(v, list) else v)
                                      for k, v in o.items() if k in fields})
    rows = [r for r in saved["rows"]
            if (a.samplers is None or r["sampler"] in a.samplers)
            and (a.strategies is None or r["strategy"] in a.strategies)]
    env = load_envmap(a.map)
    model = _model(env, opts)
    model.predict_many([(r["strategy"], r["sampler"], r["spp_used"]) for r in rows])
    for r in rows:
        p = float(model.predict(r["strategy"], r["sampler"], r["spp_used"]).rmse)
        r.update(predicted_before=r["predicted"], predicted=p, ratio=p / r["measured_rmse"],
                 inside=is_inside(p, r["low"], r["high"]))
        bands = model.predict_bands(r["strategy"], r["sampler"], r["spp_used"])
        for b, v in r.get("bands", {}).items():
            v.update(predicted_before=v["predicted"], predicted=bands[b],
                     inside=is_inside(bands[b], v["low"], v["high"]))
        print(f"{r['sampler']:12s} {r['strategy']:5s} {r['spp_used']:5d} measured "
              f"{r['measured_rmse']:.4g} [{r['low']:.4g}, {r['high']:.4g}] predicted "
              f"{p:.4g} ({p / r['measured_rmse']:.3f}; was "
              f"{r['predicted_before'] / r['measured_rmse']:.3f}) "
              f"{'inside' if r['inside'] else 'OUT'}", flush=True)
    atomic_write_json(a.out, {"options": o, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""envfit end to end on the built-in map, through the Python API, in well under a minute.

    python examples/quickstart.py [OUT_DIR]          # default OUT_DIR: ./quickstart_out

1. the built-in map (a Gaussian-process map of known smoothness s0 = 1.5), downscaled to
   32 rows, and its preview with the bright sources marked;
2. its Sobolev smoothness s (likelihood fit) and the criterion curve;
3. the paper's Table 2 on a small grid (3 s × 2 N) and its plot;
4. the advisor: the smallest N (spherical Fibonacci) and SH degree for a 2 % target, glossy
   lobe n = 30, with a check of the chosen N/L on the map;
5. the validation of predicted against measured errors on a small configuration.

Every step prints its result and writes its PNG to OUT_DIR. The settings are the smallest
the API offers that still mean something (N ≤ 300 samples, 100 axes); the README's figures
use the defaults. In Jupyter, each result (``fit``, ``table``, ``advice``, ``validation``)
displays as an HTML table by itself (``_repr_html_``).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

from envfit import advise, default_envmap, fit_smoothness, run_table2, run_validation
from envfit.fit.table2 import format_table2
from envfit.plots.advise_rules import plot_advise_rules
from envfit.plots.preview import plot_map_preview
from envfit.plots.table2 import plot_fit_curve, plot_table2
from envfit.plots.validate import plot_all
from envfit.shading.map_preview import map_preview
from envfit.validate.config import quick_config


def main(out: Path) -> list[Path]:
    """Run the five steps, print their results, return the PNGs written into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    env = default_envmap(height=32)                                  # 64x32, 3 channels
    print(f"map {env.name}: {env.width}x{env.height}, {env.channels} channel(s)")
    pngs = [plot_map_preview(map_preview(env), out / "preview.png")]

    fit = fit_smoothness(env, n=300, scale="linear")
    print(f"s = {fit.s:.3f} (95 % interval {fit.s_interval[0]:.3f} … {fit.s_interval[1]:.3f}), "
          f"sigma = {', '.join(f'{x:.3g}' for x in fit.sigma)}")
    pngs.append(plot_fit_curve(fit, out / "fit_likelihood.png"))

    table = run_table2(env, [1.2, 1.5, 1.8], [100, 300], save_reconstructions=False)
    print(format_table2(table))
    pngs.append(plot_table2(table, out / "table2_rmse.png"))

    advice = advise(env, brdf="glossy", shininess=30, target_relative=0.02, pointsets=["sf"],
                    weights=["equal"], bases=["sh"], fit_n=300, nmax=4096, check=True,
                    axes=100, cache=False, renderer=False)
    print(*advice.table_lines(), advice.recommendation, sep="\n")
    pngs.append(plot_advise_rules(advice.to_dict(), out / "advise_rules.png"))

    config = quick_config(brdfs=["glossy"], pointsets=["sf", "random"], n_values=[16, 64],
                          axes=100, fit_n=300, s=1.5, scale="linear", sh_L=[0, 2, 4],
                          hsh_L=[0, 2], hsh_axes=10, hsh_max_height=16, equivalent_nmax=256)
    validation = run_validation(env, config)
    for e in validation.results:
        m, b = e["measured_rmse"][-1], e["predicted_rmse_refined"][-1]
        print(f"validate {e['pointset']}/{e['weights']} N = {e['n'][-1]}: measured {m:.4g}, "
              f"(b') predicted {b:.4g} ({b / m:.2f} x)")
    pngs += [Path(p) for p in plot_all(validation.to_json(), out).values()]
    print(f"wrote {len(pngs)} PNGs to {out} in {time.perf_counter() - t0:.1f} s")
    return pngs


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("quickstart_out"))

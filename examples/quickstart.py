# %% [markdown]
# # envfit quickstart: the built-in map end to end, through the Python API
#
# `python examples/quickstart.py [OUT_DIR]` (default `./quickstart_out`), or
# `examples/quickstart.ipynb` (the same cells, written by `examples/make_notebook.py`):
#
# 1. the built-in map (a Gaussian-process map of known smoothness s0 = 1.5) at 32 rows, and
#    its preview with the bright sources marked;
# 2. its Sobolev smoothness s (likelihood fit) and the criterion curve;
# 3. the paper's Table 2 on a small grid (3 s x 2 N) and its plot;
# 4. the advisor: the smallest N (spherical Fibonacci) and SH degree for a 2 % target,
#    glossy lobe n = 30, with a check of the chosen N/L on the map;
# 5. the validation of predicted against measured errors on a small configuration.
#
# Every step prints its result and writes its PNG to OUT_DIR. The settings are the smallest
# that still mean something (N <= 300 samples, 100 axes); the README's figures use the
# defaults. In Jupyter the last line of a cell (`fit`, `table`, `advice`, `validation`)
# shows the result as an HTML table (`_repr_html_`).

# %%
import sys
import time
from pathlib import Path

from envfit import advise, default_envmap, fit_smoothness, run_table2, run_validation
from envfit.fit import format_table2
from envfit.maps import map_preview
from envfit.plots import plot_advise_rules, plot_all, plot_fit_curve, plot_map_preview, plot_table2
from envfit.validate import quick_config

ARG = sys.argv[1] if len(sys.argv) > 1 else ""
OUT = Path(ARG if ARG and not ARG.startswith("-") else "quickstart_out")   # Jupyter: -f …
OUT.mkdir(parents=True, exist_ok=True)
t0 = time.perf_counter()
env = default_envmap(height=32)                                  # 64x32, 3 channels
print(f"map {env.name}: {env.width}x{env.height}, {env.channels} channel(s)")
pngs = [plot_map_preview(map_preview(env), OUT / "preview.png")]

# %% [markdown]
# ## The smoothness s of the map

# %%
fit = fit_smoothness(env, n=300, scale="linear")
print(f"s = {fit.s:.3f} (95 % interval {fit.s_interval[0]:.3f} … {fit.s_interval[1]:.3f}), "
      f"sigma = {', '.join(f'{x:.3g}' for x in fit.sigma)}")
pngs.append(plot_fit_curve(fit, OUT / "fit_likelihood.png"))
fit

# %% [markdown]
# ## Table 2: kernel reconstruction RMSE per (s, N)

# %%
table = run_table2(env, [1.2, 1.5, 1.8], [100, 300], save_reconstructions=False)
print(format_table2(table))
pngs.append(plot_table2(table, OUT / "table2_rmse.png"))
table

# %% [markdown]
# ## How many samples for a 2 % error (glossy lobe n = 30)?

# %%
advice = advise(env, brdf="glossy", shininess=30, target_relative=0.02, pointsets=["sf"],
                weights=["equal"], bases=["sh"], fit_n=300, nmax=4096, check=True,
                axes=100, cache=False, renderer=False)
print(*advice.table_lines(), advice.recommendation, sep="\n")
pngs.append(plot_advise_rules(advice.to_dict(), OUT / "advise_rules.png"))
advice

# %% [markdown]
# ## Predicted against measured errors

# %%
config = quick_config(brdfs=["glossy"], pointsets=["sf", "random"], n_values=[16, 64],
                      axes=100, fit_n=300, s=1.5, scale="linear", sh_L=[0, 2, 4],
                      hsh_L=[0, 2], hsh_axes=10, hsh_max_height=16, equivalent_nmax=256)
validation = run_validation(env, config)
for e in validation.results:
    m, b = e["measured_rmse"][-1], e["predicted_rmse_refined"][-1]
    print(f"validate {e['pointset']}/{e['weights']} N = {e['n'][-1]}: measured {m:.4g}, "
          f"(b') predicted {b:.4g} ({b / m:.2f} x)")
pngs += [Path(p) for p in plot_all(validation.to_json(), OUT).values()]
print(f"wrote {len(pngs)} PNGs to {OUT} in {time.perf_counter() - t0:.1f} s")
validation

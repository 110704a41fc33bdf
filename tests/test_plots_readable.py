"""The figures people read: validate's absolute predictions one figure per BRDF with (b),
(b′) and (c) told apart; whole-number ticks wherever an axis counts (maps, N, L).

The figures are captured before saving (``save_figure`` replaced by a recorder) and their
artists read back: the plotted ratios against predicted/measured computed here, the
styles of the three predictions, the legend's names, and every tick value of a counting
axis against being a whole number.
"""
from __future__ import annotations

import numpy as np
import pytest

import envfit.plots._library as PL
import envfit.plots._validate as PV

N = [16, 32, 64, 128]


def _entry(brdf, ps, w, k):
    m = np.array([0.2, 0.1, 0.05, 0.025]) * (1 + 0.1 * k)
    return {"brdf": brdf, "pointset": ps, "weights": w, "n": N, "measured_rmse": list(m),
            "predicted_rmse": list(m * 1.5), "predicted_rmse_refined": list(m * [1.02, 0.98, 1.0, 1.05]),
            "predicted_rmse_spectral": list(m * [0.97, 1.01, 0.99, 1.0]),
            "predicted_shape": list(m * 1.1), "predicted_wce": list(m), "band_lmax": 15}


@pytest.fixture
def result():
    entries = [_entry(b, ps, w, k) for k, (b, ps, w) in enumerate(
        (b, ps, w) for b in ("diffuse", "glossy") for ps in ("sf", "random") for w in ("equal", "osw"))]
    trunc = [{"brdf": "glossy", "basis": "sh", "L": [0, 1, 2, 3], "axes": 10, "map_height": 16,
              "measured_rmse": [0.5, 0.3, 0.2, 0.1], "predicted_shape": [0.5, 0.3, 0.2, 0.1],
              "predicted_rmse": [0.6, 0.3, 0.2, 0.1], "qmc_equivalent_n": [1, 3, 7, 20],
              "measured_qmc_equivalent_n": [1, 2, 8, 25]}]
    return {"map": "m.exr", "results": entries, "truncation": trunc, "sigma": 0.5,
            "sigma_refined": 0.4, "s": 1.5, "axes": 10, "scale": "linear",
            "config": {"shininess": 30.0},
            "agreement": {"shape_fit": {"constant": {"diffuse": 1.1, "glossy": 1.1}},
                          "s_choice": {}}}


@pytest.fixture
def figures(monkeypatch):
    got = {}

    def record(fig, path, **kw):
        got[str(path).rsplit("/", 1)[-1]] = fig
        return path
    monkeypatch.setattr(PV, "save_figure", record)
    monkeypatch.setattr(PL, "save_figure", record)
    return got


def _whole(values) -> bool:
    v = np.asarray(values, dtype=float)
    return v.size > 0 and np.allclose(v, np.round(v))


def test_absolute_one_figure_per_brdf_predictions_told_apart(result, figures, tmp_path):
    files = PV.plot_all(result, tmp_path)
    assert {"validate_absolute_diffuse.png", "validate_absolute_glossy.png"} <= set(files)
    assert "validate_absolute.png" not in files
    fig = figures["validate_absolute_glossy.png"]
    axes = [ax for ax in fig.axes if ax.get_title()]
    assert len(axes) == 4                                          # 2 weightings x 2 point sets
    assert sorted(ax.get_title() for ax in axes) == ["Random, OSW", "Random, equal weights",
                                                     "Spherical Fibonacci, OSW",
                                                     "Spherical Fibonacci, equal weights"]
    for ax in axes:
        lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == len(N)]
        assert len(lines) == 3
        styles = {(ln.get_color(), ln.get_linestyle(), ln.get_marker()) for ln in lines}
        assert len({s[0] for s in styles}) == 3 and len({s[1] for s in styles}) == 3 \
            and len({s[2] for s in styles}) == 3
        got = sorted(tuple(np.round(ln.get_ydata(), 12)) for ln in lines)
        want = sorted(tuple(np.round(r, 12)) for r in
                      ([1.5] * 4, [1.02, 0.98, 1.0, 1.05], [0.97, 1.01, 0.99, 1.0]))
        assert got == want                                          # predicted / measured
    names = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any(n.startswith("(b)") for n in names) and any(n.startswith("(b′)") for n in names) \
        and any(n.startswith("(c)") for n in names)
    bottom = [ax for ax in axes if ax.get_xlabel()]
    assert [t for t in bottom[0].get_xticks()] == N
    assert [t.get_text() for t in bottom[0].get_xticklabels()] == ["16", "32", "64", "128"]


def test_counting_axes_have_whole_number_ticks(result, figures, tmp_path):
    PV.plot_all(result, tmp_path)
    trunc = figures["validate_truncation.png"]
    main = [ax for ax in trunc.axes if ax.get_xlabel() == "cut-off degree L"][0]
    lo, hi = main.get_xlim()
    assert _whole([t for t in main.get_xticks() if lo <= t <= hi])
    twin = [ax for ax in trunc.axes if "equivalent N" in ax.get_ylabel()][0]
    lo, hi = twin.get_ylim()
    assert _whole([t for t in twin.get_yticks() if lo <= t <= hi])
    quad = figures["validate_quadrature_glossy.png"].axes[0]
    assert list(quad.get_xticks()) == N
    PL.plot_s_histogram([1.21, 1.33, 1.35, 1.8], tmp_path / "h.png",
                        intervals=[(1.1, 1.3), (1.3, 1.4), (1.3, 1.4), (1.7, 1.9)])
    hist, sorted_panel = figures["h.png"].axes
    for ax in (hist, sorted_panel):
        lo, hi = ax.get_ylim()
        ticks = [t for t in ax.get_yticks() if lo <= t <= hi]
        assert _whole(ticks) and len(ticks) >= 2
    PL.plot_s_histogram([1.1, 1.5, 1.5], tmp_path / "g.png", grid=[1.1, 1.5, 1.9])
    ax = figures["g.png"].axes[0]
    lo, hi = ax.get_ylim()
    assert _whole([t for t in ax.get_yticks() if lo <= t <= hi])

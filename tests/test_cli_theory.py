"""Tests of ``envfit theory`` (wce, table1, figures) through ``envfit.cli.main``."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.theory._brdf import Diffuse, Glossy
from envfit.theory._pointsets import generate
from envfit.theory._quadrature import worst_case_error
from envfit.theory._weights import equal_weights, optimal_weights


@pytest.fixture(autouse=True)
def _only_theory(monkeypatch):
    # test this subcommand in isolation from the others (which may be work in progress)
    monkeypatch.setattr(cli, "COMMANDS", ("theory",))


def _a15(lmax):
    l = np.arange(lmax + 1, dtype=float)
    a = 2 * np.pi / ((l - 0.5) * (l + 0.5) * (l + 1.5))
    a[0] = 16 * np.pi / 3
    return a


def test_wce_json_with_spectrum(tmp_path, capsys):
    out = tmp_path / "w.json"
    rc = cli.main(["theory", "wce", "--brdf", "glossy", "--shininess", "20", "--pointset", "sobol",
                   "--weights", "osw", "--n", "128", "--lmax", "24", "--json", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "morphed" in text and "worst-case error E =" in text
    r = json.loads(out.read_text())
    for key in ("wce", "wce_zonal", "wce_anisotropic", "tail", "lmax", "spectrum"):
        assert key in r
    assert r["lmax"] == 24 and r["morphed"] is True
    # independent: the same rule built directly (Sobol, morphed for the lobe, OSW)
    g = Glossy(20.0)
    u = generate("sobol", 128, morph=g.morph)
    assert r["wce"] == pytest.approx(worst_case_error(u, optimal_weights(u, g, 1.5), g, 1.5), rel=1e-10)
    sp = r["spectrum"]
    assert [e["l"] for e in sp] == list(range(25))
    d2, C2, e2 = (np.array([e[k] for e in sp]) for k in ("d2", "C2", "e2"))
    assert np.all(C2 >= 0)
    np.testing.assert_allclose(e2, _a15(24) * (d2 + C2), rtol=1e-12)
    assert sum(e2) + r["tail"] == pytest.approx(r["wce"] ** 2, rel=1e-9)
    assert r["wce_zonal"] ** 2 == pytest.approx(float(np.sum(_a15(24) * d2)), rel=1e-9)


def test_wce_without_lmax_and_no_morph(tmp_path, capsys):
    out = tmp_path / "w.json"
    assert cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "256",
                     "--json", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    r = json.loads(out.read_text())
    assert "spectrum" not in r and r["lmax"] == 256 and r["lmax_automatic"]
    assert r["wce_zonal"] > 0 and r["wce_anisotropic"] > r["wce_zonal"]
    u = generate("sf", 256, morph=Diffuse().morph)
    assert r["wce"] == pytest.approx(worst_case_error(u, equal_weights(256), Diffuse(), 1.5), rel=1e-10)
    # without importance sampling, equal weights integrate the wrong density
    assert cli.main(["theory", "wce", "--brdf", "diffuse", "--pointset", "sf", "--n", "256",
                     "--no-morph", "--json", str(out), "--quiet"]) == 0
    r2 = json.loads(out.read_text())
    assert r2["morphed"] is False and r2["wce"] > 5 * r["wce"]


@pytest.mark.parametrize("argv, word", [
    (["--s", "2.5"], "--s: 2.5 is outside 1 < s < 2"),
    (["--s", "1.0"], "--s: 1.0 is outside 1 < s < 2"),
    (["--n", "0"], "--n"),
    (["--shininess", "-3"], "shininess"),
])
def test_wce_bad_parameters_exit_2_one_line(argv, word, capsys):
    base = ["theory", "wce", "--brdf", "glossy", "--pointset", "random", "--n", "64"]
    assert cli.main(base + argv) == 2
    err = capsys.readouterr().err.strip()
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("envfit theory wce: error:") and word in err
    assert "Traceback" not in err


def test_theory_without_subcommand_prints_help(capsys):
    assert cli.main(["theory"]) == 2
    assert "table1" in capsys.readouterr().out


def test_table1_json(tmp_path, capsys):
    out = tmp_path / "t.json"
    assert cli.main(["theory", "table1", "--json", str(out), "--out", str(tmp_path / "o")]) == 0
    text = capsys.readouterr().out
    assert "paper" in text and "b_3 = 0" in text and "Sec. 8.2" in text
    r = json.loads(out.read_text())
    assert r["target"] == 2.5e-3 and r["s"] == 1.5
    rows = {x["case"]: x for x in r["rows"]}
    assert list(rows) == ["diffuse-sh", "glossy-sh", "glossy-hsh"]
    assert {k: v["L"] for k, v in rows.items()} == {"diffuse-sh": 6, "glossy-sh": 14, "glossy-hsh": 9}
    assert {k: v["L_paper_reading"] for k, v in rows.items()} == {"diffuse-sh": 4, "glossy-sh": 13,
                                                                 "glossy-hsh": 9}
    assert rows["diffuse-sh"]["qmc_points"] == pytest.approx(2000, rel=0.03)
    assert rows["glossy-hsh"]["qmc_points"] == pytest.approx(1000, rel=0.08)
    for v in rows.values():
        E = v["wce_by_L"]
        assert E[v["L"]] <= 2.5e-3 < E[v["L"] - 1]
    assert (tmp_path / "o" / "table1.csv").exists()
    assert r["seconds"] < 30


def test_table1_bad_target(capsys):
    assert cli.main(["theory", "table1", "--target", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()   # argparse: one error line, no usage
    assert err == ["envfit theory table1: error: argument --target: 0 is outside 0.0001 <= E "
                   "<= 1 (see 'envfit theory table1 --help')"]


def test_figures_tiny_writes_pngs_and_csvs(tmp_path, capsys):
    out = tmp_path / "figs"
    js = tmp_path / "f.json"
    rc = cli.main(["theory", "figures", "--n", "32", "--nmax", "32", "--lmax", "12",
                   "--cutoff-max", "4", "--qmc-nmax", "64", "--out", str(out), "--json", str(js),
                   "--quiet"])
    assert rc == 0
    names = {p.name for p in out.iterdir()}
    for stem in ("fig1_power_spectra", "fig2_low_order_C2", "fig3_error_spectra", "fig4_wce_vs_n",
                 "fig5_truncation", "bnot_spectrum"):
        assert f"{stem}.png" in names and f"{stem}.csv" in names
        assert (out / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # CSV: a '#' caption line that states the morphing, then a header
    with open(out / "fig1_power_spectra.csv") as fh:
        first = fh.readline()
        rows = list(csv.DictReader(fh))
    assert first.startswith("#") and "morphed" in first
    assert len(rows) == 2 * 6 * 2 * 13
    assert all(float(r["C2"]) >= 0 for r in rows)
    with open(out / "fig4_wce_vs_n.csv") as fh:
        fh.readline()
        f4 = list(csv.DictReader(fh))
    assert {int(r["n"]) for r in f4} == {16, 32}
    r = json.loads(js.read_text())
    assert r["bnot"]["capacity_ok"] and r["bnot"]["max_relative_area_error"] < 1e-4
    assert len(r["truncation"]["qmc_points"]["glossy-sh"]) == 5
    assert set(r["files"]) == names


def test_figures_only_and_bad_name(tmp_path, capsys):
    out = tmp_path / "f"
    assert cli.main(["theory", "figures", "--only", "5", "--cutoff-max", "3", "--qmc-nmax", "32",
                     "--shininess", "20", "--out", str(out), "--quiet"]) == 0
    assert {p.name for p in out.iterdir()} == {"fig5_truncation.png", "fig5_truncation.csv",
                                              "fig5_qmc_curve.csv"}
    assert cli.main(["theory", "figures", "--only", "7", "--out", str(out)]) == 2
    assert "--only" in capsys.readouterr().err

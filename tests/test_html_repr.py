"""``_repr_html_`` of the result classes (Jupyter's rich display, :mod:`envfit.base._html`).

Every result is built by hand with known field values; its HTML is parsed with the standard
library's :class:`html.parser.HTMLParser` (tags must nest and close), and the cells must
hold the numbers computed here from those fields (4 significant digits), the ratios
(b′)/measured computed here by division, and text with ``<`` escaped.
"""
from __future__ import annotations

from html.parser import HTMLParser

import numpy as np
import pytest

from envfit.advisor._result import Advice, AdviceRow
from envfit.base._html import format_value, html_result
from envfit.batch._library_fit import LibraryFitResult
from envfit.fit._smoothness import FitResult
from envfit.fit._table2 import Table2Cell, Table2Result
from envfit.validate._results import ValidationResult

EVIL = "<sky & sun>.exr"


class _Tables(HTMLParser):
    """Rows of cell texts of every ``<table>``, and a check that every tag closes in order."""

    VOID = {"br", "img", "hr", "meta"}

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.tables, self.text = [], [], []
        self._cell = None

    def handle_starttag(self, tag, attrs):
        if tag not in self.VOID:
            self.stack.append(tag)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes {self.stack[-1:]}"
        self.stack.pop()
        if tag in ("td", "th"):
            self.tables[-1][-1].append("".join(self._cell))
            self._cell = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)


def _parse(html_text: str) -> _Tables:
    p = _Tables()
    p.feed(html_text)
    p.close()
    assert p.stack == [], f"unclosed tags {p.stack}"
    return p


def _fields(p: _Tables) -> dict[str, str]:
    """The (label, value) rows of the first table."""
    return {r[0]: r[1] for r in p.tables[0] if len(r) == 2}


def _g(x) -> str:
    return f"{x:.4g}"


def test_fit_result_html():
    fit = FitResult(s=1.234567, s_interval=(1.2011, 1.2744), sigma=[0.51234, 0.25],
                    method="likelihood", scale="display", n=300, seconds=2.5,
                    notes=["1 pixel < 0 clamped"])
    p = _parse(fit._repr_html_())
    f = _fields(p)
    assert f["s"] == "1.235" == _g(fit.s)
    assert f["95 % interval"] == "1.201, 1.274"
    assert f["sigma per channel"] == "0.5123, 0.25"
    assert f["note"] == "1 pixel < 0 clamped"
    assert "1 pixel &lt; 0 clamped" in fit._repr_html_()


def test_table2_result_html_table_of_rmse():
    rmse = {(1.2, 100): 0.31, (1.2, 400): 0.2123456, (1.8, 100): 0.29, (1.8, 400): 0.2222}
    cells = [Table2Cell(s, n, v, v * 1.1, 1.0, 0.5, 0.5) for (s, n), v in rmse.items()]
    res = Table2Result(EVIL, "display", "", "sf", 0, 16, [1.2, 1.8], [100, 400], cells)
    text = res._repr_html_()
    p = _parse(text)
    header, *rows = p.tables[1]
    assert header == ["s \\ N", "100", "400"]
    assert rows == [["1.2", "0.31", _g(0.2123456)], ["1.8", "0.29", "0.2222"]]
    assert _fields(p)["best s at N = 400"] == "1.2"            # 0.2123 < 0.2222
    assert EVIL in "".join(p.text) and "&lt;sky &amp; sun&gt;" in text and "<sky" not in text


def _advice(rows):
    return Advice(map=EVIL, map_size=[32, 16], channels=3, brdf="diffuse", shininess=None,
                  scale="linear", scale_description="linear", target_rmse=0.005,
                  target_relative=None, mean_shading=0.5, s=1.4321, s_interval=[1.3, 1.5],
                  sigma=0.2468, sigma_channels=[0.2468], fit_source="fit", fit_cached=False,
                  fit_kernel="bandlimited", fit_band_lmax=15, fit_samples=100, band_lmax=15,
                  mean_rms=0.0, rows=rows, recommendation="SH truncation at L = 2 (<= target)")


def test_advice_html_rows_sorted_as_given():
    rows = [AdviceRow("sh", L=2, cost=9, predicted_rmse=0.0031234, measured_rmse=0.0030001),
            AdviceRow("quadrature", "sf", "equal", n=444, cost=444, predicted_rmse=0.0049,
                      predicted_rmse_spectral=0.0047777, predictor="spectral"),
            AdviceRow("hsh", searched_max=64, predicted_rmse=0.3)]
    text = _advice(rows)._repr_html_()
    p = _parse(text)
    f = _fields(p)
    assert f["target RMSE"] == "0.005" and f["s, sigma"] == "1.432, 0.2468"
    assert f["recommendation"] == "SH truncation at L = 2 (<= target)"
    header, *body = p.tables[1]
    assert header[:3] == ["rule", "N / L", "cost"]
    assert body[0] == ["SH", "L = 2", "9", "(b')", _g(0.0031234), _g(0.0030001)]
    assert body[1] == ["sf/equal", "N = 444", "444", "(c)", _g(0.0047777), "–"]   # (c) used
    assert body[2][:3] == ["HSH", "L > 64", "–"]
    assert "&lt;= target" in text and "&lt;sky" in text


def test_validation_result_html_ratios():
    e = {"brdf": "glossy", "pointset": "sf", "weights": "equal", "n": [16, 64],
         "measured_rmse": [0.2, 0.05], "predicted_rmse": [0.3, 0.06],
         "predicted_rmse_refined": [0.21, 0.0512345], "predicted_rmse_spectral": [0.19, None]}
    res = ValidationResult(map=EVIL, map_size=[32, 16], channels=3, s=1.5, sigma=0.25,
                           sigma_channels=[0.25], s_refined=1.45, sigma_refined=0.3,
                           sigma_refined_channels=[0.3], fit_refined={}, lookup_transfer=[],
                           scale="linear", scale_description="", fit={}, config={},
                           quick_description=None, axes=200, seed=0, results=[e])
    p = _parse(res._repr_html_())
    header, row = p.tables[1]
    assert header[-3:] == ["(b)/measured", "(b')/measured", "(c)/measured"]
    assert row == ["glossy", "sf", "equal", "64", "0.05", _g(0.06 / 0.05),
                   _g(0.0512345 / 0.05), "–"]
    assert _fields(p)["s', sigma' (b', band-limited)"] == "1.45, 0.3"


def test_library_result_html_summary():
    fits = [FitResult(s=s, s_interval=(s - 0.05, s + 0.05), sigma=[0.1 * s], method="loo",
                      scale="display", n=500) for s in (1.25, 1.625)]
    lib = LibraryFitResult(labels=["a", EVIL], slugs=["a", "b"], scale="display",
                           pointset="sf", seed=0, fits=fits, method="loo", n=500,
                           factorizations=27)
    text = lib._repr_html_()
    p = _parse(text)
    assert _fields(p)["factorisations"] == "27"
    header, *rows = p.tables[1]
    assert header == ["slug", "map", "s", "s_low", "s_high", "sigma"]
    assert rows[1] == ["b", EVIL, "1.625", _g(1.575), _g(1.675), _g(0.1625)]
    assert "LibraryFitResult: 2 maps" in "".join(p.text)


@pytest.mark.parametrize("value, text", [(None, "–"), (np.float32(0.5), "0.5"), (7, "7"),
                                         (np.int64(3), "3"), (float("nan"), "nan"),
                                         ((1, 2.25), "1, 2.25"), (np.arange(3.0), "0, 1, 2")])
def test_format_value(value, text):
    assert format_value(value) == text


def test_long_tables_are_truncated_with_a_count():
    p = _parse(html_result("t", [], (["k"], [[k] for k in range(25)]), max_rows=20))
    body = p.tables[0][1:]
    assert [r[0] for r in body[:20]] == [str(k) for k in range(20)]
    assert body[-1] == ["… 5 more rows"]

r"""Which prediction sizes a row: (b′) "bandlimited" or (c) "spectral", and the warning when they
disagree.

(b′) (:func:`envfit.predict.predict_bandlimited`) is a Sobolev model fitted to the
map, :math:`\hat R_{b'}^2 = \sigma'^2\sum_{l\le H-1} a_l(s')\tau_l e_l + (\sum w-1)^2
\overline{m^2}`; (c) (:func:`envfit.predict.predict_spectral` on the map's power to 2H − 1,
:meth:`envfit.advisor._model.MapModel.context`) is the map's own power per degree
times the rule's error power, :math:`\hat R_c^2 = \frac1C\sum_c\sum_{l\le 2H-1}\hat P_{l,c}e_l`,
the exact mean over Haar-random rotations for the interpolant's content to 2H − 1. On linear
HDR maps with a sun (a heavy-tailed field, not of the :math:`l^{-2s}` model) (b′) is off by
an order of magnitude (predicted/measured median 0.03 in ``envfit validate``) while (c) is right
on average, so with ``predictor="auto"``:

* on the ``linear`` scale (what a renderer integrates) the row is sized by (c);
* on ``display``/``log`` the row is sized by (b′) unless :math:`r = \hat R_c/\hat R_{b'}` at
  the N (or L) that (b′) chose is outside :math:`[1/D, D]`, D = :data:`DISAGREEMENT` = 1.25;
  then it is sized again by (c);
* whenever r is outside that range at the chosen N/L the row carries the line
  ``rule X: (b′) and (c) disagree (ratio r at N = n); using (c)`` (the CLI prints it as a
  ``warning:`` line).

``predictor="bandlimited"`` or ``"spectral"`` forces one (the ratio is still reported, with
no switch and no warning). HSH truncation has no (c) here (its projection is not diagonal
in l): (b′) only — and with ``"auto"`` a glossy HSH row is not sized where (b′) and (c) of SH
truncation disagree at its L (the model fails there, and nothing else predicts HSH).

Example
-------
>>> first_predictor("auto", "linear"), first_predictor("auto", "display")
('spectral', 'bandlimited')
>>> disagree(1.0, 1.3), disagree(1.0, 0.81), disagree(1.0, 0.79)
(True, False, True)
>>> disagreement_line("sf/equal", 0.031, "N = 400")
'rule sf/equal: (b′) and (c) disagree (ratio 0.031 at N = 400); using (c)'
"""
from __future__ import annotations

__all__ = ["DISAGREEMENT", "first_predictor", "disagree", "disagreement_line", "ratio"]

#: (b′) and (c) disagree when their ratio is outside [1/D, D]
DISAGREEMENT = 1.25


def first_predictor(choice: str, scale: str) -> str:
    """The predictor a row is searched with first: the forced one, else "spectral" on the
    linear scale and "bandlimited" on the others."""
    if choice in ("bandlimited", "spectral"):
        return choice
    return "spectral" if scale == "linear" else "bandlimited"


def ratio(bandlimited: float | None, spectral: float | None) -> float | None:
    r""":math:`\hat R_c / \hat R_{b'}`; None when either is unknown, inf when only (b′) is 0.

    >>> ratio(2.0, 1.0), ratio(0.0, 1.0), ratio(None, 1.0)
    (0.5, inf, None)
    """
    if bandlimited is None or spectral is None:
        return None
    if bandlimited <= 0.0:
        return 1.0 if spectral <= 0.0 else float("inf")
    return spectral / bandlimited


def disagree(bandlimited: float | None, spectral: float | None,
             factor: float = DISAGREEMENT) -> bool:
    """Whether (b′) and (c) differ by more than ``factor`` (either way)."""
    r = ratio(bandlimited, spectral)
    return r is not None and not (1.0 / factor <= r <= factor)


def disagreement_line(label: str, r: float, setting: str) -> str:
    """The row's warning: ``rule X: (b′) and (c) disagree (ratio r at N = n); using (c)``
    (``setting`` "N = n" or "L = n")."""
    return f"rule {label}: (b′) and (c) disagree (ratio {r:.3g} at {setting}); using (c)"

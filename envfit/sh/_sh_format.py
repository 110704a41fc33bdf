r"""Text forms of :class:`envfit.sh._sh_export.SHCoefficients` for engines: CSV and GLSL.

* :func:`to_csv` — one row per coefficient: ``l, m, index`` and one column per channel
  (``R, G, B`` or ``Y``).
* :func:`to_glsl` — ``const vecC shCoefficients[(L+1)^2]`` (9 significant digits), a generic
  ``shEval(vec3 n)`` (the normalised recurrences of
  :func:`envfit.sh._sh_export.real_sh_basis`, any L, float arithmetic), and for L ≥ 2
  ``shIrradianceRH(vec3 n)``: Ramamoorthi & Hanrahan 2001 Eq. 13 with their constants
  c1…c5 (:data:`envfit.sh._sh_export.RH_CONSTANTS`) on the 9 radiance coefficients
  (``shRadiance9``; for a radiance export the first 9 of ``shCoefficients``).

The JSON form (with the predicted errors) is built by :mod:`envfit.sh._ringing`.
"""
from __future__ import annotations

import io
import csv

import numpy as np

from envfit.base import ParameterError
from envfit.sh._sh_export import NORMALISATION, ORDERING, RH_CONSTANTS, SHCoefficients

__all__ = ["to_csv", "to_glsl", "signed_coefficients", "GLSL_TYPES"]

#: channels → GLSL type
GLSL_TYPES = {1: "float", 2: "vec2", 3: "vec3", 4: "vec4"}


def signed_coefficients(sh: SHCoefficients, which: str = "coefficients") -> np.ndarray:
    """``sh.coefficients`` (or ``sh.radiance``) with the odd-m signs of the Condon–Shortley
    phase applied when ``sh.condon_shortley``."""
    c = np.asarray(getattr(sh, which), dtype=np.float64)
    if sh.condon_shortley:
        c = c * np.where(sh.orders % 2 == 1, -1.0, 1.0)[:, None]
    return c


def to_csv(sh: SHCoefficients) -> str:
    """CSV text: header ``l,m,index,<channels>``, (L+1)² rows, 17 significant digits.

    >>> from envfit.maps._envmap import EnvMap
    >>> from envfit.sh._sh_export import sh_coefficients
    >>> print(to_csv(sh_coefficients(EnvMap(np.ones((4, 8, 1))), 0))[:27])   # √(4π)
    l,m,index,Y
    0,0,0,3.5449077
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["l", "m", "index", *sh.channels])
    c = signed_coefficients(sh)
    for i, (l, m) in enumerate(zip(sh.degrees, sh.orders)):
        w.writerow([int(l), int(m), i, *(repr(float(v)) for v in c[i])])
    return buf.getvalue()


def _literal(v: float) -> str:
    return f"{float(v):.9e}"


def _array(name: str, values: np.ndarray, degrees, orders) -> list[str]:
    c = values.shape[1]
    t = GLSL_TYPES.get(c)
    if t is None:
        raise ParameterError(f"GLSL output takes 1 to 4 channels, the map has {c}")
    n = values.shape[0]
    lines = [f"const {t} {name}[{n}] = {t}[{n}]("]
    for i, row in enumerate(values):
        body = ", ".join(_literal(v) for v in row)
        item = body if c == 1 else f"{t}({body})"
        lines.append(f"    {item}{',' if i < n - 1 else ''}   // {i}: l {degrees[i]}, m {orders[i]}")
    return lines + [");"]


_EVAL = """\
// Real orthonormal SH, no Condon-Shortley phase, index l(l+1)+m; n: unit vector in the
// map's world axes. Normalised recurrences in z, (x + iy)^m for the azimuth.
{t} shEval(vec3 n) {{
    {t} sum = {t}(0.0);
    float qmm = 0.28209479177387814;           // Q_0^0 = 1/sqrt(4 pi)
    float re = 1.0, im = 0.0;                   // Re, Im of (x + iy)^m
    for (int m = 0; m <= SH_LMAX; ++m) {{
        if (m > 0) {{
            qmm *= sqrt(float(2 * m + 1) / float(2 * m));
            float r2 = re * n.x - im * n.y;
            im = re * n.y + im * n.x;
            re = r2;
        }}
        float q2 = 0.0, q1 = qmm;
        for (int l = m; l <= SH_LMAX; ++l) {{
            if (l == m + 1) {{
                q2 = q1; q1 = sqrt(float(2 * m + 3)) * n.z * qmm;
            }} else if (l > m + 1) {{
                float a = sqrt(float(4 * l * l - 1) / float(l * l - m * m));
                float b = sqrt(float((l - 1) * (l - 1) - m * m) / float(4 * (l - 1) * (l - 1) - 1));
                float q = a * (n.z * q1 - b * q2);
                q2 = q1; q1 = q;
            }}
            int i = l * (l + 1);
            if (m == 0) {{
                sum += shCoefficients[i] * q1;
            }} else {{
                sum += shCoefficients[i + m] * (1.41421356237 * q1 * re);
                sum += shCoefficients[i - m] * (1.41421356237 * q1 * im);
            }}
        }}
    }}
    return sum;
}}
"""

_RH = """\
// Ramamoorthi & Hanrahan 2001, Eq. 13: irradiance from the 9 radiance coefficients L_lm.
const float SH_C1 = {c1}, SH_C2 = {c2}, SH_C3 = {c3}, SH_C4 = {c4}, SH_C5 = {c5};
{t} shIrradianceRH(vec3 n) {{
    {t} L00 = {a}[0], L1m1 = {a}[1], L10 = {a}[2], L11 = {a}[3], L2m2 = {a}[4],
        L2m1 = {a}[5], L20 = {a}[6], L21 = {a}[7], L22 = {a}[8];
    return SH_C1 * L22 * (n.x * n.x - n.y * n.y) + SH_C3 * L20 * n.z * n.z + SH_C4 * L00
         - SH_C5 * L20 + 2.0 * SH_C1 * (L2m2 * n.x * n.y + L21 * n.x * n.z + L2m1 * n.y * n.z)
         + 2.0 * SH_C2 * (L11 * n.x + L1m1 * n.y + L10 * n.z);
}}
"""


def to_glsl(sh: SHCoefficients, comments=()) -> str:
    """GLSL source (module docstring); ``comments``: lines put first as ``//`` comments.
    Always in this module's basis (no Condon–Shortley phase, whatever
    ``sh.condon_shortley``): the array and ``shEval`` agree.

    >>> from envfit.maps._envmap import EnvMap
    >>> from envfit.sh._sh_export import sh_coefficients
    >>> src = to_glsl(sh_coefficients(EnvMap(np.ones((8, 16, 3))), 2))
    >>> "const vec3 shCoefficients[9]" in src, "shIrradianceRH" in src
    (True, True)
    """
    c = np.asarray(sh.coefficients, dtype=np.float64)
    t = GLSL_TYPES.get(c.shape[1], "float")
    deg, order = sh.degrees.tolist(), sh.orders.tolist()
    kind = "irradiance E_lm = A_l L_lm" if sh.irradiance else "radiance L_lm"
    lines = [f"// {x}" for x in comments] + [
        f"// basis: {NORMALISATION}", f"// ordering: {ORDERING}",
        f"// {kind}, window {sh.window}, world axes: +{sh.up} up", "",
        f"const int SH_LMAX = {sh.lmax};"]
    lines += _array("shCoefficients", c, deg, order) + ["", _EVAL.format(t=t)]
    if sh.lmax >= 2:
        rad = "shCoefficients"
        if sh.irradiance:
            rad = "shRadiance9"
            lines += _array(rad, np.asarray(sh.radiance)[:9], deg, order) + [""]
        cons = {k: _literal(v) for k, v in RH_CONSTANTS.items()}
        lines.append(_RH.format(t=t, a=rad, **cons))
    return "\n".join(lines)

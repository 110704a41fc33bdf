r"""Exact power diagrams on the flat torus :math:`T = [0,1)^2`, the geometry under BNOT
(:mod:`envfit.theory._bnot`).

For sites :math:`x_1…x_n \in T` and weights :math:`w_1…w_n` the power cell of site i is
:math:`V_i^w = \{x \in T : |x - x_i|_T^2 - w_i \le |x - x_j|_T^2 - w_j \;\forall j\}`.

Power diagrams are computed exactly: the sites and their periodic copies are lifted to
:math:`(x, y, |p|^2 - w)`; the lower convex hull (``scipy.spatial.ConvexHull``, Qhull)
projects to the regular triangulation, whose dual is the power diagram. Each cell is the
polygon of the power centres of the triangles around its site, in fan order. Only copies
within a margin of the unit square are lifted; a certificate (every cell vertex is closer,
in the power distance, to its own site than to any copy left out) is checked and the
computation falls back to all 3×3 copies if it fails, so the result is exact either way.

>>> import numpy as np
>>> pd = power_diagram(np.random.default_rng(0).random((50, 2)))
>>> bool(abs(pd.areas.sum() - 1.0) < 1e-12)
True
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from envfit.theory._errors import TheoryParameterError

__all__ = ["PowerDiagram", "power_diagram"]

_OFFSETS = np.array([(0, 0), (-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0),
                     (1, 1)], dtype=np.float64)


def _check_sites(sites) -> np.ndarray:
    x = np.asarray(sites, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 2 or x.shape[0] < 1:
        raise TheoryParameterError(f"sites must be an (n, 2) array with n >= 1, got shape "
                                   f"{x.shape}")
    if not np.all(np.isfinite(x)):
        raise TheoryParameterError("sites must be finite")
    return _wrap(x)


def _wrap(x: np.ndarray) -> np.ndarray:
    """Wrap into [0, 1) (``np.mod`` can round -1e-17 up to exactly 1.0)."""
    y = np.mod(x, 1.0)
    y[y >= 1.0] = 0.0
    return y


def _check_weights(weights, n: int) -> np.ndarray:
    if weights is None:
        return np.zeros(n)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.shape != (n,):
        raise TheoryParameterError(f"weights must have shape ({n},), got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise TheoryParameterError("weights must be finite")
    return w - w.mean()  # a power diagram is invariant to a common shift of the weights


def _toroidal_delta(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = a - b
    return d - np.round(d)


# ----------------------------------------------------------------------------- diagram
@dataclass(frozen=True)
class PowerDiagram:
    r"""A power diagram on the flat torus [0,1)².

    Attributes
    ----------
    sites, weights : (n, 2), (n,) — the input (sites wrapped into [0,1)², weights shifted
        to zero mean, which leaves the diagram unchanged).
    areas : (n,) — :math:`|V_i^w|`; they sum to 1 (the cells tile the torus); 0 for a
        hidden (empty) cell.
    centroids : (n, 2) — cell centroids wrapped into [0,1)² (the site itself for an
        empty cell).
    second_moments : (n,) — :math:`\int_{V_i} |x - x_i|^2 dx` (the transport cost of cell i).
    cell_vertices : (V, 2) and cell_offsets : (n+1,) — the polygon of cell i is
        ``cell_vertices[cell_offsets[i]:cell_offsets[i+1]]``, counter-clockwise, in the
        unrolled plane (coordinates near ``sites[i]``, possibly outside the unit square).
    edges : (E, 2) int — pairs (i, j) of original site indices whose cells share an edge,
        one row per (directed) adjacency seen from cell i; ``edge_lengths`` (E,) the length
        of that common edge and ``edge_distances`` (E,) the distance between site i and
        the copy of site j across it.
    margin : the width of the band of periodic copies that was used (1.0 = all 3×3).
    """
    sites: np.ndarray
    weights: np.ndarray
    areas: np.ndarray
    centroids: np.ndarray
    second_moments: np.ndarray
    cell_vertices: np.ndarray
    cell_offsets: np.ndarray
    edges: np.ndarray
    edge_lengths: np.ndarray
    edge_distances: np.ndarray
    margin: float

    @property
    def n(self) -> int:
        return self.sites.shape[0]

    def polygon(self, i: int) -> np.ndarray:
        """Vertices (k, 2) of cell i, counter-clockwise, in the unrolled plane."""
        return self.cell_vertices[self.cell_offsets[i]:self.cell_offsets[i + 1]]

    @property
    def polygons(self) -> list:
        """All cells as a list of (k_i, 2) arrays (see :meth:`polygon`)."""
        return [self.polygon(i) for i in range(self.n)]

    def area_jacobian(self) -> sp.csr_matrix:
        r"""Sparse :math:`J_{ij} = \partial |V_i| / \partial w_j` (a graph Laplacian).

        Off-diagonal :math:`-\ell_{ij}/(2|x_i-x_j|)`, diagonal the negated row sum, so
        rows sum to zero (a common weight shift changes nothing). It is the negated
        Hessian of the concave OT dual function g(w).
        """
        n = self.n
        i, j = self.edges[:, 0], self.edges[:, 1]
        c = self.edge_lengths / (2.0 * self.edge_distances)
        rows = np.concatenate([i, i])
        cols = np.concatenate([j, i])
        vals = np.concatenate([-c, c])
        return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def _padded_copies(x: np.ndarray, margin: float):
    """Copies of the sites within [-margin, 1+margin]², originals first."""
    n = x.shape[0]
    if margin >= 1.0:
        pts = (x[None, :, :] + _OFFSETS[:, None, :]).reshape(-1, 2)
        orig = np.tile(np.arange(n), 9)
        return pts, orig
    parts, origs = [x], [np.arange(n)]
    for t in _OFFSETS[1:]:
        y = x + t
        keep = np.all((y >= -margin) & (y <= 1.0 + margin), axis=1)
        parts.append(y[keep])
        origs.append(np.nonzero(keep)[0])
    return np.concatenate(parts), np.concatenate(origs)


def _power_centres(p: np.ndarray, w: np.ndarray, tri: np.ndarray, eq: np.ndarray):
    """Power centres (orthocentres) of the triangles ``tri`` of points p with weights w.

    Solves 2(p_b-p_a)·q = |p_b-p_a|² - w_b + w_a, 2(p_c-p_a)·q = … for q = c - p_a
    (Cramer). A (Qhull-triangulated) degenerate triangle falls back to the facet's plane
    z = 2c·p + const of the lifted points.
    """
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    u, v = b - a, c - a
    ru = 0.5 * (np.einsum("ij,ij->i", u, u) - w[tri[:, 1]] + w[tri[:, 0]])
    rv = 0.5 * (np.einsum("ij,ij->i", v, v) - w[tri[:, 2]] + w[tri[:, 0]])
    det = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    scale = np.einsum("ij,ij->i", u, u) + np.einsum("ij,ij->i", v, v)
    good = np.abs(det) > 1e-12 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        qx = (ru * v[:, 1] - rv * u[:, 1]) / det
        qy = (u[:, 0] * rv - v[:, 0] * ru) / det
    cen = a + np.stack([qx, qy], axis=1)
    if not np.all(good):
        bad = ~good
        # plane a1 x + a2 y + a3 z + b = 0 of the lifted points, z = |p|^2 - w
        cen[bad] = -eq[bad, :2] / (2.0 * eq[bad, 2:3])
    return cen


def _diagram_from_copies(x, w, margin):
    """The power diagram from the sites' copies within ``margin``, or None when the copies
    left out could cut a cell (the caller then retries with all 3×3 copies)."""
    n = x.shape[0]
    hull = _lower_hull(x, w, margin)
    if hull is None:
        return None
    pts, orig, tri, cen, nbr, ea, eb = hull
    verts, rel, vv, offsets, areas, crel, smom = _cell_polygons(x, pts, tri, cen)
    if margin < 1.0 and verts.size and not _certificate_holds(verts, rel, vv, w, margin):
        return None
    edges, lengths, dists = _dual_edges(n, pts, orig, cen, nbr, ea, eb)
    return PowerDiagram(sites=x, weights=w, areas=areas,
                        centroids=_wrap(x + crel), second_moments=smom,
                        cell_vertices=verts, cell_offsets=offsets, edges=edges,
                        edge_lengths=lengths, edge_distances=dists, margin=float(margin))


def _lower_hull(x, w, margin):
    """Lift the copies to (p, |p|² − w); the lower hull's facets are the regular
    triangulation. Returns (copies, their originals, lower triangles, power centres, facet
    neighbours, the two edge-vertex index arrays), or None if an original site's star is open."""
    n = x.shape[0]
    pts, orig = _padded_copies(x, margin)
    wp = w[orig]
    centre = pts - 0.5  # better conditioning of the lifted heights
    lifted = np.column_stack([centre, np.einsum("ij,ij->i", centre, centre) - wp])
    from scipy.spatial import ConvexHull  # local: scipy.spatial is slow to import

    hull = ConvexHull(lifted)
    eq = hull.equations
    fidx = np.nonzero(eq[:, 2] < -1e-12)[0]
    tri = hull.simplices[fidx]
    cen = _power_centres(centre, wp, tri, eq[fidx]) + 0.5
    # facet adjacency restricted to lower facets; open stars of original sites => invalid
    pos = np.full(eq.shape[0], -1, dtype=np.int64)
    pos[fidx] = np.arange(tri.shape[0])
    nbr = pos[hull.neighbors[fidx]]                    # (nf, 3), -1 where not lower
    ea = tri[:, [1, 2, 0]]                             # edge opposite vertex k: (k+1, k+2)
    eb = tri[:, [2, 0, 1]]
    if np.any((nbr < 0) & ((ea < n) | (eb < n))):
        return None
    return pts, orig, tri, cen, nbr, ea, eb


def _cell_polygons(x, pts, tri, cen):
    """Each original site's cell as the fan-ordered power centres around it, with its area,
    centroid offset and second moment (shoelace formulas)."""
    n = x.shape[0]
    nf = tri.shape[0]
    vv = tri.reshape(-1)
    ff = np.repeat(np.arange(nf), 3)
    keep = vv < n
    vv, ff = vv[keep], ff[keep]
    tcent = (pts[tri[:, 0]] + pts[tri[:, 1]] + pts[tri[:, 2]]) / 3.0
    d = tcent[ff] - x[vv]
    order = np.lexsort((np.arctan2(d[:, 1], d[:, 0]), vv))
    vv, ff = vv[order], ff[order]
    counts = np.bincount(vv, minlength=n)
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    verts = cen[ff]
    rel = verts - x[vv]
    nxt = np.arange(vv.size) + 1
    last = offsets[1:][counts > 0] - 1
    nxt[last] = offsets[:-1][counts > 0]
    rn = rel[nxt]
    cross = rel[:, 0] * rn[:, 1] - rn[:, 0] * rel[:, 1]
    areas = 0.5 * np.bincount(vv, weights=cross, minlength=n)
    mx = np.bincount(vv, weights=(rel[:, 0] + rn[:, 0]) * cross, minlength=n)
    my = np.bincount(vv, weights=(rel[:, 1] + rn[:, 1]) * cross, minlength=n)
    with np.errstate(divide="ignore", invalid="ignore"):
        crel = np.stack([mx, my], axis=1) / (6.0 * areas[:, None])
    smom = np.bincount(vv, weights=cross * (rel[:, 0] ** 2 + rel[:, 0] * rn[:, 0] + rn[:, 0] ** 2
                                            + rel[:, 1] ** 2 + rel[:, 1] * rn[:, 1]
                                            + rn[:, 1] ** 2), minlength=n) / 12.0
    empty = ~(areas > 0)
    crel[empty] = 0.0
    areas[empty] = 0.0
    smom[empty] = 0.0
    return verts, rel, vv, offsets, areas, crel, smom


def _certificate_holds(verts, rel, vv, w, margin) -> bool:
    """Copies outside the band cannot cut any cell: every cell vertex is closer, in the
    power distance, to its own site than to any copy left out."""
    powv = np.einsum("ij,ij->i", rel, rel) - w[vv]
    dist = np.minimum.reduce([verts[:, 0] + margin, 1.0 + margin - verts[:, 0],
                              verts[:, 1] + margin, 1.0 + margin - verts[:, 1]])
    return not (np.any(dist <= 0) or np.any(dist ** 2 - w.max() < powv + 1e-12))


def _dual_edges(n, pts, orig, cen, nbr, ea, eb):
    """Directed adjacency i -> j (i original, j any site) with the common edge's length and
    the sites' distance: both facets across the edge are lower."""
    nf = nbr.shape[0]
    fa = np.repeat(np.arange(nf), 3)
    fb = nbr.reshape(-1)
    a_, b_ = ea.reshape(-1), eb.reshape(-1)
    sel = fb >= 0
    fa, fb, a_, b_ = fa[sel], fb[sel], a_[sel], b_[sel]
    length = np.linalg.norm(cen[fa] - cen[fb], axis=1)
    # each geometric edge appears once from each side (fa, fb) and (fb, fa); for the
    # directed adjacency "i -> j" keep, per side, the rows whose first vertex is original
    rows_i, rows_j, lens, dists = [], [], [], []
    for s, t in ((a_, b_), (b_, a_)):
        m = (s < n) & (fa < fb)
        rows_i.append(s[m])
        rows_j.append(orig[t[m]])
        lens.append(length[m])
        dists.append(np.linalg.norm(pts[s[m]] - pts[t[m]], axis=1))
    edges = np.stack([np.concatenate(rows_i), np.concatenate(rows_j)], axis=1)
    return edges, np.concatenate(lens), np.concatenate(dists)


def _default_margin(n: int, w: np.ndarray) -> float:
    # cells have diameter ~ 1/√n; weights shift bisectors by up to ~ sqrt(ptp w)
    return min(1.0, 4.0 / np.sqrt(n) + np.sqrt(np.ptp(w)))


def power_diagram(sites, weights=None, *, margin: float | None = None) -> PowerDiagram:
    r"""Exact power diagram of weighted sites on the flat torus [0,1)².

    Cell i is :math:`\{x : |x-x_i|_T^2 - w_i \le |x-x_j|_T^2 - w_j\ \forall j\}`
    (de Goes et al. 2012, Eq. 2; with w = 0 it is the periodic Voronoi diagram). Computed
    as the dual of the regular triangulation (lower convex hull of the lifted periodic
    copies :math:`(p, |p|^2 - w)`), with a certificate that the copies left out of the
    band ``margin`` around the square cannot change any cell (else all 3×3 copies).

    Parameters
    ----------
    sites : (n, 2) array — wrapped into [0,1)².
    weights : (n,) array or None (zeros).
    margin : width of the band of periodic copies to start with; default
        min(1, 4/√n + √(max w − min w)).

    Returns
    -------
    PowerDiagram — areas, centroids, cell polygons, dual edges (see its docstring).

    Examples
    --------
    >>> import numpy as np
    >>> pd = power_diagram(np.random.default_rng(0).random((50, 2)))
    >>> bool(abs(pd.areas.sum() - 1.0) < 1e-12)
    True
    """
    x = _check_sites(sites)
    n = x.shape[0]
    w = _check_weights(weights, n)
    m = _default_margin(n, w) if margin is None else float(margin)
    if not (m > 0):
        raise TheoryParameterError(f"margin must be > 0, got {margin!r}")
    for mm in ((m, 1.0) if m < 1.0 else (1.0,)):
        pd = _diagram_from_copies(x, w, mm)
        if pd is not None:
            return pd
    raise TheoryParameterError(  # pragma: no cover - needs weights far beyond the torus
        "power diagram: the weights are too spread for 3×3 periodic copies "
        f"(max |w| = {np.abs(w).max():.3g})")

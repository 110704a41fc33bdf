"""The frame's net model under a renderer that importance-samples its pixel filter (Cycles'
Blackman–Harris 1.5 px): each pixel's converged value is its film's mean under the filter's
density, reaching 0.25 px into the neighbours, and its error follows the renderer's own
points through the filter's warp.

The scene is analytic (no renderer needed): a diffuse plane z = 0 seen straight down by an
orthographic camera, its albedo a function of the film's x, under a small map. Its pixel
values are checked against a dense quadrature of the albedo under the filter's density
(independent of the model's cells), and its error against a direct simulation of the
estimator over Cycles' own points with the integrand evaluated at each sample's own film
position."""
import math

import numpy as np
import pytest

from envfit.frame._nets import cell_weights, film_span, pixel_mse_nets
from envfit.frame._model import _Techniques, film_block
from envfit.maps import EnvMap
from envfit.renderers import BOX_FILTER, FrameScene, HIT_SURFACE, get_renderer
from envfit.renderers._frame import Occluder, TwoLobes
from envfit.renderers.cycles._film import film_warp

W, H, K = 6, 4, 0.5               # pixels; world units per pixel


def _albedo(x):
    """The plane's albedo at film x (pixels): a staircase on half pixels (constant in each
    of the model's film cells, so that the model's cells hold it exactly: what is checked
    is the filter's warp, the cells' weights and the kernel, not the variation inside a
    cell, which the model leaves out) rising 0.05 a step, with a jump of 0.3 between
    pixels 2 and 3."""
    c = np.floor(np.asarray(x) * 2.0) / 2.0 + 0.25
    return 0.2 + 0.1 * c + 0.3 * (c >= 3.0)


def _Layered(alpha):
    """A two-lobe BSDF as the readers give it: a GGX dielectric layer over a Lambert base."""
    from envfit.shading.microfacet import AlbedoLayered
    return TwoLobes(AlbedoLayered(alpha))


def _scene(warp, sampler="tabulated_sobol", bsdfs=()) -> FrameScene:
    rec = get_renderer("cycles")
    rng = np.random.default_rng(5)
    data = 0.5 + rng.random((8, 16, 3))

    def hits(xy):
        xy = np.asarray(xy, float)
        p = len(xy)
        n = np.tile([0.0, 0.0, 1.0], (p, 1))
        return {"kind": np.full(p, HIT_SURFACE, np.int8),
                "position": np.column_stack([xy[:, 0] * K, -xy[:, 1] * K, np.zeros(p)]),
                "normal": n, "geo_normal": n, "tangent": rec.tangent_frame(n),
                "wi": np.tile([0.0, 0.0, 1.0], (p, 1)),
                "albedo": np.repeat(_albedo(xy[:, 0])[:, None], 3, axis=1),
                "facing": np.ones(p, bool), "shape": np.zeros(p, np.int64),
                "background": np.zeros((p, 3))}

    def rays(xy):
        xy = np.asarray(xy, float)
        o = np.column_stack([xy[:, 0] * K, -xy[:, 1] * K, np.full(len(xy), 10.0)])
        return o, np.tile([0.0, 0.0, -1.0], (len(xy), 1))

    big = 100.0
    plane = Occluder("plane", np.array([[-big, -big, 0], [big, -big, 0], [big, big, 0],
                                        [-big, big, 0]], float),
                     np.array([[0, 1, 2], [0, 2, 3]]), True)
    return FrameScene("plane.blend", "cycles", (W, H), (plane,), data, np.eye(3), 1.0,
                      sampler, 16, "path", 1, 1, 2, "blackman_harris", 0.75,
                      lambda x: np.ones_like(x), hits, rays, draws=(1, 2), film_warp=warp,
                      bsdfs=bsdfs)


def test_span_and_cell_weights_are_the_filters():
    warp = film_warp("blackman_harris", 1.5)
    fs = _scene(warp)
    lo, size = film_span(fs)
    u = (np.arange(1 << 20) + 0.5) / (1 << 20)
    x = warp.offset(u) + 0.5                            # from the pixel's corner
    assert (lo, size) == (-0.5, 2.0)                    # ±1 px: 98.7 % of the samples
    assert 0.98 <= np.mean((x >= lo) & (x < lo + size)) < 0.99
    assert np.mean(np.abs(x - 0.5) <= 1.5 + 1e-6) == 1.0   # the table: ±1.5 px
    w = cell_weights(fs, 4)
    edges = lo + size * np.arange(5) / 4
    direct = np.histogram(np.clip(x, lo, lo + size - 1e-9), bins=edges)[0] / len(u)
    assert w.sum() == pytest.approx(1.0) and np.allclose(w, direct, atol=1e-4)
    assert np.allclose(cell_weights(_scene(BOX_FILTER), 4), 0.25)
    assert film_span(_scene(BOX_FILTER)) == (0.0, 1.0)


def _irradiance_over_pi(fs) -> np.ndarray:
    """E/π of the plane (normal +z) from the map: a direct quadrature of the map's radiance
    times cos θ over the upper hemisphere, in the technique's native frame."""
    rec = get_renderer("cycles")
    tech = rec.technique(EnvMap(fs.envmap_data))
    m = 2048
    u, v = np.meshgrid((np.arange(m) + 0.5) / m, (np.arange(m) + 0.5) / m, indexing="ij")
    z, phi = u.ravel(), 2 * np.pi * v.ravel()        # uniform on the hemisphere
    r = np.sqrt(1 - z * z)
    d = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    rad = np.asarray(tech.eval_unit(d), float)
    return (rad * z[:, None]).mean(axis=0) * 2 * np.pi / np.pi


def test_converged_pixels_are_the_filtered_film():
    warp = film_warp("blackman_harris", 1.5)
    fs = _scene(warp)
    pixels = np.array([[1, x] for x in range(1, 5)])
    block = film_block(fs, pixels, 2)
    value, mse, _, _ = pixel_mse_nets(fs, block, pixels, [16], level=4, seed=1)
    u = (np.arange(1 << 18) + 0.5) / (1 << 18)
    e = _irradiance_over_pi(fs)
    for k, (_, x) in enumerate(pixels):
        rho = _albedo(x + 0.5 + warp.offset(u)).mean()     # the albedo under the filter
        # cells of 0.5 px hold their midpoint's albedo: the ramp is exact, the jump is not
        assert np.allclose(value[k], rho * e, rtol=0.04), (x, value[k], rho * e)
    box = _scene(BOX_FILTER)
    vb, _, _, _ = pixel_mse_nets(box, film_block(box, pixels, 2), pixels, [16], 4, 1)
    # pixel 2 sees its neighbour's jump through the filter (12 % of its samples), not the box
    assert value[1].mean() > 1.05 * vb[1].mean()


def _simulated(fs, n: int, level: int, warp, x0: float):
    """The MSE of pixel (1, x0) simulated directly over the model's own points (the same R
    pixels of Cycles' Tabulated Sobol, :func:`envfit.frame._nets.scrambles` of them, seed 2):
    each sample's albedo at its own warped film position, its emitter sample and its BSDF
    sample read from the techniques' tables at ``level`` for the plane's normal, the BSDF's
    table the one of the lobe its request's z picks (z < p: lobe 0); the truth the albedo's
    mean under the filter times the tables' means."""
    from envfit.frame._nets import scrambles
    tq = _Techniques(fs, level)
    up = np.array([[0.0, 0.0, 1.0]])
    frame = get_renderer("cycles").tangent_frame(up)
    if fs.bsdfs and fs.bsdfs[0].lobes == 2:
        he, (ta, tb), _, _, p = tq.lobe_parts(frame, up, fs.bsdfs[0])
        m = 1 << tq.glossy_level(fs.bsdfs[0])
    else:
        he, ta, _, _ = tq.parts(up)
        tb, p, m = ta, np.ones(1), 1 << level
    te, ta, tb = (t[0].reshape(m, m, 3) for t in (he, ta, tb))
    pts = get_renderer("cycles").sampler("tabulated_sobol").film_points(scrambles(n), n, 4, 2)
    a = _albedo(x0 + 0.5 + warp.offset(pts[:, :, 0, 0]))[..., None]

    def look(t, uv):
        i = np.minimum((uv[..., 0] * m).astype(int), m - 1)
        j = np.minimum((uv[..., 1] * m).astype(int), m - 1)
        return t[i, j]

    pick = (pts[:, :, 3, 0] < p[0])[..., None]
    f = a * (look(te, pts[:, :, 1]) + np.where(pick, look(ta, pts[:, :, 2]),
                                               look(tb, pts[:, :, 2])))
    u = (np.arange(1 << 18) + 0.5) / (1 << 18)
    truth = _albedo(x0 + 0.5 + warp.offset(u)).mean() * (
        te.mean((0, 1)) + p[0] * ta.mean((0, 1)) + (1 - p[0]) * tb.mean((0, 1)))
    return ((f.mean(axis=1) - truth) ** 2).mean(axis=0), truth, p[0], (ta, tb)


@pytest.mark.parametrize("warp", [film_warp("blackman_harris", 1.5), BOX_FILTER])
def test_error_is_a_direct_simulation_over_the_same_points(warp, monkeypatch):
    """The kernel's MSE, without the error above the tables' grid (``ABOVE`` 0: that term
    and the tables' level are checked by rendering, ``bench/frame_check_cycles.py``),
    equals a direct simulation of the estimator over the same points and tables: the film's
    warp, the filter's cells and their weights, the MIS estimator's two tables."""
    import envfit.frame._nets as nets
    monkeypatch.setattr(nets, "ABOVE", 0.0)
    fs = _scene(warp)
    pixels, n = np.array([[1, 2]]), 16
    value, mse, _, _ = pixel_mse_nets(fs, film_block(fs, pixels, 2), pixels, [n], 5, 2)
    sim, truth, _, _ = _simulated(fs, n, 5, warp, 2.0)
    # the filter's 2 % of samples past its square count in the square's edge cells
    tol = 0.04 if warp.table is not None else 1e-9
    assert np.allclose(value[0], truth, rtol=tol / 4)
    assert np.allclose(mse[n][0], sim, rtol=tol), (mse[n][0], sim)


def test_two_lobes_read_the_table_their_lobe_number_picks(monkeypatch):
    """A two-lobe BSDF (a GGX α 0.1 dielectric layer over a Lambert base) under Cycles' points:
    the kernel's MSE equals the estimator simulated over the same points with the BSDF's
    sample read from the table of the lobe the request's z picks (one table of the mixture,
    its lobe drawn from u_x, reads 0.95–1.11 of it here)."""
    import envfit.frame._nets as nets
    from envfit.renderers import FrameBsdf
    monkeypatch.setattr(nets, "ABOVE", 0.0)
    warp = film_warp("blackman_harris", 1.5)
    fs = _scene(warp, bsdfs=(FrameBsdf("glossy", "layered", _Layered(0.1), None, 0,
                                       lobes=2),))
    pixels, n = np.array([[1, 2]]), 16
    value, mse, _, _ = pixel_mse_nets(fs, film_block(fs, pixels, 2), pixels, [n], 5, 2)
    sim, truth, p, (ta, tb) = _simulated(fs, n, 5, warp, 2.0)
    assert 0 < p < 1 and not np.allclose(ta, tb, rtol=0.1)          # two lobes' tables
    assert np.allclose(value[0], truth, rtol=0.01)
    assert np.allclose(mse[n][0], sim, rtol=0.04), (mse[n][0], sim)


def test_weighted_percentile_is_numpys_inverted_cdf():
    """The pixel percentiles without numpy 2's weighted percentile (bpy pins numpy < 2):
    equal to ``np.percentile(..., weights=, method="inverted_cdf")`` where numpy has it."""
    from envfit.frame._api import _percentile
    rng = np.random.default_rng(3)
    x, w = rng.random(101), rng.integers(1, 5, 101).astype(float)
    for q in (1, 10, 50, 90, 99, 100):
        ref = np.percentile(np.repeat(x, w.astype(int)), q, method="inverted_cdf")
        assert _percentile(x, q, w) == ref


def test_neighbours_share_the_film_grids_cells():
    """Under the filter's 1.5-px-wide squares, neighbouring pixels read the same cells of
    one film grid: the shared cells' hits are each pixel's own square's, with fewer casts."""
    from envfit.frame._nets import _grid_hits, _shared
    fs = _scene(film_warp("blackman_harris", 1.5))
    px = np.array([[1, 1], [1, 2], [2, 1], [2, 2]])
    span = film_span(fs)
    h, pix, cell, row = _shared(fs, px, 2, span)
    own = _grid_hits(fs, px, 4, span)
    assert np.array_equal(pix, np.repeat(np.arange(4), 16)) and len(row) == 64
    assert np.allclose(h["position"][row], own["position"], atol=1e-12)
    assert len(h["kind"]) == 36                       # 6 × 6 distinct cells, not 64



def test_the_compiled_layered_tables_are_the_numpy_ones():
    """A two-lobe lobe that holds an AlbedoLayered as ``bsdf`` is tabulated by the compiled
    kernels (one view at a time); the same BSDF through its numpy methods gives the same
    tables."""
    from envfit.renderers import FrameBsdf

    class Hidden(TwoLobes):                    # no ``bsdf`` attribute: the numpy path
        def __init__(self, alpha):
            from envfit.shading.microfacet import AlbedoLayered
            self.inner, self.alpha = AlbedoLayered(alpha), alpha

        @property
        def bsdf(self):
            raise AttributeError("bsdf")

        def eval(self, wi, wo):
            return self.inner.eval(wi, wo)

        def pdf(self, wi, wo):
            return self.inner.pdf(wi, wo)

        def sample_lobe(self, wi, u, lobe):
            return self.inner.sample(wi, u, np.full(len(u), 0.0 if lobe == 0 else 1 - 1e-12))

        def lobe_probability(self, cos_i):
            return self.inner.lobe_probability(cos_i)

    fs = _scene(BOX_FILTER)
    tq = _Techniques(fs, 4)
    wi = np.array([[0.6, 0.0, 0.8], [0.0, 0.3, np.sqrt(0.91)]])
    frames = get_renderer("cycles").tangent_frame(np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]]))
    out = [tq.lobe_parts(frames, wi, FrameBsdf("glossy", "l", lobe, None, 0, lobes=2))
           for lobe in (_Layered(0.1), Hidden(0.1))]
    (he, (a0, b0), _, (d0, e0), p0), (he1, (a1, b1), _, (d1, e1), p1) = out
    assert np.allclose(he, he1, rtol=1e-9, atol=1e-12) and np.allclose(p0, p1)
    assert np.allclose(a0, a1, rtol=1e-7, atol=1e-12) and np.allclose(b0, b1, rtol=1e-7)
    assert np.allclose(d0, d1, atol=1e-9) and np.allclose(e0, e1, atol=1e-9)


def test_an_answer_between_powers_of_two_is_predicted_at_its_own_spp(monkeypatch):
    """Cycles runs any spp, but blue noise's error does not fall smoothly between powers of
    two (runs of a shared sequence: rendered, 69 spp measured above 64's error): an answer
    the powers of two bracket is predicted at its own spp and a few above, and the answer is
    the smallest predicted spp that meets the target — the same model at that spp alone
    meets it, and at the spp reported below it does not."""
    import envfit.frame._api as api
    fs = _scene(film_warp("blackman_harris", 1.5), sampler="blue_noise")
    monkeypatch.setattr(api, "_reader", lambda path: (lambda p: fs))
    opts = dict(level=3, quiet=True, max_pixels=4)
    at = {r.spp: r.rmse for r in api.predict_frame("plane.blend", spp=(8, 16), **opts).rows}
    target = math.sqrt(at[8] * at[16])
    p = api.predict_frame("plane.blend", target=target, **opts)
    assert 8 < p.answer <= 16 and 8 <= p.below < p.answer
    assert any("not predicted" in n and f"{p.below} the largest" in n for n in p.notes)
    own = {r.spp: r.rmse
           for r in api.predict_frame("plane.blend", spp=(p.below, p.answer), **opts).rows}
    assert own[p.answer] <= target < own[p.below]


def test_the_checked_spp_are_spaced_up_to_the_next_prediction():
    from envfit.frame._api import _candidates
    assert _candidates(list(range(1, 300)), 69, {32, 64, 128}) == [69, 80, 93, 109]
    assert _candidates([1, 2, 4, 8, 16], 5, {4, 16}) == [8]

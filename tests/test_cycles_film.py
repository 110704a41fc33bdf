"""Cycles' importance-sampled pixel filter (renderers/cycles/_film) and the film warp the
pixel footprint samples (renderers/_film): the table's offsets have the filter's density, the
footprint's variance scale is exact for a function linear across the pixel, and the model's
footprint follows the renderer's default filter."""
import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.renderers import BOX_FILTER, FilmWarp, get_renderer
from envfit.renderers.cycles._film import BLACKMAN_HARRIS, film_warp, filter_table

_U = (np.arange(1 << 17) + 0.5) / (1 << 17)


def _blackman_harris(x, length):
    v = 2 * np.pi * (x / length + 0.5)
    return 0.35875 - 0.48829 * np.cos(v) + 0.14128 * np.cos(2 * v) - 0.01168 * np.cos(3 * v)


@pytest.mark.parametrize("width", [1.0, 1.5, 2.5])
def test_blackman_harris_offsets_have_its_density(width):
    """Blender's width w: the window spans 2w pixels, centred on the pixel's centre."""
    off = film_warp("blackman_harris", width).offset(_U)
    edges = np.linspace(-width, width, 41)
    hist, _ = np.histogram(off, bins=edges, density=True)
    mid = 0.5 * (edges[1:] + edges[:-1])
    dens = _blackman_harris(mid, 2 * width)
    dens /= dens.sum() * (edges[1] - edges[0])
    inner = dens > 0.05 * dens.max()
    assert np.allclose(hist[inner], dens[inner], rtol=0.02)
    assert abs(np.median(off)) < 1e-3 * width


def test_gaussian_and_box_tables():
    box = film_warp("box", 1.0).offset(_U[_U < 1022 / 1023])     # the last 1/1023: see _film
    assert np.allclose(np.sort(box), np.linspace(-0.5, 0.5, len(box)), atol=2e-3)
    g = film_warp("gaussian", 1.5).offset(_U)       # exp(-2 (6v/3w)^2): sigma = 3w/12,
    assert np.std(g) == pytest.approx(3 * 1.5 / 12, rel=0.02)   # +1.4 %: the table's last
                                                                # entry and inversion
    t = filter_table("blackman_harris", 1.5)
    assert t[1023] == 0.0 and t[511] == 0.5                         # entry 1023 never written


def test_box_warp_is_the_pixels_strata():
    assert BOX_FILTER.variance() == pytest.approx(1 / 12)
    for s in (2, 3, 4):
        assert BOX_FILTER.variance_scale(s) == pytest.approx(s * s / (s * s - 1))
        assert np.allclose(BOX_FILTER.midpoints(s), (np.arange(s) + 0.5) / s - 0.5)


@pytest.mark.parametrize("warp", [BLACKMAN_HARRIS, film_warp("gaussian", 1.5), BOX_FILTER])
def test_variance_scale_is_exact_for_linear_variation(warp):
    """f(x, y) = a x + b y over the side × side footprint: its variance over the quantile
    midpoints times the scale is its variance over the filter."""
    for side in (2, 3):
        m = warp.midpoints(side)
        x, y = np.meshgrid(m, m)
        f = 0.7 * x - 0.3 * y
        exact = (0.7 ** 2 + 0.3 ** 2) * np.var(warp.offset(_U))
        assert warp.variance_scale(side) * np.var(f) == pytest.approx(exact, rel=1e-3)


def test_blackman_harris_is_wider_than_the_box():
    assert BLACKMAN_HARRIS.variance() == pytest.approx(0.1735, abs=5e-4)    # σ 0.4165 px
    assert get_renderer("cycles").pixel_filter is BLACKMAN_HARRIS
    assert get_renderer("mitsuba3").pixel_filter is None


def test_refusals():
    with pytest.raises(ParameterError, match="pixel filter"):
        filter_table("mitchell", 1.0)
    with pytest.raises(ParameterError, match="width"):
        filter_table("box", 0.0)
    from envfit.predict.renderer import RendererModelOptions
    with pytest.raises(ParameterError, match="FilmWarp"):
        RendererModelOptions(pixel_filter="blackman_harris")
    assert isinstance(RendererModelOptions().film(get_renderer("cycles")), FilmWarp)


def test_the_model_footprint_follows_the_filter():
    """On a small sphere the wider filter adds more footprint error; the renderer's default
    is Cycles' Blackman–Harris."""
    from envfit.maps import EnvMap
    from envfit.predict.renderer import DiffuseModel, RendererModelOptions
    h = 16
    th = (np.arange(h) + 0.5) / h * np.pi
    ph = (np.arange(2 * h) + 0.5) / (2 * h) * 2 * np.pi
    data = 0.3 + 0.2 * np.cos(th)[:, None, None] * np.sin(ph)[None, :, None] * np.ones(3)
    data[h // 3, h // 2] = [60.0, 50.0, 40.0]
    env, cyc = EnvMap(data.astype(np.float32), up="y"), get_renderer("cycles")
    base = dict(normals=8, pool=64, max_level=6, sphere_pixels=8)
    box = DiffuseModel(env, cyc, options=RendererModelOptions(**base, pixel_filter=BOX_FILTER))
    bh = DiffuseModel(env, cyc, options=RendererModelOptions(**base))
    assert bh.film is BLACKMAN_HARRIS
    assert bh.predict("mis", "tabulated_sobol", 256).rmse > box.predict(
        "mis", "tabulated_sobol", 256).rmse

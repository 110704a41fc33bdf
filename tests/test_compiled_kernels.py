"""The compiled lat-long lookup and map-sampler warp against their numpy references (the
same arithmetic written as array operations), in the main thread (parallel build) and in a
worker thread (serial build)."""
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from envfit.maps import _latlong as latlong
from envfit.maps._envmap import EnvMap
from envfit.sampling._map_sampler import MapSampler
from oracles.numpy_kernels import bilinear_lookup_numpy, pixel_of_numpy, sample_numpy


def _special_directions(h, w, up):
    rng = np.random.default_rng(3)
    centres = latlong.pixel_directions(h, w, up=up).reshape(-1, 3)
    poles = latlong.local_to_world(up) @ np.array([[0, 0, 1.0], [0, 0, -1.0]]).T
    seam = latlong.pixel_to_direction(rng.uniform(-0.6, h - 0.4, 50), np.full(50, -0.5), h, w,
                                      up=up)
    return np.vstack([rng.normal(size=(5000, 3)) * rng.uniform(0.1, 10, (5000, 1)),
                      centres, poles.T, seam, [[1e-300, 0, 0], [0, -1e-12, 1.0]]])


@pytest.mark.parametrize("up", ["y", "z"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_lookup_kernel_equals_numpy_reference(up, dtype):
    h, w = 12, 20
    img = np.random.default_rng(1).gamma(0.5, 2.0, size=(h, w, 3)).astype(dtype)
    d = _special_directions(h, w, up)
    m = latlong.local_to_world(up)
    ref = bilinear_lookup_numpy(img.reshape(h * w, 3), d, m, h, w)
    got = latlong.bilinear_lookup(img, d, up=up)
    # the same formula; libm and numpy's SIMD atan2 may differ by an ulp
    assert np.allclose(got, ref, rtol=1e-12, atol=1e-12 * float(img.max()))
    # pixel centres stay bit-exact (snapping)
    nc = h * w
    assert np.array_equal(got[5000:5000 + nc], img.reshape(-1, 3).astype(np.float64))
    with ThreadPoolExecutor(1) as pool:                     # the serial build
        again = pool.submit(latlong.bilinear_lookup, img, d, up=up).result()
    assert np.array_equal(again, got)


def test_lookup_rejects_nonfinite():
    from envfit.base._errors import ParameterError
    with pytest.raises(ParameterError, match="NaN or Inf"):
        latlong.bilinear_lookup(np.ones((4, 8)), [[np.nan, 0, 1.0]])


@pytest.mark.parametrize("up", ["y", "z"])
def test_sampler_kernel_equals_numpy_reference(up):
    rng = np.random.default_rng(2)
    data = rng.gamma(0.3, 1.0, size=(16, 32, 3))
    data[3, 7] = 5e4                                        # a sun: stretched pixels
    data[10:, :] = 0.0                                      # rows of zero luminance
    s = MapSampler(EnvMap(data, up=up), floor=0.0)
    U = np.vstack([rng.random((20000, 2)), [[0, 0], [np.nextafter(1, 0)] * 2, [0.5, 0.0]]])
    d, p = s.sample(U)
    dr, pr = sample_numpy(s, U)
    assert np.array_equal(p, pr)
    assert np.allclose(d, dr, rtol=0, atol=1e-14)
    assert np.allclose(s.pdf(d[p > 0]), p[p > 0])           # the pdf of the pixel it lands in
    with ThreadPoolExecutor(1) as pool:
        d2, p2 = pool.submit(s.sample, U).result()
    assert np.array_equal(d2, d) and np.array_equal(p2, p)


@pytest.mark.parametrize("up", ["y", "z"])
def test_pixel_of_kernel_equals_numpy_reference(up):
    s = MapSampler(EnvMap(np.ones((12, 24)), up=up))
    d = _special_directions(12, 24, up)
    i, j = s.pixel_of(d)
    ir, jr = pixel_of_numpy(s, d)
    # the same formula; an ulp of atan2 may move a direction on a pixel edge to its neighbour
    assert np.mean((i == ir) & (j == jr)) > 0.999
    dj = np.abs(j - jr)
    assert np.all(np.abs(i - ir) <= 1) and np.all(np.minimum(dj, 24 - dj) <= 1)
    grid = latlong.pixel_directions(12, 24, up=up)          # pixel centres: their own pixel
    gi, gj = s.pixel_of(grid)
    assert np.array_equal(gi, np.repeat(np.arange(12)[:, None], 24, axis=1))
    assert np.array_equal(gj, np.repeat(np.arange(24)[None, :], 12, axis=0))

r"""Environment maps: the :class:`EnvMap` container (geometry, lookup, resizing) and the
sample-count guard :func:`check_sample_count`.

An :class:`EnvMap` is an ``H x 2H x C`` lat-long image in envfit's convention (see
:mod:`envfit.maps._latlong`: row 0 touches the ``up`` pole, half-integer pixel centres, exact
solid angles). The map *as a function on the sphere* is its bilinear interpolant
(:meth:`EnvMap.lookup`). Reading and writing map files is :mod:`envfit.maps._io`.

Example
-------
>>> import numpy as np
>>> m = EnvMap(np.ones((4, 8, 3), np.float32))
>>> m.height, m.width, m.channels, bool(np.allclose(m.mean(), 1.0))
(4, 8, 3, True)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envfit.maps import _latlong as latlong
from envfit.base import EnvMapFormatError, ParameterError
from envfit.base import check_memory

__all__ = ["EnvMap", "check_sample_count", "REC709_WEIGHTS", "solid_angle_variance",
           "variance_kept"]

#: Rec. 709 / sRGB luminance weights of linear R, G, B
REC709_WEIGHTS = (0.2126, 0.7152, 0.0722)

_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


@dataclass(eq=False)
class EnvMap:
    """A lat-long environment map (``H x W x C``, ``W = 2H``) in envfit's convention.

    Attributes
    ----------
    data : ndarray (H, W, C), float32 or float64 (a 2-D array gets a channel axis; other
        dtypes are converted: float16 → float32, integers/bool → float64)
    up : the world axis of row 0 ("y", "z" or "x"; see :mod:`envfit.maps._latlong`)
    name : a label (the file name when loaded)
    notes : what loading changed (clamped, fixed, dropped channels, resized)

    >>> m = EnvMap(np.zeros((2, 4)))
    >>> m.data.shape
    (2, 4, 1)
    """

    data: np.ndarray
    up: str = "y"
    name: str = ""
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        a = np.asarray(self.data)
        if a.dtype not in _DTYPES:
            if a.dtype == np.float16:
                a = a.astype(np.float32)
            elif np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_ \
                    or np.issubdtype(a.dtype, np.floating):
                a = a.astype(np.float64)
            else:
                raise EnvMapFormatError(f"map data must be real numbers, got dtype {a.dtype}")
        if a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3:
            raise EnvMapFormatError(f"map data must be H x W or H x W x C, got shape {a.shape}")
        h, w, c = a.shape
        if h == 0 or w == 0 or c == 0:
            raise EnvMapFormatError(f"map is empty ({w}x{h}, {c} channels)")
        if w != 2 * h:
            raise EnvMapFormatError(
                f"a lat-long map must be twice as wide as high; got {w}x{h} (width x height)")
        latlong.local_to_world(self.up)  # validates up
        # pixel-interleaved (C order): the lookups gather whole pixels, and a planar layout
        # (as OpenImageIO may return a multi-channel EXR) made each gather ~50× slower
        self.data = np.ascontiguousarray(a)
        self.notes = list(self.notes)

    # -- geometry ------------------------------------------------------------------------
    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def channels(self) -> int:
        return int(self.data.shape[2])

    def directions(self) -> np.ndarray:
        """World direction of each pixel centre, (H, W, 3) float64 (:func:`latlong.pixel_directions`)."""
        return latlong.pixel_directions(self.height, self.width, up=self.up)

    def solid_angles(self) -> np.ndarray:
        """Exact solid angle of each pixel, (H, W) float64, sums to 4π."""
        return latlong.pixel_solid_angles(self.height, self.width)

    def lookup(self, dirs) -> np.ndarray:
        """The map as a function: bilinear value at world directions (..., 3) → (..., C) float64."""
        return latlong.bilinear_lookup(self.data, dirs, up=self.up)

    # -- values --------------------------------------------------------------------------
    def luminance(self) -> np.ndarray:
        r"""Luminance (H, W) float64: :math:`Y = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709)
        for 3 or more channels, else channel 0.

        >>> EnvMap(np.ones((1, 2, 3))).luminance().tolist()
        [[1.0, 1.0]]
        """
        y = self.data[:, :, 0].astype(np.float64)
        if self.channels >= 3:
            y *= REC709_WEIGHTS[0]
            y += REC709_WEIGHTS[1] * self.data[:, :, 1].astype(np.float64)
            y += REC709_WEIGHTS[2] * self.data[:, :, 2].astype(np.float64)
        return y

    def mean(self) -> np.ndarray:
        r"""Solid-angle weighted mean per channel, (C,) float64:
        :math:`\bar f_c = \sum_{ij} \Omega_{ij} f_{ijc} / \sum_{ij}\Omega_{ij}` (≈ ∫f dω / 4π).

        >>> m = EnvMap(np.arange(2.0)[:, None].repeat(4, 1))  # top row 0, bottom row 1
        >>> round(float(m.mean()[0]), 12)
        0.5
        """
        w = latlong.row_solid_angles(self.height, self.width)
        row_sums = self.data.sum(axis=1, dtype=np.float64)      # (H, C)
        return (w @ row_sums) / (w.sum() * self.width)

    # -- derived maps --------------------------------------------------------------------
    def with_data(self, array) -> "EnvMap":
        """A new map with the same ``up``, ``name`` and ``notes`` but other pixels."""
        return EnvMap(np.asarray(array), up=self.up, name=self.name, notes=list(self.notes))

    def astype(self, dtype) -> "EnvMap":
        """The same map with ``data`` converted to ``dtype`` (float32 or float64)."""
        dt = np.dtype(dtype)
        if dt not in _DTYPES:
            raise ParameterError(f"dtype must be float32 or float64, got {dt}")
        return self.with_data(self.data.astype(dt, copy=False))

    def resized(self, max_height: int, *, quiet: bool = True) -> "EnvMap":
        r"""Downscale to height ``max_height`` (width ``2 max_height``); no-op if already small enough.

        * Integer factor ``f = H / max_height``: each output pixel is the **solid-angle
          weighted** mean of its ``f x f`` block, so :meth:`mean` is preserved exactly (to
          rounding); this is ``skimage.transform.downscale_local_mean`` with the exact
          per-row solid angles as weights.
        * Other factors: the anti-aliasing Gaussian of ``skimage.transform.resize`` (σ =
          (factor − 1)/2 per axis), applied with the sphere's boundary conditions (wrap in
          longitude, continuation across the poles at φ + π instead of skimage's mirror),
          then ``skimage.transform.resize(..., order=1, anti_aliasing=False)``.

        >>> m = EnvMap(np.random.default_rng(0).random((8, 16, 3)))
        >>> r = m.resized(2)
        >>> r.data.shape, bool(np.allclose(r.mean(), m.mean(), atol=1e-14))
        ((2, 4, 3), True)
        """
        try:
            mh = int(max_height)
        except (TypeError, ValueError):
            raise ParameterError(f"max_height must be a positive integer, got {max_height!r}") \
                from None
        if mh < 1 or mh != max_height:
            raise ParameterError(f"max_height must be a positive integer, got {max_height!r}")
        h, w, c = self.data.shape
        if h <= mh:
            return self
        dtype = self.data.dtype
        if h % mh == 0:
            f = h // mh
            om = latlong.row_solid_angles(h, w)                          # (H,)
            den = om.reshape(mh, f).sum(axis=1) * f                       # (mh,)
            out = np.empty((mh, 2 * mh, c), dtype=np.float64)
            step = max(1, (1 << 22) // (f * w * c))      # output rows per block (~32 MB)
            from envfit.base import progress
            for r in progress(range(0, mh, step), desc=f"downsampling {w}x{h}", quiet=quiet,
                              unit="block"):
                r1 = min(mh, r + step)
                block = self.data[r * f:r1 * f].astype(np.float64) * om[r * f:r1 * f, None, None]
                out[r:r1] = block.reshape(r1 - r, f, 2 * mh, f, c).sum(axis=(1, 3))
            out /= den[:, None, None]
        else:
            check_memory(4 * self.data.nbytes, f"resizing a {w}x{h} map",
                         hint="use a max_height that divides the height (block averaging)")
            out = _resize_smooth(self.data, mh)
        note = f"resized from {w}x{h} to {2 * mh}x{mh}"
        return EnvMap(out.astype(dtype), up=self.up, name=self.name,
                      notes=list(self.notes) + [note])


def solid_angle_variance(envmap: EnvMap) -> np.ndarray:
    r"""Solid-angle weighted variance of the pixel values per channel, (C,) float64:
    :math:`\overline{f^2} - \bar f^2` with the exact per-row solid angles, in row blocks of
    ~32 MB (no full-size float64 copy of a big map).

    >>> m = EnvMap(np.arange(2.0)[:, None].repeat(4, 1))  # rows 0 and 1, equal solid angles
    >>> round(float(solid_angle_variance(m)[0]), 12)
    0.25
    """
    h, w, c = envmap.data.shape
    om = latlong.row_solid_angles(h, w)
    s1, s2 = np.zeros(c), np.zeros(c)
    step = max(1, (1 << 22) // (w * c))
    for r in range(0, h, step):
        block = envmap.data[r:r + step].astype(np.float64)
        s1 += om[r:r + step] @ block.sum(axis=1)
        s2 += om[r:r + step] @ (block * block).sum(axis=1)
    total = om.sum() * w
    m = s1 / total
    return np.maximum(s2 / total - m * m, 0.0)


def variance_kept(original: EnvMap, resized: EnvMap) -> float:
    """The share of the original map's solid-angle variance (:func:`solid_angle_variance`,
    summed over channels) that ``resized`` keeps: 1 for a map without detail finer than the
    resized pixels, less where block means average detail away (1 for a constant map).

    >>> m = EnvMap(np.tile([[0.0, 1.0]], (4, 4)))          # columns alternate 0, 1
    >>> variance_kept(m, m.resized(2))                      # 2x2 block means: all 0.5
    0.0
    """
    v0 = float(np.sum(solid_angle_variance(original)))
    v1 = float(np.sum(solid_angle_variance(resized)))
    return 1.0 if v0 <= 0 else v1 / v0


def _resize_smooth(data: np.ndarray, mh: int) -> np.ndarray:
    """Anti-aliased resize to (mh, 2mh) with spherical boundary handling (see EnvMap.resized)."""
    from scipy.ndimage import gaussian_filter
    from skimage.transform import resize

    h, w, c = data.shape
    factor = h / mh
    sigma = max(0.0, (factor - 1.0) / 2.0)
    if sigma > 0:
        pad = int(4.0 * sigma + 0.5) + 1
        pr = min(pad, h)
        # rows across the pole: row -1-k is row k at azimuth + pi (column + W/2)
        top = np.roll(data[:pr][::-1], w // 2, axis=1)
        bot = np.roll(data[h - pr:][::-1], w // 2, axis=1)
        ext = np.concatenate([top, data, bot], axis=0)
        pc = min(pad, w)
        ext = np.concatenate([ext[:, w - pc:], ext, ext[:, :pc]], axis=1)
        ext = gaussian_filter(ext, sigma=(sigma, sigma, 0), mode="nearest")
        data = ext[pr:pr + h, pc:pc + w]
    return resize(data, (mh, 2 * mh, c), order=1, mode="edge", anti_aliasing=False,
                  preserve_range=True)


def check_sample_count(n: int, width: int, height: int, *, name: str = "",
                       what: str = "N") -> int:
    """Refuse more interpolation samples than the map has pixels (returns ``n``).

    The map is read as its bilinear interpolant between pixel centres, so samples beyond
    one per pixel add no information, only near-duplicate nodes: the kernel matrix becomes
    ill-conditioned and the fit or reconstruction measures the sampling, not the map. This
    is an error rather than a silent cap: a capped N would change the experiment (Table 2
    columns, the fit's N) behind the user's back; the message gives the largest sensible N,
    the pixel count W x H.

    >>> check_sample_count(32, 8, 4)
    32
    >>> check_sample_count(5000, 8, 4, name="tiny.exr")
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: N = 5000 samples is more than the 32 pixels of map tiny.exr (8x4): more samples than pixels add no information (the map is read bilinearly) and make the kernel matrix ill-conditioned; the largest sensible N is 32
    """
    pixels = int(width) * int(height)
    if int(n) > pixels:
        label = f"map {name} ({width}x{height})" if name else f"the {width}x{height} map"
        raise ParameterError(
            f"{what} = {n} samples is more than the {pixels} pixels of {label}: more samples "
            f"than pixels add no information (the map is read bilinearly) and make the kernel "
            f"matrix ill-conditioned; the largest sensible {what} is {pixels}")
    return int(n)

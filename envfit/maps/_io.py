r"""Environment map file I/O through OpenImageIO: :func:`load_envmap` and :func:`save_envmap`.

Maps are read into and written from :class:`~envfit.maps._envmap.EnvMap` (an ``H x 2H x C``
lat-long image in envfit's convention, see :mod:`envfit.maps._latlong`).

Loading (:func:`load_envmap`) reads anything OpenImageIO reads (EXR, HDR, PNG, TIFF, ...)
as float, checks the memory budget before reading pixels, and turns every problem into a
one-line :mod:`envfit.base._errors` exception:

=============================================  ===========================================
problem                                        result
=============================================  ===========================================
missing file / a folder                        :class:`EnvMapFileError` ("no such file")
not a regular file (FIFO, device, socket,      :class:`EnvMapFileError` saying which,
symbolic link loop, dangling link)             never opened (a FIFO would block)
unreadable, corrupt, truncated                 :class:`EnvMapFileError` (OIIO's message)
empty, or display width != 2 x height          :class:`EnvMapFormatError` (with the size)
data window != display window (EXR)            placed in the display window: the
                                               missing pixels are 0, stored pixels
                                               outside are dropped (noted, with counts)
data window outside the display window         :class:`EnvMapFormatError` (both windows)
too large for the memory budget                :class:`MemoryBudgetError`
NaN / Inf values                               :class:`NonFiniteError` (count; suggests
                                               ``fix_nonfinite=True`` / ``--fix-nonfinite``)
NaN / Inf with no finite neighbour, fixing     :class:`NonFiniteError` (nothing to
                                               replace them by)
negative values                                clamped to 0 and noted (``allow_negative``
                                               keeps them)
=============================================  ===========================================

Only the first subimage (EXR part) is read (noted if there are more).

Windows (OpenImageIO's ``ImageSpec``: ``x, y, width, height`` is the *data window*, the pixels
stored; ``full_x, full_y, full_width, full_height`` the *display window*, the image): the
display window is the sphere and must be 2:1. A data window that differs (an autocropped
sky storing 128x32 of a 128x64 map, an offset or overscanned window) is placed in it with
``ImageBufAlgo.crop`` to the display ROI: display pixels not stored are 0 (OpenEXR's
convention), stored pixels outside the display window are dropped, and the map's notes say
how many of each. A data window that covers none of the display window is refused.

Colour: float files (EXR, HDR, float TIFF) are taken as linear radiance, as they are.
Integer files (8/16-bit PNG, JPEG, TIFF, ...) are display-referred: their colour space
(``oiio:ColorSpace``, sRGB when the file names none, the convention for such files) is
decoded to linear with OpenImageIO's ``ImageBufAlgo.colorconvert`` and the map gets the note
"decoded 8-bit sRGB to linear radiance (display-referred file: its dynamic range is
clipped)" (``linearize=False`` keeps the encoded values).

Channels: 1 channel → grey (C = 1); 2 channels → the first one (grey + alpha, or a
two-channel image of which only the first channel is used; noted); 3 → RGB; 4 or more →
the alpha channel (OIIO's ``alpha_channel``, else channel 3 of an RGBA-like 4-channel
image) is dropped and the first three remaining channels are kept as RGB (noted).

Example
-------
>>> import numpy as np
>>> p = save_envmap("m.exr", np.full((4, 8, 3), 0.5, np.float32))
>>> m = load_envmap(p)
>>> m.name, m.data.shape, bool(np.allclose(m.data, 0.5))
('m.exr', (4, 8, 3), True)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from envfit.base import replace_via_temporary
from envfit.base import regular_file_problem
from envfit.base import EnvMapFileError, NonFiniteError, ParameterError
from envfit.maps import _latlong as latlong
from envfit.maps._conventions import lat_long_convention
from envfit.maps._envmap import _DTYPES, EnvMap
from envfit.maps._oiio_read import one_line, read_pixels

__all__ = ["load_envmap", "save_envmap", "FLOAT_EXTENSIONS", "PREVIEW_EXTENSIONS"]

#: extensions written as floating point by :func:`save_envmap`
FLOAT_EXTENSIONS = (".exr", ".hdr", ".tif", ".tiff")

#: extensions written as 8-bit display-referred previews by :func:`save_envmap`
#: (.pfm is left out: OpenImageIO 3.x reads back its own PFM files upside down)
PREVIEW_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tga", ".ppm")


def _neighbour_means(data: np.ndarray, bad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, count)`` of the finite values among each value's 8 neighbours (same channel;
    longitude wraps, rows stop at the map edge); the mean is 0 where the count is 0."""
    good = ~bad
    vals = np.where(good, data, 0.0).astype(np.float64)
    cnt = good.astype(np.float64)
    # wrap longitude, zero rows beyond the edges
    vp = np.pad(np.concatenate([vals[:, -1:], vals, vals[:, :1]], axis=1), ((1, 1), (0, 0), (0, 0)))
    cp = np.pad(np.concatenate([cnt[:, -1:], cnt, cnt[:, :1]], axis=1), ((1, 1), (0, 0), (0, 0)))
    h, w = data.shape[:2]
    s = np.zeros_like(vals)
    n = np.zeros_like(cnt)
    for di in (0, 1, 2):
        for dj in (0, 1, 2):
            if di == 1 and dj == 1:
                continue
            s += vp[di:di + h, dj:dj + w]
            n += cp[di:di + h, dj:dj + w]
    return np.divide(s, n, out=np.zeros_like(s), where=n > 0), n


def _fix_nonfinite(data: np.ndarray, bad: np.ndarray, p: Path) -> np.ndarray:
    """Replace non-finite values by the mean of the finite values among their 8 neighbours
    (same channel; longitude wraps, rows stop at the map edge). A value with no finite
    neighbour (a non-finite region 3 or more pixels across, or a whole channel) has nothing
    to be replaced by: :class:`NonFiniteError`, one line saying so (no invented 0)."""
    repl, n = _neighbour_means(data, bad)
    alone = bad & (n == 0)
    if alone.any():
        k, nbad = int(alone.sum()), int(bad.sum())
        if not np.isfinite(data).any():
            raise NonFiniteError(f"{p}: all {nbad} values are non-finite: --fix-nonfinite has "
                                 "no finite neighbour to replace them by; repair the file")
        i, j, c = (int(x) for x in np.argwhere(alone)[0])
        whole = [ch for ch in range(data.shape[2]) if bad[:, :, ch].all()]
        where = (f"channel {whole[0]} is non-finite throughout" if whole else
                 f"e.g. row {i}, col {j}, channel {c}, inside a non-finite region")
        raise NonFiniteError(
            f"{p}: {k} of the {nbad} non-finite values have no finite neighbour ({where}): "
            "--fix-nonfinite replaces a value only by the mean of its finite neighbours; "
            "repair the file")
    out = data.copy()
    out[bad] = repl[bad].astype(data.dtype)
    return out


def load_envmap(path, *, up: str | None = None, convention=None, allow_negative: bool = False,
                fix_nonfinite: bool = False, max_height: int | None = None,
                dtype=np.float32, linearize: bool = True) -> EnvMap:
    """Read a lat-long environment map with OpenImageIO, in envfit's convention.

    In this order: read the pixels (in ``convention``'s lat-long layout, or envfit's), clean
    them (NaN/Inf, negatives), convert them to envfit's grid
    (:meth:`~envfit.maps._convention_base.LatLongConvention.to_internal`: exact where only
    pixels move, else bilinear), *then* downscale to ``max_height`` (as the CLI's
    ``--convention C --max-height H``).

    Parameters
    ----------
    path : file in any format OIIO reads (EXR, HDR, PNG, TIFF, ...). Float files (EXR,
        HDR, float TIFF, PFM) are read as they are. Integer files (8/16-bit PNG, JPEG,
        TIFF, ...) are display-referred: their colour space (OIIO's ``oiio:ColorSpace``; if
        absent, sRGB, the convention for such files) is decoded to linear radiance with
        ``ImageBufAlgo.colorconvert(..., "linear")`` and noted
        (:func:`envfit.maps._oiio_read._display_decoding`).
    linearize : False keeps an integer file's encoded values in [0, 1] (no decoding).
    up : the world axis of the map's top row ("y", "z", "x"; default "y") on envfit's grid
        (:mod:`envfit.maps._latlong`); not with ``convention``, which fixes it.
    convention : the renderer whose lat-long layout the file has: a name of
        :data:`~envfit.maps._conventions.CONVENTIONS` (``"mitsuba3"``, ``"blender"``, ...)
        or a convention object; the map's ``up`` is the convention's.
    allow_negative : keep negative values (default: clamp them to 0 and note how many).
    fix_nonfinite : replace NaN/Inf values by the mean of the finite values among their 8
        neighbours in the same channel, noted (:class:`NonFiniteError` if one has none);
        by default they raise :class:`NonFiniteError`.
    max_height : downscale to this height (:meth:`~envfit.maps._envmap.EnvMap.resized`).
    dtype : float32 (default) or float64.

    Raises :class:`EnvMapFileError`, :class:`EnvMapFormatError`, :class:`NonFiniteError`,
    :class:`MemoryBudgetError` with one-line messages (see the module docstring); the memory
    guard runs on the header's size *before* any pixel is read; :class:`ParameterError` for
    a convention unknown or not lat-long (``pbrt4``), or given with ``up``.

    >>> import numpy as np
    >>> p = save_envmap("b.exr", np.arange(8.0, dtype=np.float32).reshape(2, 4, 1), up="z")
    >>> m = load_envmap(p, convention="blender")       # Cycles' columns: mirrored, shifted
    >>> m.up, m.data[0, :, 0].tolist()
    ('z', [1.0, 0.0, 3.0, 2.0])
    """
    dt = np.dtype(dtype)
    if dt not in _DTYPES:
        raise ParameterError(f"dtype must be float32 or float64, got {dt}")
    conv = lat_long_convention(convention, up)
    up = conv.up if conv is not None else (up or "y")
    latlong.local_to_world(up)
    p = _readable_file(path)
    pixels, spec, notes = read_pixels(p, dt, linearize)
    pixels = _clean_values(pixels, p, notes, fix_nonfinite=fix_nonfinite,
                           allow_negative=allow_negative)
    notes += _up_mismatch(spec, up)
    m = EnvMap(pixels.astype(dt, copy=False), up=up, name=p.name, notes=notes)
    if conv is not None:
        m = conv.to_internal(m)
    if max_height is not None:
        m = m.resized(max_height)
    return m


def _up_mismatch(spec, up: str) -> list[str]:
    """A note if the file's ``envfit:up`` attribute names another axis than ``up``."""
    try:
        file_up = spec.get_string_attribute("envfit:up", "")
    except Exception:  # pragma: no cover - old OIIO bindings
        file_up = ""
    if file_up and file_up != up:
        return [f"the file says up={file_up!r} (envfit:up) but up={up!r} was used"]
    return []


def _readable_file(path) -> Path:
    """``path`` as a Path if it is an existing, readable regular file; else
    :class:`EnvMapFileError` saying what it is (no such file, a folder, a named pipe, a
    device, a socket, a symbolic link loop or a dangling one, permission denied). Only
    ``stat`` looks at it: a FIFO or a device is never opened (an ``open()`` of a FIFO blocks
    in the kernel, where no signal handler runs)."""
    p = Path(path)
    why = regular_file_problem(p, "an image file")
    if why is not None:
        raise EnvMapFileError(f"{p}: {why}")
    return p


def _clean_values(pixels: np.ndarray, p: Path, notes: list[str], *, fix_nonfinite: bool,
                  allow_negative: bool) -> np.ndarray:
    """NaN/Inf refused or repaired, negative values clamped (each noted)."""
    bad = ~np.isfinite(pixels)
    nbad = int(bad.sum())
    if nbad:
        nnan = int(np.isnan(pixels).sum())
        npix = int(bad.any(axis=2).sum())
        what = (f"{nbad} non-finite value(s) ({nnan} NaN, {nbad - nnan} Inf) "
                f"in {npix} pixel(s)")
        if not fix_nonfinite:
            raise NonFiniteError(f"{p}: {what}; pass fix_nonfinite=True (CLI: --fix-nonfinite) "
                                 f"to replace them by the mean of their finite neighbours")
        pixels = _fix_nonfinite(pixels, bad, p)
        notes.append(f"replaced {what} by the mean of their finite neighbours")
    if not allow_negative:
        neg = pixels < 0
        nneg = int(neg.sum())
        if nneg:
            npix = int(neg.any(axis=2).sum())
            pixels = np.maximum(pixels, 0.0)
            notes.append(f"clamped {nneg} negative value(s) in {npix} pixel(s) to 0")
    return pixels


def _encoded(data: np.ndarray, ext: str, half: bool, p: Path) -> tuple[str, np.ndarray]:
    """``(OIIO format, contiguous pixels)`` for writing ``data`` as ``ext``: float (half for
    ``.exr`` with ``half``), or 8-bit ``round(255 v)`` of display-referred data in [0, 1]."""
    if ext in FLOAT_EXTENSIONS:
        fmt = "half" if (half and ext == ".exr") else "float"
        return fmt, np.ascontiguousarray(data, dtype=np.float32)
    if not np.all(np.isfinite(data)):
        raise ParameterError(f"{p}: 8-bit output needs finite display-referred data in "
                             "[0, 1]; the data holds NaN/Inf")
    lo, hi = float(data.min()), float(data.max())
    if lo < -1e-6 or hi > 1 + 1e-6:
        raise ParameterError(
            f"{p}: 8-bit output needs display-referred data in [0, 1], got "
            f"[{lo:.4g}, {hi:.4g}]; apply envfit.maps._scales.fit_scale('display', map) first "
            "or save as .exr")
    return "uint8", np.ascontiguousarray(np.rint(np.clip(data, 0.0, 1.0) * 255.0), dtype=np.uint8)


def save_envmap(path, envmap_or_array, *, half: bool = False, up: str | None = None) -> Path:
    """Write a map (EnvMap or H x W [x C] array) atomically; returns the path.

    * ``.exr``: 32-bit float (``half=True``: 16-bit half), zip compression; the ``up`` axis
      (default: the EnvMap's, else "y") is stored as the string attribute ``envfit:up``
      (:func:`load_envmap` notes a mismatch).
    * ``.hdr`` (RGB only), ``.tif``/``.tiff``: float.
    * ``.png``, ``.jpg``/``.jpeg``, ``.bmp``, ``.tga``, ``.ppm``: 8-bit, for previews. The
      data must already be display-referred in [0, 1] (e.g. ``fit_scale("display", m)
      .apply(m.data)``); values are rounded to ``round(255 v)``. Data outside [0, 1] (beyond
      1e-6) or non-finite raises :class:`ParameterError` rather than being silently clipped.
    * other extensions raise :class:`ParameterError`.

    The file is written to a temporary name (same folder, same extension) and moved into
    place with ``os.replace``, so ``path`` is either the old file or the complete new one.
    """
    if isinstance(envmap_or_array, EnvMap):
        data = envmap_or_array.data
        up = envmap_or_array.up if up is None else up
    else:
        data = EnvMap(np.asarray(envmap_or_array)).data  # validates shape
    up = "y" if up is None else up
    latlong.local_to_world(up)
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in FLOAT_EXTENSIONS + PREVIEW_EXTENSIONS:
        raise ParameterError(f"{p}: cannot save as {ext or 'a file without extension'!r}; use "
                             f"one of {', '.join(FLOAT_EXTENSIONS + PREVIEW_EXTENSIONS)}")
    fmt, pixels = _encoded(data, ext, half, p)
    replace_via_temporary(p, lambda tmp: _write_image(str(tmp), p, pixels, fmt, up),
                          suffix=p.suffix)
    return p


def _write_image(tmp: str, p: Path, pixels: np.ndarray, fmt: str, up: str) -> None:
    """Write ``pixels`` (H, W, C) as OIIO format ``fmt`` to ``tmp`` (named like ``p``):
    channels R, G, B or Y; an EXR gets zip compression and ``envfit:up``. A failure is
    :class:`EnvMapFileError` "``p``: write failed: …"."""
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(tmp)
    if out is None:
        raise EnvMapFileError(f"{p}: cannot write this format: {one_line(oiio.geterror())}")
    spec = oiio.ImageSpec(w, h, c, fmt)
    if c == 3:
        spec.channelnames = ("R", "G", "B")
    elif c == 1:
        spec.channelnames = ("Y",)
    if p.suffix.lower() == ".exr":
        spec.attribute("compression", "zip")
        spec.attribute("envfit:up", up)
    ok = out.open(tmp, spec) and out.write_image(pixels)
    err = out.geterror() if not ok else ""
    ok = out.close() and ok
    if not ok:
        raise EnvMapFileError(f"{p}: write failed: "
                              f"{one_line(err or out.geterror() or oiio.geterror())}")

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
unreadable, corrupt, truncated                 :class:`EnvMapFileError` (OIIO's message)
empty, or display width != 2 x height          :class:`EnvMapFormatError` (with the size)
data window != display window (EXR)            placed in the display window: the
                                               missing pixels are 0, stored pixels
                                               outside are dropped (noted, with counts)
data window outside the display window         :class:`EnvMapFormatError` (both windows)
too large for the memory budget                :class:`MemoryBudgetError`
NaN / Inf values                               :class:`NonFiniteError` (count; suggests
                                               ``fix_nonfinite=True`` / ``--fix-nonfinite``)
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

import os
import tempfile
from pathlib import Path

import numpy as np

from envfit.maps import _latlong as latlong
from envfit.maps._envmap import _DTYPES, EnvMap
from envfit.base._atomic import current_umask
from envfit.base._errors import EnvMapFileError, EnvMapFormatError, NonFiniteError, ParameterError
from envfit.base._resources import check_memory

__all__ = ["load_envmap", "save_envmap", "FLOAT_EXTENSIONS", "PREVIEW_EXTENSIONS"]

#: extensions written as floating point by :func:`save_envmap`
FLOAT_EXTENSIONS = (".exr", ".hdr", ".tif", ".tiff")

#: extensions written as 8-bit display-referred previews by :func:`save_envmap`
#: (.pfm is left out: OpenImageIO 3.x reads back its own PFM files upside down)
PREVIEW_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tga", ".ppm")


def _one_line(msg: str) -> str:
    """Condense a (possibly multi-line) library message to one line."""
    parts = [p.strip() for p in str(msg).replace("\r", "\n").split("\n") if p.strip()]
    # OIIO sometimes repeats the same message
    seen: list[str] = []
    for p in parts:
        if p not in seen:
            seen.append(p)
    text = "; ".join(seen)
    return text if len(text) <= 300 else text[:297] + "..."


def _select_channels(pixels: np.ndarray, spec, notes: list[str]) -> np.ndarray:
    c = pixels.shape[2]
    names = [str(n) for n in spec.channelnames] if spec.channelnames else []
    if c == 1:
        return pixels
    alpha = int(spec.alpha_channel)
    if alpha < 0 and c == 4:
        alpha = 3
    if c == 2:
        other = names[1] if len(names) > 1 else "1"
        kind = "alpha " if alpha == 1 else ""
        notes.append(f"2-channel image: used channel {names[0] if names else 0!r}, "
                     f"dropped {kind}channel {other!r}")
        return pixels[:, :, :1]
    keep = [i for i in range(c) if i != alpha]
    dropped = []
    if 0 <= alpha < c:
        dropped.append(f"alpha channel {names[alpha] if alpha < len(names) else alpha!r}")
    if len(keep) > 3:
        extra = keep[3:]
        dropped.append(f"{len(extra)} extra channel(s) "
                       + ", ".join(repr(names[i]) if i < len(names) else str(i) for i in extra))
    if dropped:
        notes.append("dropped " + " and ".join(dropped))
    return pixels[:, :, keep[:3]]


def _fix_nonfinite(data: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Replace non-finite values by the mean of the finite values among their 8 neighbours
    (same channel; longitude wraps, rows stop at the map edge), or by 0 if there are none."""
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
    repl = np.divide(s, n, out=np.zeros_like(s), where=n > 0)
    out = data.copy()
    out[bad] = repl[bad].astype(data.dtype)
    return out


_INTEGER_BASETYPES = ("UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "UINT64", "INT64")
#: the colour space display-referred files are decoded to (OIIO 3.x: "linear" is an alias of
#: "lin_rec709_scene", linear Rec. 709 primaries as sRGB's)
LINEAR_SPACE = "linear"


def _colour_config():
    import OpenImageIO as oiio
    global _COLOUR_CONFIG
    if _COLOUR_CONFIG is None:
        _COLOUR_CONFIG = oiio.ColorConfig()
    return _COLOUR_CONFIG


_COLOUR_CONFIG = None


def _display_decoding(spec) -> tuple[str | None, str | None]:
    """``(colour space to decode from or None, note or None)`` for a file's header.

    * float data (EXR, HDR, float TIFF): ``(None, None)``, read as it is;
    * integer data tagged linear or raw data: ``(None, None)``;
    * integer data tagged with a display colour space OIIO knows (``sRGB``,
      ``srgb_rec709_scene``, gamma 2.2, ...), or untagged (sRGB is the convention for 8-bit
      PNG/JPEG/TIFF): that space, with the note ``decoded 8-bit sRGB to linear radiance
      (display-referred file: its dynamic range is clipped)``;
    * a colour space OIIO's configuration does not know: ``(None, note)``, values kept.
    """
    basetype = str(spec.format.basetype).rsplit(".", 1)[-1].upper()
    if basetype not in _INTEGER_BASETYPES and basetype not in ("UCHAR", "CHAR", "USHORT", "SHORT"):
        return None, None
    bits = spec.get_int_attribute("oiio:BitsPerSample", 0) or 8 * int(spec.format.size())
    cs = spec.get_string_attribute("oiio:ColorSpace", "") or ""
    tail = "(display-referred file: its dynamic range is clipped)"
    if not cs:
        return "sRGB", (f"decoded {bits}-bit sRGB to linear radiance {tail}; the file names no "
                        f"colour space, sRGB assumed (the convention for {bits}-bit images)")
    cc = _colour_config()
    if cc.getColorSpaceIndex(cs) < 0 and not cc.equivalent(cs, "sRGB"):
        return None, (f"{bits}-bit file in colour space {cs!r}, which OpenImageIO's colour "
                      "configuration does not know: its values are used as they are (not "
                      "decoded to linear radiance)")
    if cc.isData(cs) or cc.isColorSpaceLinear(cc.resolve(cs)):
        return None, None
    name = "sRGB" if cc.equivalent(cs, "sRGB") else cs
    return cs, f"decoded {bits}-bit {name} to linear radiance {tail}"


def _decode_to_linear(pixels: np.ndarray, spec, space: str, p: Path) -> np.ndarray:
    """``pixels`` (H, W, C float32, encoded in ``space``) converted to linear radiance with
    ``ImageBufAlgo.colorconvert`` (alpha, if the header names one, is left as it is)."""
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    fspec = oiio.ImageSpec(w, h, c, "float")
    if spec.channelnames:
        fspec.channelnames = tuple(spec.channelnames)
    fspec.alpha_channel = int(spec.alpha_channel)
    buf = oiio.ImageBuf(fspec)
    buf.set_pixels(oiio.ROI.All, np.ascontiguousarray(pixels, dtype=np.float32))
    out = oiio.ImageBufAlgo.colorconvert(buf, space, LINEAR_SPACE)
    if out.has_error:
        raise EnvMapFormatError(f"{p}: cannot decode its {space} colour space to linear "
                                f"radiance: {_one_line(out.geterror())}")
    return np.asarray(out.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(h, w, c)


def load_envmap(path, *, up: str = "y", allow_negative: bool = False,
                fix_nonfinite: bool = False, max_height: int | None = None,
                dtype=np.float32, linearize: bool = True) -> EnvMap:
    """Read a lat-long environment map with OpenImageIO.

    Parameters
    ----------
    path : file in any format OIIO reads (EXR, HDR, PNG, TIFF, ...). Float files (EXR,
        HDR, float TIFF, PFM) are read as they are. Integer files (8/16-bit PNG, JPEG,
        TIFF, ...) are display-referred: their colour space (OIIO's ``oiio:ColorSpace``; if
        absent, sRGB, the convention for such files) is decoded to linear radiance with
        ``ImageBufAlgo.colorconvert(..., "linear")`` and noted (:func:`_display_decoding`).
    linearize : False keeps an integer file's encoded values in [0, 1] (no decoding).
    up : the world axis of the map's top row ("y", "z", "x"); see :mod:`envfit.maps._latlong`.
    allow_negative : keep negative values (default: clamp them to 0 and note how many).
    fix_nonfinite : replace NaN/Inf values by the mean of the finite values among their 8
        neighbours in the same channel (0 if none) and note how many; by default they
        raise :class:`NonFiniteError`.
    max_height : downscale to this height (see :meth:`~envfit.maps._envmap.EnvMap.resized`).
    dtype : float32 (default) or float64.

    Raises :class:`EnvMapFileError`, :class:`EnvMapFormatError`, :class:`NonFiniteError`,
    :class:`MemoryBudgetError` with one-line messages (see the module docstring); the memory
    guard runs on the header's size *before* any pixel is read.
    """
    dt = np.dtype(dtype)
    if dt not in _DTYPES:
        raise ParameterError(f"dtype must be float32 or float64, got {dt}")
    latlong.local_to_world(up)
    p = _readable_file(path)
    pixels, spec, notes = _read_pixels(p, dt, linearize)
    pixels = _clean_values(pixels, p, notes, fix_nonfinite=fix_nonfinite,
                           allow_negative=allow_negative)
    try:
        file_up = spec.get_string_attribute("envfit:up", "")
    except Exception:  # pragma: no cover - old OIIO bindings
        file_up = ""
    if file_up and file_up != up:
        notes.append(f"the file says up={file_up!r} (envfit:up) but up={up!r} was used")
    m = EnvMap(pixels.astype(dt, copy=False), up=up, name=p.name, notes=notes)
    if max_height is not None:
        m = m.resized(max_height)
    return m


def _readable_file(path) -> Path:
    """``path`` as a Path if it is an existing, readable file; else :class:`EnvMapFileError`."""
    p = Path(path)
    if not p.exists():
        raise EnvMapFileError(f"{p}: no such file")
    if p.is_dir():
        raise EnvMapFileError(f"{p}: is a folder, not an image file")
    if not os.access(p, os.R_OK):
        raise EnvMapFileError(f"{p}: permission denied")
    return p


def _check_header(spec, p: Path) -> tuple[int, int, int]:
    """``(h, w, c)`` of the display window of a usable lat-long image header (the sphere,
    see :func:`_window_notes`); else :class:`EnvMapFormatError`."""
    h, w, c = int(spec.full_height), int(spec.full_width), int(spec.nchannels)
    dw, dh = int(spec.width), int(spec.height)
    if dh <= 0 or dw <= 0 or c <= 0:
        raise EnvMapFormatError(f"{p}: image is empty ({dw}x{dh}, {c} channels)")
    if int(spec.depth) > 1 or spec.deep:
        raise EnvMapFormatError(f"{p}: volume/deep images are not environment maps")
    same = _data_is_display(spec)
    what = "" if same else (f" (its display window, the sphere; the data window is {dw}x{dh} "
                            f"at ({spec.x}, {spec.y}))")
    if h <= 0 or w <= 0:
        raise EnvMapFormatError(f"{p}: its display window is empty ({w}x{h}){what}")
    if w != 2 * h:
        raise EnvMapFormatError(
            f"{p}: a lat-long map must be twice as wide as high; got {w}x{h} "
            f"(width x height){what}")
    return h, w, c


def _data_is_display(spec) -> bool:
    """Whether the data window is the display window (the usual case)."""
    return (int(spec.x), int(spec.y), int(spec.width), int(spec.height)) == (
        int(spec.full_x), int(spec.full_y), int(spec.full_width), int(spec.full_height))


def _window_notes(spec, p: Path) -> list[str]:
    """Notes on a data window that differs from the display window; refuses one that
    stores none of it.

    OpenImageIO's (and OpenEXR's) windows: the *display window* (``full_x, full_y,
    full_width, full_height``) is the image — here the whole sphere — and the *data window*
    (``x, y, width, height``) the pixels stored in the file, anywhere relative to it (an
    autocropped sky stores only the rows that are not black). Display pixels outside the
    data window are 0 (OpenEXR's convention for pixels not stored); stored pixels outside
    the display window are not part of the image and are dropped.
    """
    x, y, dw, dh = int(spec.x), int(spec.y), int(spec.width), int(spec.height)
    fx, fy, fw, fh = int(spec.full_x), int(spec.full_y), int(spec.full_width), int(spec.full_height)
    ox = max(0, min(x + dw, fx + fw) - max(x, fx))
    oy = max(0, min(y + dh, fy + fh) - max(y, fy))
    inside, full, data = ox * oy, fw * fh, dw * dh
    data_at, display_at = f"{dw}x{dh} at ({x}, {y})", f"{fw}x{fh} at ({fx}, {fy})"
    if inside == 0:
        raise EnvMapFormatError(
            f"{p}: its data window ({data_at}) does not overlap its display window "
            f"({display_at}): the file stores no pixel of the sphere")
    notes = []
    if inside < full:
        notes.append(f"the file's data window ({data_at}) covers {inside} of the "
                     f"{full} pixels of its display window ({display_at}, the sphere; "
                     f"{100 * inside / full:.3g}%): the other {full - inside} pixels, not "
                     "stored in the file, were padded with 0")
    if inside < data:
        notes.append(f"dropped {data - inside} pixels of the file's data window ({data_at}) "
                     f"that lie outside its display window ({display_at})")
    return notes


def _to_display_window(pixels: np.ndarray, spec, p: Path) -> np.ndarray:
    """The data window's pixels (H_d, W_d, C) placed in the display window (H, W, C) with
    ``ImageBufAlgo.crop`` to the full ROI: zero where nothing is stored, data outside the
    display window dropped."""
    import OpenImageIO as oiio

    dspec = oiio.ImageSpec(spec)
    dspec.set_format(oiio.FLOAT)
    buf = oiio.ImageBuf(dspec)
    buf.set_pixels(oiio.ROI.All, np.ascontiguousarray(pixels, dtype=np.float32))
    out = oiio.ImageBufAlgo.crop(buf, buf.roi_full)
    if out.has_error:
        raise EnvMapFormatError(f"{p}: cannot place its data window in its display window: "
                                f"{_one_line(out.geterror())}")
    h, w, c = int(spec.full_height), int(spec.full_width), pixels.shape[2]
    return np.asarray(out.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(h, w, c)


def _read_pixels(p: Path, dt: np.dtype, linearize: bool) -> tuple[np.ndarray, object, list[str]]:
    """The first subimage's display window as float32 (H, W, C') linear values, its spec and
    the notes; the memory guard runs on the header before any pixel is read."""
    import OpenImageIO as oiio

    oiio.geterror()  # clear stale global errors
    inp = oiio.ImageInput.open(str(p))
    if inp is None:
        msg = _one_line(oiio.geterror()) or "unknown format"
        raise EnvMapFileError(f"{p}: cannot read image: {msg}")
    try:
        spec = inp.spec()
        h, w, c = _check_header(spec, p)
        notes = [] if _data_is_display(spec) else _window_notes(spec, p)
        dw, dh = int(spec.width), int(spec.height)
        c_out = min(c, 3) if c != 2 else 1
        nbytes = dh * dw * c * 4 + h * w * c_out * (4 + dt.itemsize)
        if notes:
            nbytes += dh * dw * c * 4 + 2 * h * w * c * 4   # ImageBuf, crop, its copy
        decode, decode_note = _display_decoding(spec) if linearize else (None, None)
        if decode is not None:
            nbytes += 2 * h * w * c * 4           # the ImageBuf and the converted copy
        check_memory(nbytes, f"reading {p.name} ({w}x{h}, {c} channels)",
                     hint="downscale the file with another tool first, or raise "
                          "ENVFIT_MEMORY_LIMIT if more memory is really available")
        pixels = inp.read_image(0, 0, 0, c, "float")
        err = inp.geterror() if inp.has_error else ""
        if pixels is None or err:
            msg = _one_line(err or oiio.geterror()) or "read failed"
            raise EnvMapFileError(f"{p}: corrupt or truncated image: {msg}")
        if inp.seek_subimage(1, 0):
            notes.append("the file holds several subimages/parts; used the first")
        inp.geterror()
    finally:
        inp.close()
    pixels = np.asarray(pixels, dtype=np.float32).reshape(dh, dw, c)
    if not _data_is_display(spec):
        pixels = _to_display_window(pixels, spec, p)
    if decode is not None:
        pixels = _decode_to_linear(pixels, spec, decode, p)
    if decode_note:
        notes.append(decode_note)
    return _select_channels(pixels, spec, notes), spec, notes


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
        pixels = _fix_nonfinite(pixels, bad)
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
    import OpenImageIO as oiio

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
    h, w, c = data.shape
    fmt, pixels = _encoded(data, ext, half, p)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=p.suffix, dir=p.parent)
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise EnvMapFileError(f"{p}: cannot write this format: "
                                  f"{_one_line(oiio.geterror())}")
        spec = oiio.ImageSpec(w, h, c, fmt)
        if c == 3:
            spec.channelnames = ("R", "G", "B")
        elif c == 1:
            spec.channelnames = ("Y",)
        if ext == ".exr":
            spec.attribute("compression", "zip")
            spec.attribute("envfit:up", up)
        ok = out.open(tmp, spec) and out.write_image(pixels)
        err = out.geterror() if not ok else ""
        ok = out.close() and ok
        if not ok:
            raise EnvMapFileError(f"{p}: write failed: "
                                  f"{_one_line(err or out.geterror() or oiio.geterror())}")
        os.chmod(tmp, 0o666 & ~current_umask())   # mkstemp makes 0600; the usual permissions
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return p

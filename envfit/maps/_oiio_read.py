"""Reading an image file's pixels with OpenImageIO for :func:`envfit.maps._io.load_envmap`:
the header checks (a 2:1 display window), the data window placed in the display window, the
display-referred colour decoding and the channel selection, each problem one line (the table
of :mod:`envfit.maps._io`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from envfit.base import EnvMapFileError, EnvMapFormatError
from envfit.base import check_memory

__all__ = ["LINEAR_SPACE", "one_line", "read_pixels"]


def one_line(msg: str) -> str:
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
    if _data_or_linear(cc, cs):
        return None, None
    name = "sRGB" if cc.equivalent(cs, "sRGB") else cs
    return cs, f"decoded {bits}-bit {name} to linear radiance {tail}"


def _data_or_linear(cc, cs: str) -> bool:
    """Whether colour space ``cs`` holds data or linear values (kept as they are):
    ``ColorConfig.isData`` / ``isColorSpaceLinear`` where OpenImageIO has them (3.1+); on
    3.0, which lacks both, ``cs`` equivalent to the configuration's data, linear or
    scene-linear space."""
    is_data = getattr(cc, "isData", None)
    is_linear = getattr(cc, "isColorSpaceLinear", None)
    if is_data is not None and is_linear is not None:
        return bool(is_data(cs) or is_linear(cc.resolve(cs)))
    return any(cc.equivalent(cs, ref) for ref in ("data", "linear", "scene_linear"))


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
                                f"radiance: {one_line(out.geterror())}")
    return np.asarray(out.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(h, w, c)


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
                                f"{one_line(out.geterror())}")
    h, w, c = int(spec.full_height), int(spec.full_width), pixels.shape[2]
    return np.asarray(out.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(h, w, c)


def read_pixels(p: Path, dt: np.dtype, linearize: bool) -> tuple[np.ndarray, object, list[str]]:
    """The first subimage's display window as float32 (H, W, C') linear values, its spec and
    the notes; the memory guard runs on the header before any pixel is read."""
    import OpenImageIO as oiio

    oiio.geterror()  # clear stale global errors
    inp = oiio.ImageInput.open(str(p))
    if inp is None:
        msg = one_line(oiio.geterror()) or "unknown format"
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
            msg = one_line(err or oiio.geterror()) or "read failed"
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

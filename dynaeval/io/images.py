"""Reading image files into float arrays in [0, 1], with the range taken from the dtype.

Supported: PNG (8 and 16 bit), JPEG, TIFF (8/16 bit, float), WebP, BMP via OpenCV; OpenEXR (float)
via the ``OpenEXR`` package; ``.npy.gz`` (a gzip'd NumPy array: nerfstudio's float renders,
``raw-rgb/``) via numpy, under the same range rule as a float file. Grayscale stays one channel ``(H, W, 1)``; RGB is returned in RGB order
(OpenCV's BGR is converted); RGBA is composited over a background colour (see ``composite_alpha``).

``decode`` chooses how a 16-bit PNG becomes [0, 1]: ``"dynaeval"`` (default) divides by 65535;
``"pil"`` keeps the high byte, ``(v >> 8) / 255``, as Pillow (and so NeRFBaselines'
``io.read_image``, ``np.array(PIL.Image.open(f))``) decodes 16-bit RGB and RGBA PNGs (Pillow has
no 16-bit colour mode). Pillow opens a 16-bit grey PNG as mode ``I;16`` and NeRFBaselines then
saturates it (``clip(v * 255, 0, 255)``): under ``"pil"`` such a file is an ``InputError``. Other
formats decode the same under both rules.

The format is taken from the file's content (its first bytes), not its name: a PNG named ``.jpg``
is read as the PNG it is. The extension only decides which files are images.

Value range (**one rule for every path**: the metrics, the detector, motion masks and temporal
terms all see the image as read here): uint8 / 255, uint16 / 65535; float files (EXR, float TIFF)
must hold values in [0, 1]. Values within ``FLOAT_TOLERANCE`` outside it (a renderer's rounding,
1.0000002) are clipped to [0, 1]; a float file with values further out (linear HDR above 1, a
float TIFF of 1e30) is an ``InputError`` naming the file and its min/max, with the fix (tone-map
or clip it to [0, 1], or save 8/16-bit). The range is never guessed from the pixel values.

Pixel types (**every one is read or refused by name**, an ``InputError`` naming the file, the
type and the fix, never a traceback): uint8 and uint16 as above (a 1-8 bit TIFF is decoded by
OpenCV to uint8 as displayed, so 1-bit black/white reads as 0 and 1); float32 and float64 (TIFF,
``.npy.gz``) and float16 (EXR half, ``.npy.gz``) as stored, float64 and float16 rounded to
float32 (the dtype every float file is scored in), under the float range rule. Refused: int8,
int16, int32, int64, uint32, uint64 (their range to [0, 1] is not defined: the rule of
``dynaeval.core.validation``), bool arrays, complex samples, untyped TIFF samples, OpenEXR UINT
channels, and half-float TIFFs (OpenCV cannot decode them). A TIFF's header (a ``.npy.gz``
file's too) is read for its type when ``find_frames`` lists it (``check_pixel_type``), so a run
stops before the work; a TIFF under another name is checked when decoded, and so is an EXR's
channel type.

Decoded frames are kept for reuse (``FrameCache``), so one scoring run decodes each file once
where memory allows. A camera's ground truth is read by several passes (motion masks, detector,
per-frame metrics, temporal terms) and its predictions by two; PNG decoding of a 1080p frame
costs about as much as its SSIM. ``FrameCache`` keeps decoded frames up to a byte budget. It never evicts: once full, the
frames already kept keep hitting and the rest are decoded on each read, so a sequential pass over
more frames than fit degrades to the uncached cost instead of thrashing as an LRU would.
"""

from __future__ import annotations

import os
import struct
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import FLOAT_TOLERANCE, as_image

ARRAY_EXTENSION = ".npy.gz"
"""A gzip'd NumPy array holding one image: nerfstudio's raw renders (``ns-render dataset
--rendered-output-names raw-rgb raw-gt-rgb`` writes ``np.save`` into ``gzip.open``), read as
stored (RGB order, the dtype's range)."""

IMAGE_EXTENSIONS = frozenset(
    {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".webp", ".bmp", ARRAY_EXTENSION}
)

BACKGROUNDS = {"white": 1.0, "black": 0.0}

STORED_RGB = ("exr", "array")
"""Kinds of ``decode_file`` that hold RGB(A) as stored, not OpenCV's BGR(A), at any depth."""

DECODES = ("dynaeval", "pil")
"""How 16-bit PNGs are mapped to [0, 1] (module docstring)."""

_EXR_MAGIC = b"\x76\x2f\x31\x01"
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_JPEG_MAGIC = b"\xff\xd8\xff"


def frame_name_parts(path: str | Path) -> tuple[str, str]:
    """``(frame name, extension)`` of an image file: ``("0007", ".png")`` for ``0007.PNG``,
    ``("0007", ".npy.gz")`` for ``0007.npy.gz`` (the one extension of two parts)."""
    name = Path(path).name
    if name.lower().endswith(ARRAY_EXTENSION) and len(name) > len(ARRAY_EXTENSION):
        return name[:-len(ARRAY_EXTENSION)], ARRAY_EXTENSION
    return Path(name).stem, Path(name).suffix.lower()


def _read_array(path: Path) -> np.ndarray:
    """The image array of a ``.npy.gz`` file, as stored: ``(H, W)`` or ``(H, W, C)``, C in 1-4,
    RGB(A) order; its dtype is checked by ``to_float``.

    Raises:
        InputError: not gzip'd, not a NumPy array file (or a pickle), or not an image's shape.
    """
    import gzip
    import io
    import zlib

    try:
        arr = np.load(io.BytesIO(gzip.decompress(_read_bytes(path))), allow_pickle=False)
    except (OSError, EOFError, ValueError, zlib.error) as err:
        raise InputError(
            f"cannot read this .npy.gz frame ({err}): it must be one NumPy array saved with "
            "np.save into gzip.open, as ns-render writes raw-rgb / raw-gt-rgb; render it again",
            path=path) from err
    if not isinstance(arr, np.ndarray) or arr.ndim not in (2, 3) or arr.size == 0 or (
            arr.ndim == 3 and arr.shape[2] > 4):
        shape = getattr(arr, "shape", type(arr).__name__)
        raise InputError(
            f"a .npy.gz frame must hold one image, (H, W) or (H, W, C) with C <= 4 channels last "
            f"(as ns-render writes), got {shape}; a channel-first (C, H, W) array needs "
            "arr.transpose(1, 2, 0)", path=path)
    return arr


def to_float(image: np.ndarray, path: str | Path | None = None) -> np.ndarray:
    """Convert an integer or float image to float32, dividing integers by the dtype's maximum.

    Args:
        image: (H, W) or (H, W, C) array, dtype uint8, uint16, float16, float32 or float64.
        path: file the image came from, for error messages.

    Returns:
        float32 array of the same shape; integers mapped to [0, 1] by ``x / iinfo(dtype).max``
        (the rule of ``dynaeval.core.validation.as_image``; NaN/Inf are checked by the caller).
    """
    return as_image(image, "image", finite=False, path=path)


def composite_alpha(rgba: np.ndarray, background: str | float) -> np.ndarray:
    """Blend an (H, W, 4) float image in [0, 1] (straight alpha) over a uniform background.

    ``out = rgb * a + bg * (1 - a)``, as Blender-style datasets (NeRF synthetic) are evaluated.

    Args:
        rgba: (H, W, 4) float32 in [0, 1], channels R, G, B, A.
        background: ``"white"``, ``"black"`` or a grey level in [0, 1].

    Returns:
        (H, W, 3) float32.
    """
    bg = BACKGROUNDS[background] if isinstance(background, str) else float(background)
    alpha = rgba[..., 3:4]
    return (rgba[..., :3] * alpha + np.float32(bg) * (1.0 - alpha)).astype(np.float32)


def _read_exr(path: Path) -> np.ndarray:
    try:
        import OpenEXR
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise InputError(
            "reading OpenEXR needs the 'openexr' package: pip install openexr", path=path
        ) from err
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = {name: np.asarray(c.pixels) for name, c in f.channels().items()}
    except Exception as err:  # OpenEXR raises bare RuntimeError/ValueError on corrupt files
        raise InputError(f"cannot read OpenEXR file ({err})", path=path) from err
    for names in (("R", "G", "B", "A"), ("R", "G", "B"), ("Y", "A"), ("Y",)):
        if all(n in channels for n in names):
            kinds = sorted({str(channels[n].dtype) for n in names
                            if channels[n].dtype.kind != "f"})
            if kinds:  # OpenEXR's UINT channels: integers, whose range is no float's
                _refuse_pixel_type(f"{', '.join(kinds)} (OpenEXR UINT channels)", path)
            planes = [channels[n].astype(np.float32) for n in names]
            return np.stack(planes, axis=-1)
    raise InputError(
        f"OpenEXR channels {sorted(channels)} hold no R,G,B or Y image", path=path
    )


def _jpeg_complete(raw: bytes) -> bool:
    """True when JPEG bytes end with the end-of-image marker (OpenCV decodes truncated JPEGs
    silently, filling the missing part with grey)."""
    return b"\xff\xd9" in raw[-64:]


_PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"
"""A PNG's last chunk: IEND, no data, so always these 12 bytes (length, type, CRC)."""


def check_complete(raw: bytes, path: Path) -> None:
    """Refuse JPEG and PNG bytes cut short, before a decoder sees them.

    A JPEG must end with its end-of-image marker (OpenCV fills a truncated one with grey); a PNG
    must hold its IEND chunk (libpng refuses one without it, but first prints "PNG input buffer
    is incomplete" on stderr, beside dynaeval's own message).

    Raises:
        InputError: truncated JPEG or PNG, naming ``path``.
    """
    if raw.startswith(_JPEG_MAGIC) and not _jpeg_complete(raw):
        raise InputError("truncated JPEG (no end-of-image marker)", path=path)
    if raw.startswith(_PNG_MAGIC) and raw.rfind(_PNG_END) < 0:
        raise InputError("truncated PNG (no IEND chunk)", path=path)


def _read_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except PermissionError as err:
        raise InputError("cannot read the file: permission denied (check its permissions, "
                         "e.g. chmod a+r)", path=path) from err
    except OSError as err:
        raise InputError(f"cannot read the file ({err.strerror or err})", path=path) from err


TIFF_EXTENSIONS = frozenset({".tif", ".tiff"})
"""Names whose header ``find_frames`` checks for the pixel type before the work
(``check_pixel_type``); a TIFF under another name is checked when decoded."""

TYPED_HEADERS = TIFF_EXTENSIONS | {ARRAY_EXTENSION}
"""Extensions whose header ``check_pixel_type`` reads (the others state no pixel type to
check)."""

_TIFF_MAGIC = {b"II*\x00": ("<", False), b"MM\x00*": (">", False),
               b"II+\x00": ("<", True), b"MM\x00+": (">", True)}
_TIFF_SAMPLE_KINDS = {1: "uint", 2: "int", 3: "float", 4: "void", 5: "complex int",
                      6: "complex float"}
_READ_DTYPES = frozenset(np.dtype(d) for d in ("uint8", "uint16", "float16", "float32", "float64"))
"""Pixel types read from a file: integers by ``UNIT_SCALE``, floats as stored (range rule)."""
_PIXEL_TYPE_FIX = ("dynaeval reads uint8 / 255, uint16 / 65535 and float values as stored in "
                   "[0, 1]; save it as an 8/16-bit PNG, or a 32-bit float TIFF (or EXR) with "
                   "values in [0, 1]")


def tiff_pixel_type(head: bytes, read_at: Any) -> tuple[str, int] | None:
    """``(sample kind, bits per sample)`` stated by a TIFF's first image (IFD), e.g.
    ``("int", 32)``; None when ``head`` (the file's first 16 bytes) is no TIFF or the header
    cannot be parsed (the decoder then names the file).

    Args:
        head: the file's first 16 bytes.
        read_at: ``read_at(offset, size) -> bytes`` reads the file at an offset.
    """
    kind = _TIFF_MAGIC.get(head[:4])
    if kind is None or len(head) < 16:
        return None
    order, big = kind
    word, count_fmt, entry = ("Q", "Q", 20) if big else ("I", "H", 12)
    try:
        ifd = struct.unpack_from(order + word, head, 8 if big else 4)[0]
        n = struct.unpack(order + count_fmt, read_at(ifd, struct.calcsize(count_fmt)))[0]
        entries = read_at(ifd + struct.calcsize(count_fmt), n * entry)
        found = {}
        for k in range(min(n, len(entries) // entry)):
            tag, typ = struct.unpack_from(order + "HH", entries, k * entry)
            if tag in (258, 339) and typ in (3, 4):  # BitsPerSample, SampleFormat: SHORT / LONG
                size = 2 if typ == 3 else 4
                count = struct.unpack_from(order + word, entries, k * entry + 4)[0]
                value = entries[k * entry + 4 + (8 if big else 4):][:8 if big else 4]
                if count * size > len(value):  # stored elsewhere: the first sample's
                    value = read_at(struct.unpack(order + word, value)[0], size)
                found[tag] = struct.unpack_from(order + ("H" if typ == 3 else "I"), value)[0]
    except (struct.error, OSError, ValueError, OverflowError):
        return None
    return _TIFF_SAMPLE_KINDS.get(found.get(339, 1), "unknown"), found.get(258, 1)


def _refuse_pixel_type(name: str, path: str | Path | None) -> None:
    raise InputError(f"unsupported pixel type {name}: it has no defined mapping to [0, 1] "
                     f"({_PIXEL_TYPE_FIX})", path=path)


def check_tiff_type(kind: tuple[str, int] | None, path: str | Path | None) -> None:
    """Refuse a TIFF whose stated pixel type (``tiff_pixel_type``) is not read: integers other
    than 1-8 bit (OpenCV gives uint8: 1-bit black/white is 0 and 1) or 16-bit unsigned, float
    other than 32/64 bit (OpenCV cannot decode half-float TIFFs), complex or untyped samples.

    Raises:
        InputError: naming the file, the pixel type and the fix.
    """
    if kind is None:
        return
    sample, bits = kind
    if sample == "uint" and (bits <= 8 or bits == 16) or sample == "float" and bits in (32, 64):
        return
    if sample == "float" and bits == 16:
        raise InputError("16-bit (half) float TIFF: OpenCV cannot decode it; save it as a 32-bit "
                         "float TIFF, or as EXR (half floats are read from EXR)", path=path)
    _refuse_pixel_type(f"{sample}{bits}" if " " not in sample else f"{sample} ({bits} bits)", path)


def _array_dtype(path: Path) -> np.dtype | None:
    """The dtype in a ``.npy.gz`` file's header (its first bytes decompressed), or None when
    it cannot be read (``_read_array`` then names the file)."""
    import gzip
    import zlib

    try:
        with gzip.open(path) as f:
            version = np.lib.format.read_magic(f)
            read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                    else np.lib.format.read_array_header_2_0)
            return np.dtype(read(f)[2])
    except (OSError, EOFError, ValueError, TypeError, zlib.error):
        return None


def check_pixel_type(path: str | Path) -> None:
    """Refuse an image file whose header states a pixel type that is not read (before any
    decoding: ``find_frames`` runs it on every TIFF it lists, so a run stops before the work).
    Only TIFF (``TIFF_EXTENSIONS``) and ``.npy.gz`` headers are read: PNG, JPEG, WebP and BMP
    hold 8/16-bit unsigned values, EXR floats (its UINT channels are refused when read).

    Raises:
        InputError: as ``check_tiff_type``; an unreadable file as ``_read_bytes``.
    """
    name = os.fspath(path).lower()  # not pathlib: run on every file listed
    if name.endswith(ARRAY_EXTENSION):
        dtype = _array_dtype(Path(path))
        if dtype is not None and dtype.newbyteorder("=") not in _READ_DTYPES:
            _refuse_pixel_type(str(dtype), path)
        return
    if not name.endswith(tuple(TIFF_EXTENSIONS)):
        return
    try:
        with open(path, "rb", buffering=0) as f:  # a few small reads
            def read_at(offset: int, size: int) -> bytes:
                f.seek(offset)
                return f.read(size)
            kind = tiff_pixel_type(f.read(16), read_at)
    except OSError:
        _read_bytes(path)  # names the file and the reason
        raise
    check_tiff_type(kind, path)


def check_decoded_type(image: np.ndarray, path: str | Path | None) -> np.ndarray:
    """The decoded array of an image file, in the machine's byte order, float64 (and float16)
    as float32 (the dtype every float file is scored in, rounded to nearest), other dtypes
    refused by name.

    Raises:
        InputError: a dtype outside ``_READ_DTYPES`` (int8/16/32/64, uint32/64, bool, complex).
    """
    if image.dtype.byteorder not in "=|":  # a big-endian array (np.save keeps the order)
        image = image.astype(image.dtype.newbyteorder("="))
    if image.dtype not in _READ_DTYPES:
        _refuse_pixel_type(str(image.dtype), path)
    return image.astype(np.float32) if image.dtype.kind == "f" and image.dtype != np.float32 \
        else image


def check_float_range(image: np.ndarray, path: str | Path | None = None) -> np.ndarray:
    """A float image read from a file, in [0, 1]: values within ``FLOAT_TOLERANCE`` outside it
    are clipped; further out raise InputError with the file's min/max and the fix."""
    lo, hi = float(image.min()), float(image.max())
    if lo >= 0.0 and hi <= 1.0:
        return image
    if lo < -FLOAT_TOLERANCE or hi > 1.0 + FLOAT_TOLERANCE:
        raise InputError(
            f"float pixel values must be in [0, 1], this file holds values in [{lo:.4g}, "
            f"{hi:.4g}]; tone-map or clip it to [0, 1] (e.g. np.clip(x, 0, 1)), or save it as "
            "8/16-bit PNG",
            path=path,
        )
    return np.clip(image, 0.0, 1.0)


def pil_png_bytes(image: np.ndarray, path: str | Path | None = None) -> np.ndarray:
    """A decoded 16-bit PNG as Pillow returns it: its high byte, ``v >> 8``, as uint8.

    Args:
        image: (H, W, 3) or (H, W, 4) uint16 as stored (8-bit images are returned unchanged).

    Raises:
        InputError: a 16-bit grey (or grey + alpha) PNG, which Pillow reads as ``I;16`` and
            NeRFBaselines saturates to 255.
    """
    if image.dtype != np.uint16:
        return image
    if image.ndim == 2 or image.shape[2] in (1, 2):
        raise InputError(
            "16-bit grey PNG: Pillow reads it as mode I;16 and NeRFBaselines saturates every "
            "non-zero value to 255, a number dynaeval does not reproduce; save it as RGB or use "
            "--protocol dynaeval",
            path=path,
        )
    return (image >> 8).astype(np.uint8)


def decode_file(path: str | Path) -> tuple[np.ndarray, str]:
    """An image file decoded as stored, and its kind by content (``"exr"``, ``"png"`` or
    ``"image"``; ``"array"`` for ``.npy.gz``, by name): OpenCV's channel order (BGR/BGRA) and
    dtype (uint8, uint16, float32: float64 and float16 rounded to it), or an EXR's float RGB
    data, or the array as saved (RGB); the checks of :func:`read_image` that need the file.

    Raises:
        InputError: missing, unreadable, truncated JPEG or PNG, unsupported extension, not an
            image, a pixel type that is not read (module docstring).
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path=path)
    ext = frame_name_parts(path)[1]
    if ext not in IMAGE_EXTENSIONS:
        raise InputError(
            f"unsupported image extension {ext!r}; expected one of {sorted(IMAGE_EXTENSIONS)}",
            path=path,
        )
    if ext == ARRAY_EXTENSION:
        return check_decoded_type(_read_array(path), path), "array"
    data = _read_bytes(path)
    if data.startswith(_EXR_MAGIC):
        return _read_exr(path), "exr"
    check_complete(data, path)
    check_tiff_type(tiff_pixel_type(data[:16], lambda at, n: data[at:at + n]), path)
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED) if data else None
    if image is None:
        raise InputError("cannot decode image (corrupt, truncated or not an image)", path=path)
    return check_decoded_type(image, path), "png" if data.startswith(_PNG_MAGIC) else "image"


def read_image(path: str | Path, *, background: str | float = "white",
               decode: str = "dynaeval", decoded: np.ndarray | None = None) -> np.ndarray:
    """Read one image file as float32 in [0, 1] (float files: as stored).

    Args:
        path: image file with an image extension; the format is taken from its content.
        background: colour that RGBA images are composited over (``composite_alpha``); images
            without alpha are unaffected.
        decode: ``"dynaeval"`` or ``"pil"``: how a 16-bit PNG maps to [0, 1] (module docstring).
        decoded: the file's :func:`decode_file` array when it is uint8 and not EXR, decoded
            beforehand (a prepared ground truth, ``dynaeval prepare``): the file is then not
            read again.

    Returns:
        (H, W, 3) or (H, W, 1) float32 array in [0, 1], RGB order. Grey+alpha gives (H, W, 1).

    Raises:
        InputError: the file is missing, unreadable (permissions), truncated, of an unsupported
            type or pixel type, holds NaN/Inf values, or float values outside [0, 1] (module
            docstring).
    """
    import cv2

    if decode not in DECODES:
        raise InputError(f"decode must be one of {', '.join(DECODES)}, got {decode!r}")
    path = Path(path)
    if decoded is not None and decoded.dtype != np.uint8:
        raise InputError(f"a decoded image given for it must be uint8, got {decoded.dtype}", path=path)
    image, kind = (decoded, "image") if decoded is not None else decode_file(path)
    if kind not in STORED_RGB:  # OpenCV's decoding (pil_png_bytes changes 16-bit PNGs only)
        if decode == "pil" and kind == "png":
            image = pil_png_bytes(image, path)
        if image.ndim == 3 and image.shape[2] in (3, 4):  # BGR(A) -> RGB(A), contiguous
            image = cv2.cvtColor(image, cv2.COLOR_BGR2RGB if image.shape[2] == 3
                                 else cv2.COLOR_BGRA2RGBA)
    stored_float = np.issubdtype(image.dtype, np.floating)
    image = to_float(np.ascontiguousarray(image), path=path)
    if image.ndim == 2:
        image = image[..., None]
    if stored_float and not np.all(np.isfinite(image)):  # integers divided by their maximum: finite
        bad = int(np.count_nonzero(~np.isfinite(image)))
        raise InputError(f"{bad} pixel values are NaN or Inf", path=path)
    if stored_float:  # integers divided by their maximum are in [0, 1] already
        image = check_float_range(image, path)
    if image.shape[2] == 4:
        image = composite_alpha(image, background)
    elif image.shape[2] == 2:  # grey + alpha
        grey = np.concatenate([np.repeat(image[..., :1], 3, axis=2), image[..., 1:]], axis=2)
        image = composite_alpha(grey, background)[..., :1]
    elif image.shape[2] not in (1, 3):
        raise InputError(f"unsupported channel count {image.shape[2]}", path=path)
    return np.ascontiguousarray(image)


class FrameCache:
    """Thread-safe store of decoded frames (read-only arrays), up to ``max_bytes``.

    ``decoded``: where image files decoded beforehand come from (``path -> uint8 array or
    None``: a prepared ground truth); a miss on such a file skips reading and decoding it.
    """

    def __init__(self, max_bytes: int,
                 decoded: Callable[[Path], np.ndarray | None] | None = None) -> None:
        self.max_bytes = int(max_bytes)
        self.decoded = decoded
        self.bytes = 0
        self.hits = 0
        self.misses = 0
        self._frames: dict[tuple[Any, str | float, str], np.ndarray] = {}
        self._lock = threading.Lock()

    def read(self, ref: Any, background: str | float = "white",
             decode: str = "dynaeval") -> np.ndarray:
        """The frame of ``ref`` (a ``dynaeval.io.frames.FrameRef``), from the cache when it was
        read before: an image file (``ref.image_file``) read here (``read_image``, from
        ``decoded`` where it has the file), other frames by ``ref.read(background, decode)``.

        Returns a read-only (H, W, C) float32 array: callers must not modify it in place.
        """
        key = (ref, background, decode)  # the whole reference: a K-Planes stack's parts share path and index
        with self._lock:
            frame = self._frames.get(key)
            if frame is not None:
                self.hits += 1
                return frame
            self.misses += 1
        file = ref.image_file  # None: a video frame, a part of a file
        if file is not None:
            raw = self.decoded(file) if self.decoded is not None else None
            frame = read_image(file, background=background, decode=decode, decoded=raw)
        else:
            frame = ref.read(background, decode)
        frame.flags.writeable = False
        with self._lock:
            if key not in self._frames and self.bytes + frame.nbytes <= self.max_bytes:
                self._frames[key] = frame
                self.bytes += frame.nbytes
        return frame

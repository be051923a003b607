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
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dynaeval.errors import InputError
from dynaeval.validation import FLOAT_TOLERANCE, as_image

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
        (the rule of ``dynaeval.validation.as_image``; NaN/Inf are checked by the caller).
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
    dtype (uint8, uint16, float), or an EXR's float RGB data, or the array as saved (RGB); the
    checks of :func:`read_image` that need the file.

    Raises:
        InputError: missing, unreadable, truncated JPEG or PNG, unsupported extension, not an
            image.
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
        return _read_array(path), "array"
    data = _read_bytes(path)
    if data.startswith(_EXR_MAGIC):
        return _read_exr(path), "exr"
    check_complete(data, path)
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED) if data else None
    if image is None:
        raise InputError("cannot decode image (corrupt, truncated or not an image)", path=path)
    return image, "png" if data.startswith(_PNG_MAGIC) else "image"


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
            type, holds NaN/Inf values, or float values outside [0, 1] (module docstring).
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

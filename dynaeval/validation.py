"""The one image validator: shape, dtype, value range and NaN/Inf checks shared by every layer.

**Range rule**: the unit of a pixel is stated, never guessed from the pixel values.

* ``to_unit=True`` (default; optical flow, temporal terms, detector, motion masks, image files):
  the image is wanted in ``[0, 1]``. uint8 is divided by 255, uint16 by 65535 (the dtype's
  maximum); floats are taken as they are (``check_range=True`` refuses values outside
  ``[0, 1]``); other integer types and bool are refused, since their range is unknown.
* image files: ``dynaeval.io.images.read_image`` applies the rule once, at reading time, so every
  path (``--focus none``, detector, motion masks, temporal terms) sees the same image: float
  files outside [0, 1] by more than ``FLOAT_TOLERANCE`` are an InputError naming the file and its
  min/max, rounding within it is clipped. Arrays passed to the library are checked here.
* ``to_unit=False`` (PSNR, SSIM, presence, LPIPS's pair check: metrics with an explicit
  ``data_range``): values are in ``[0, data_range]`` and are returned as they are; integer and
  float16 input is upcast to float32, **never divided**. So uint8 scored with ``data_range=255``
  equals ``uint8 / 255`` scored with ``data_range=1`` (``tests``: "uint8 scores like float/255").

Numpy only (torch tensors are recognised by duck typing and copied to CPU numpy): every layer may
import this module.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dynaeval.errors import InputError

UNIT_SCALE = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}
"""Integer dtypes read as ``x / dtype max`` when an image is wanted in [0, 1]."""


_U8_UNIT = np.arange(256, dtype=np.float32) / np.float32(255.0)
"""``v / 255`` in float32 for every uint8 value ``v``: the division done once per value."""


def unit_u8(arr: np.ndarray) -> np.ndarray:
    """uint8 ``arr`` of any shape as float32 ``arr / 255`` (the float32 division, bit for bit),
    by table lookup: one pass and one new float32 array, where ``astype`` then ``/`` made two
    of each (1.2 against 2.0 ms for a 1080p RGB frame in warm memory; the new arrays' page faults
    come on top)."""
    import cv2

    if arr.ndim in (2, 3) and (arr.ndim == 2 or arr.shape[2] <= 4) and arr.flags.c_contiguous:
        return cv2.LUT(arr, _U8_UNIT).reshape(arr.shape)  # OpenCV drops a trailing 1 channel
    return _U8_UNIT[arr]


def is_torch_tensor(x: object) -> bool:
    """True when ``x`` is a torch tensor (checked without importing torch)."""
    return type(x).__module__.startswith("torch") and hasattr(x, "detach")


def to_numpy(x: object, name: str) -> np.ndarray:
    """``x`` (numpy array, torch tensor or nested sequence) as a numpy array of numbers.

    Numpy input is not copied. Raises InputError for bool or non-numeric data.
    """
    if is_torch_tensor(x):
        x = x.detach().cpu().numpy()  # type: ignore[attr-defined]
    arr = np.asarray(x)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(
            f"{name} must hold numbers (float in [0, data_range] or integers), got dtype {arr.dtype}"
        )
    return arr


def as_image(
    x: object,
    name: str = "image",
    *,
    to_unit: bool = True,
    check_range: bool = False,
    finite: bool = True,
    channels: int | None = None,
    keep_float64: bool = False,
    path: str | Path | None = None,
) -> np.ndarray:
    """Validate one image and return it as a float numpy array of the same shape.

    Args:
        x: ``(H, W)`` or ``(H, W, C)`` numpy array or torch tensor (any device), H, W, C > 0.
        name: what the image is, for messages (``"pred"``, ``"frame 3"``).
        to_unit: True: return values in [0, 1] units (uint8 / 255, uint16 / 65535, floats as
            they are, other integers refused); False: keep the values (the caller's
            ``data_range`` is their unit; any integer or float dtype). See the module's rule.
        check_range: with ``to_unit``, refuse float values outside [0, 1] (never clipped).
        finite: refuse NaN / Inf values (False: the caller checks later).
        channels: require ``(H, W, channels)``.
        keep_float64: keep float64 input as float64; otherwise everything becomes float32.
        path: the file the image came from, named in messages.

    Returns:
        float32 (or float64 with ``keep_float64``) array; numpy float input of the returned
        dtype is not copied.
    """
    arr = _numbers(x, name, to_unit, path)
    if arr.ndim not in (2, 3):
        raise InputError(f"{name} must be (H, W) or (H, W, C), got shape {arr.shape}", path=path)
    if arr.size == 0:
        raise InputError(f"{name} is empty (shape {arr.shape}): need H, W, C > 0", path=path)
    if channels is not None and (arr.ndim != 3 or arr.shape[2] != channels):
        what = "an (H, W, 3) RGB image" if channels == 3 else f"(H, W, {channels})"
        raise InputError(f"{name} must be {what}, got shape {arr.shape}", path=path)
    scale = UNIT_SCALE.get(arr.dtype) if to_unit else None
    if scale is not None:  # integers: finite and in range
        return unit_u8(arr) if arr.dtype == np.uint8 else arr.astype(np.float32) / np.float32(scale)
    if arr.dtype != np.float32 and not (keep_float64 and arr.dtype == np.float64):
        arr = arr.astype(np.float32)
    if finite:
        check_finite_image(arr, name, path)
    if check_range and to_unit:
        check_unit_range(arr, name, path)
    return arr


def _numbers(x: object, name: str, to_unit: bool, path: str | Path | None) -> np.ndarray:
    if not to_unit:
        return to_numpy(x, name)
    arr = np.asarray(x.detach().cpu().numpy() if is_torch_tensor(x) else x)  # type: ignore[attr-defined]
    if arr.dtype not in UNIT_SCALE and not np.issubdtype(arr.dtype, np.floating):
        raise InputError(
            f"{name} has unsupported pixel type {arr.dtype}: expected uint8 or float in [0, 1] "
            "(or uint16, read as x / 65535)",
            path=path,
        )
    return arr


def check_finite_image(arr: np.ndarray, name: str, path: str | Path | None = None) -> None:
    """Raise InputError naming the image and the count when ``arr`` holds NaN or Inf."""
    if not np.isfinite(arr).all():
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise InputError(
            f"{name} contains {bad} NaN or Inf values, on which no number is defined (fix the "
            "renderer output or its loader, or replace them, e.g. with np.nan_to_num)",
            path=path,
        )


def check_unit_range(arr: np.ndarray, name: str, path: str | Path | None = None) -> None:
    """Raise InputError when float ``arr`` has values outside [0, 1] (they are never clipped)."""
    lo, hi = float(arr.min()), float(arr.max())
    if lo < 0.0 or hi > 1.0:
        raise InputError(
            f"{name}: float values must be in [0, 1], got values in [{lo:.4g}, {hi:.4g}]", path=path
        )


def check_pair(pred: object, gt: object, *, finite: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Validate an image pair for a metric with an explicit ``data_range`` (values kept).

    Accepts (H, W) or (H, W, C) arrays/tensors of equal shape; float16 and integer input is upcast
    to float32 (float64 stays float64), never divided. Raises InputError on a shape mismatch, a
    wrong rank, an empty image, or (unless ``finite=False``: the caller checks later) NaN/Inf
    pixels — a silent NaN score is never returned.
    """
    p = as_image(pred, "pred", to_unit=False, finite=False, keep_float64=True)
    g = as_image(gt, "gt", to_unit=False, finite=False, keep_float64=True)
    if p.shape != g.shape:
        raise InputError(
            f"pred and gt must have the same shape, got pred {p.shape} and gt {g.shape}; "
            "render the prediction at the ground truth's resolution"
        )
    if finite:
        check_finite(p, g)
    return p, g


def check_finite(p: np.ndarray, g: np.ndarray) -> None:
    """Raise InputError naming the image and the count when ``p`` or ``g`` holds NaN or Inf."""
    check_finite_image(p, "pred")
    check_finite_image(g, "gt")


def check_data_range(data_range: float) -> float:
    """``data_range`` as a positive finite float; raise InputError otherwise."""
    try:
        value = float(data_range)
    except (TypeError, ValueError):
        raise InputError(f"data_range must be a positive number, got {data_range!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise InputError(
            f"data_range must be a positive number (1.0 for float images in [0, 1], 255 for uint8), "
            f"got {data_range!r}"
        )
    return value


def grey_to_rgb(image: np.ndarray, name: str, what: str) -> np.ndarray:
    """``image`` as ``(H, W, 3)``: RGB unchanged, grayscale ``(H, W)`` / ``(H, W, 1)`` with the
    grey in each channel (what an RGB network sees of a grey photo); same dtype.

    Raises:
        InputError: another channel count (``what`` names the consumer, e.g. "LPIPS").
    """
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim == 3 and image.shape[2] == 1:
        return np.repeat(image, 3, axis=2)
    if image.ndim != 3 or image.shape[2] != 3:
        got = f"{image.shape[2]} channels" if image.ndim == 3 else f"shape {image.shape}"
        raise InputError(
            f"{what} needs RGB (H, W, 3) or grayscale (H, W) / (H, W, 1) images, got {name} with "
            f"{got} (composite RGBA over a background first)")
    return image

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
  Given the ``data_range`` (``check_pair(..., data_range=L)``, every metric function with one),
  the values are checked against it (``check_value_range``): an integer image with
  ``data_range <= 1`` is refused (its values are counts, 0..255 for uint8, never read as
  [0, 1]); a value below 0 or above L by more than ``FLOAT_TOLERANCE * L`` is refused naming
  the image, its min/max and the fixes (``data_range=255``, ``x / 255``, ``np.clip``); values
  within the tolerance are kept as they are. One min/max pass (about the cost of the NaN/Inf pass it
  replaces; NaN/Inf show in it, so it is also the finite check), none for an integer dtype that
  cannot leave [0, L] (uint8 with L >= 255). Callers that know the values are in range (frames
  read by ``dynaeval.io.images``, a batch ``ImageMetrics`` has checked) skip it inside
  ``values_known_in(hi)``.

**Layout rule**: images are channel-last, ``(H, W)`` or ``(H, W, C)``. A 3-D array whose first
axis is <= 4 and last axis > 4 (``(C, H, W)``) or a 4-D ``(B, C, H, W)`` one is refused with the
permute that fixes it (``channel_first_hint``), never scored as an image 3 pixels high.

Numpy only (torch tensors are recognised by duck typing and copied to CPU numpy): every layer may
import this module.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from dynaeval.core.errors import InputError

FLOAT_TOLERANCE = 1e-3
"""Float values this far outside [0, 1] (a fraction of ``data_range`` for the metrics) are a
renderer's rounding (1.0000002), not another unit: image files are clipped by it
(``dynaeval.io.images``), arrays given to a metric pass it unchanged; further out is refused."""

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
    data_range: float | None = None,
    clipped: bool = False,
) -> np.ndarray:
    """Validate one image and return it as a float numpy array of the same shape.

    Args:
        x: ``(H, W)`` or ``(H, W, C)`` numpy array or torch tensor (any device), H, W, C > 0;
            channel-first ``(C, H, W)`` is refused with the permute that fixes it.
        name: what the image is, for messages (``"pred"``, ``"frame 3"``).
        to_unit: True: return values in [0, 1] units (uint8 / 255, uint16 / 65535, floats as
            they are, other integers refused); False: keep the values (the caller's
            ``data_range`` is their unit; any integer or float dtype). See the module's rule.
        check_range: with ``to_unit``, refuse float values outside [0, 1] (never clipped).
        finite: refuse NaN / Inf values (False: the caller checks later).
        channels: require ``(H, W, channels)``.
        keep_float64: keep float64 input as float64; otherwise everything becomes float32.
        path: the file the image came from, named in messages.
        data_range: with ``to_unit=False``: refuse values outside ``[0, data_range]`` (the
            module's range rule, ``check_value_range``; also refuses NaN/Inf).
        clipped: with ``data_range``: the caller clips floats to the range (a protocol that
            does, as its tool does): overshoots up to ``CLIPPED_LIMIT`` times the range pass.

    Returns:
        float32 (or float64 with ``keep_float64``) array; numpy float input of the returned
        dtype is not copied.
    """
    arr = _numbers(x, name, to_unit, path)
    hint = channel_first_hint(arr.shape, is_torch_tensor(x))
    if hint is not None:
        raise InputError(f"{name} {hint}", path=path)
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
    if data_range is not None and not to_unit:
        check_value_range(arr, name, data_range, path, clipped=clipped)
        finite = False  # the range check's min/max saw every value: no NaN/Inf is left
    if arr.dtype != np.float32 and not (keep_float64 and arr.dtype == np.float64):
        arr = arr.astype(np.float32)
    if finite and not known_finite():
        check_finite_image(arr, name, path)
    if check_range and to_unit:
        check_unit_range(arr, name, path)
    return arr


def channel_first_hint(shape: tuple[int, ...], torch: bool = False) -> str | None:
    """What to do with an image of this shape that looks channel-first, or None when it does not.

    ``(C, H, W)``: 3-D, first axis <= 4 (the channels), last axis > 4 (no image here has more
    than 4 channels); ``(B, C, H, W)``: 4-D with the same on its last three axes. ``torch``:
    word the fix for a tensor (``permute``) rather than a numpy array (``np.moveaxis``).
    """
    shape = tuple(int(n) for n in shape)
    if len(shape) == 3 and shape[0] <= 4 < shape[2]:
        fix = "x.permute(1, 2, 0)" if torch else "np.moveaxis(x, 0, -1)"
        return (f"looks channel-first: shape {shape} read as (C, H, W); the metrics take "
                f"channel-last (H, W, C) images: pass {fix}")
    if len(shape) == 4 and shape[1] <= 4 < shape[3]:
        fix = "x[i].permute(1, 2, 0)" if torch else "np.moveaxis(x[i], 0, -1)"
        return (f"looks like a channel-first batch: shape {shape} read as (B, C, H, W); the "
                f"metric functions take one channel-last (H, W, C) image: pass {fix} for each "
                "image i, or feed the batch to dynaeval.metrics.ImageMetrics")
    return None


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


def check_pair(
    pred: object, gt: object, *, data_range: float | None = None, finite: bool = True,
    clipped: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Validate an image pair for a metric with an explicit ``data_range`` (values kept).

    Accepts (H, W) or (H, W, C) arrays/tensors of equal shape; float16 and integer input is upcast
    to float32 (float64 stays float64), never divided. ``data_range``: the values must lie in
    ``[0, data_range]`` (the module's range rule; skipped inside ``values_known_in``); None: not
    checked (protocol variants that clip); ``clipped``: the caller clips floats to the range,
    so overshoots up to ``CLIPPED_LIMIT`` times it pass (integers with ``data_range <= 1``
    and values further out, another unit, are refused). Raises InputError on a shape mismatch, a
    wrong rank, a channel-first layout, an empty image, values outside the range, or (unless
    ``finite=False``: the caller checks later) NaN/Inf pixels — a silent NaN score is never
    returned.
    """
    if data_range is not None and known_in_range(data_range):
        data_range = None
    kw = {"to_unit": False, "finite": False, "keep_float64": True, "data_range": data_range,
          "clipped": clipped}
    p, g = as_image(pred, "pred", **kw), as_image(gt, "gt", **kw)
    if p.shape != g.shape:
        raise InputError(
            f"pred and gt must have the same shape, got pred {p.shape} and gt {g.shape}; "
            "render the prediction at the ground truth's resolution"
        )
    if finite and data_range is None and not known_finite():  # else seen by the range check
        check_finite(p, g)
    return p, g


CLIPPED_LIMIT = 2.0
"""Under a protocol that clips (nerfbaselines, kplanes, dycheck clip renders to the range as those
tools do), values in ``[-(CLIPPED_LIMIT - 1), CLIPPED_LIMIT] * data_range`` are overshoots and
are clipped; values further out are another unit (a 0..255 float image would be clipped to white)
and are refused."""


def check_value_range(arr: np.ndarray, name: str, data_range: float,
                      path: str | Path | None = None, *, clipped: bool = False) -> None:
    """Raise InputError unless ``arr`` (numbers, any shape) holds values in ``[0, data_range]``.

    Integers: refused with ``data_range <= 1`` (uint8 holds 0..255, never read as [0, 1]); no
    pass over the pixels when the dtype cannot leave ``[0, data_range]``. Otherwise one min/max
    pass: values below ``-tol`` or above ``data_range + tol`` (``tol = FLOAT_TOLERANCE *
    data_range``) are refused with the image's min/max and the fixes; NaN/Inf are refused by
    ``check_finite_image``'s message. ``clipped``: the caller clips to the range (a protocol
    that clips overshoots, as its tool does), so only values beyond ``CLIPPED_LIMIT`` times the
    range are refused: another unit (0..255), not an overshoot.
    """
    data_range = check_data_range(data_range)
    if np.issubdtype(arr.dtype, np.integer):
        info = np.iinfo(arr.dtype)
        if data_range <= 1.0:
            top = info.max if info.max <= 65535 else 255
            raise InputError(
                f"{name} is {arr.dtype} (integer values, 0..{info.max}) but data_range is "
                f"{data_range:g}: integers are never read as [0, 1]; pass data_range={top}, or "
                f"{name} / {top} as float in [0, 1]", path=path)
        if info.min >= 0 and info.max <= data_range:
            return
    lo, hi = float(arr.min()), float(arr.max())
    if not (np.isfinite(lo) and np.isfinite(hi)):
        check_finite_image(arr, name, path)
    tol = (CLIPPED_LIMIT - 1 if clipped else FLOAT_TOLERANCE) * data_range
    if lo >= -tol and hi <= data_range + tol:
        return
    raise InputError(f"{name} holds values in [{lo:.4g}, {hi:.4g}], outside [0, data_range] = "
                     f"[0, {data_range:g}]: {_range_fix(lo, hi, data_range)}", path=path)


def _range_fix(lo: float, hi: float, data_range: float) -> str:
    """The fix for values in [lo, hi] outside [0, data_range], most likely cause first."""
    if lo < 0 and lo >= -1 - FLOAT_TOLERANCE and hi <= 1 + FLOAT_TOLERANCE:
        return ("images in [-1, 1] (a tanh output)? pass (x + 1) / 2; a render that overshoots "
                "[0, 1]: np.clip(x, 0, 1)")
    if 2 * data_range < hi <= 255 * (1 + FLOAT_TOLERANCE) and lo >= 0:
        return (f"0..255 values? pass data_range=255, or x / 255 to score in [0, "
                f"{data_range:g}]; a render that overshoots: np.clip(x, 0, {data_range:g})")
    return (f"pass the data_range the images use (data_range=255 for 0..255 values), or scale "
            f"them to [0, {data_range:g}] (x / 255 for 8-bit values; np.clip(x, 0, "
            f"{data_range:g}) for a render that overshoots)")


_KNOWN = threading.local()


@contextmanager
def values_known_in(hi: float, *, finite: bool = False) -> Iterator[None]:
    """Within this block (this thread), images are known to hold values in ``[0, hi]``: frames
    read by ``dynaeval.io.images`` (hi = 1), a batch ``ImageMetrics`` checked. ``check_pair``
    then skips its range pass for every ``data_range >= hi``; the NaN/Inf check stays unless
    ``finite``: the images are also known to be finite (frames read by ``dynaeval.io.images``:
    decoded from integer pixels, or float files it refused NaN/Inf in; the prepared ground truth
    is such a frame, its bytes hash-verified), and ``check_pair`` and ``as_image`` skip that
    pass too. The checks are made once where the values come in, not by every metric of every
    frame."""
    before = getattr(_KNOWN, "hi", None), getattr(_KNOWN, "finite", False)
    _KNOWN.hi, _KNOWN.finite = float(hi), bool(finite)
    try:
        yield
    finally:
        _KNOWN.hi, _KNOWN.finite = before


def known_in_range(data_range: float) -> bool:
    """True inside ``values_known_in(hi)`` with ``hi <= data_range``."""
    hi = getattr(_KNOWN, "hi", None)
    return hi is not None and hi <= check_data_range(data_range)


def known_finite() -> bool:
    """True inside ``values_known_in(hi, finite=True)``: this thread's images hold no NaN/Inf."""
    return getattr(_KNOWN, "finite", False)


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

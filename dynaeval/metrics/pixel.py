"""Pixel-wise metrics: PSNR (whole image, masked, focused), its sufficient statistics, 8-bit quantisation.

PSNR = 10 * log10(data_range**2 / MSE) in dB, MSE = mean of the squared error over the region's
pixels *and* channels, accumulated in float64. Identical images have MSE 0 and PSNR ``math.inf``
(the results layer writes it as JSON ``null`` with a reason; JSON has no infinity).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import check_data_range, check_finite, check_pair
from dynaeval.metrics._common import WholeOrRegion, clipped_boxes, region_mask

# float64 differences are formed in chunks of this many values (32 KB): the buffer stays in L1/L2
# cache, so the exact float64 accumulation costs little more than reading both images once.
_CHUNK = 4096


class SquaredErrorStats(NamedTuple):
    """Sufficient statistics of PSNR over one image (or a pool of images).

    ``sse``: sum of squared errors in (data units)**2, float64. ``count``: number of values summed
    (pixels x channels). ``mse = sse / count``. Add them up across frames to get the *pooled* MSE
    (torchmetrics' PSNR class); NeRF tables instead report the mean of per-frame PSNRs.
    """

    sse: float
    count: int

    def __add__(self, other: object) -> SquaredErrorStats:  # type: ignore[override]
        if not isinstance(other, SquaredErrorStats):
            return NotImplemented
        return SquaredErrorStats(self.sse + other.sse, self.count + other.count)


def _sse(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of (a - b)**2 over all values, differences and sum in float64.

    Fast path: OpenCV's ``norm(NORM_L2SQR)`` converts float32 to float64 *before* subtracting and
    accumulates in float64 (one pass, ~3 ms for a 1080p RGB pair; a test with values where a
    float32 subtraction would round holds it to the float64 reference). Not its ``mask=``
    variant: that one subtracts in float32 (relative error ~1e-9, measured). Fallback (dtypes or
    layouts OpenCV refuses, > 4 channels): ``_sse_numpy``.
    """
    if a.dtype != b.dtype:
        a, b = a.astype(np.float64), b.astype(np.float64)
    if a.ndim <= 2 or a.shape[2] <= 4:
        import cv2

        try:
            return float(cv2.norm(np.ascontiguousarray(a), np.ascontiguousarray(b), cv2.NORM_L2SQR))
        except cv2.error:  # pragma: no cover - layouts OpenCV refuses go to numpy
            pass
    return _sse_numpy(a, b)


def _sse_numpy(a: np.ndarray, b: np.ndarray) -> float:
    """Readable reference of ``_sse``: float64 differences in chunks of ``_CHUNK`` values."""
    a1 = a.reshape(-1)
    b1 = b.reshape(-1)
    buf = np.empty(min(_CHUNK, a1.size), dtype=np.float64)
    total = 0.0
    for i in range(0, a1.size, _CHUNK):
        d = buf[: min(_CHUNK, a1.size - i)]
        np.subtract(a1[i : i + _CHUNK], b1[i : i + _CHUNK], out=d, dtype=np.float64)
        total += float(np.dot(d, d))
    return total


def squared_error_stats(
    pred: object, gt: object, *, mask: object = None, boxes: object = None,
    data_range: float | None = None,
) -> SquaredErrorStats:
    """Sum of squared errors and the number of values over the whole image or a region.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays or tensors of equal shape, any float/int dtype.
        mask: optional bool (H, W): only these pixels count (all channels).
        boxes: optional (N, 4) ``[x_min, y_min, x_max, y_max]`` (max exclusive); their union
            counts, each pixel once. Not together with ``mask``.
        data_range: when given, both images must hold values in [0, data_range]
            (``dynaeval.core.validation.check_value_range``); None: any values.

    Returns:
        ``SquaredErrorStats(sse, count)``, sse in squared data units (float64), count = pixels x C.

    Raises:
        InputError (shapes, NaN/Inf, values outside [0, data_range]), EmptyRegionError (region
        with no pixel).
    """
    # NaN/Inf anywhere are an error, also outside the region; the whole frame checks them only
    # when its sum is not finite (saves a pass)
    region = mask is not None or boxes is not None
    p, g = check_pair(pred, gt, data_range=data_range, finite=region)
    h, w = p.shape[:2]
    channels = 1 if p.ndim == 2 else p.shape[2]
    if boxes is not None and mask is None:
        # the union of the boxes as disjoint rectangles: each pixel once, only the boxes are read
        rects = disjoint_rectangles(clipped_boxes(boxes, h, w))
        sse = sum(_sse(p[y0:y1, x0:x1], g[y0:y1, x0:x1]) for x0, y0, x1, y1 in rects)
        count = sum(int((x1 - x0) * (y1 - y0)) for x0, y0, x1, y1 in rects)
        return SquaredErrorStats(float(sse), count * channels)
    m = region_mask(mask, boxes, h, w)
    if m is None:
        sse = _sse(p, g)
        if not math.isfinite(sse):
            check_finite(p, g)
            raise InputError(
                "the squared error overflows float64 (values of 1e154 and more): scale the "
                "images and data_range down"
            )
        return SquaredErrorStats(sse, p.size)
    # only the mask's bounding box is read
    rows = np.flatnonzero(m.any(axis=1))
    cols = np.flatnonzero(m.any(axis=0))
    y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    sub = m[y0:y1, x0:x1]
    pc, gc = p[y0:y1, x0:x1], g[y0:y1, x0:x1]
    count = int(np.count_nonzero(sub))
    sse = _sse(pc, gc) if count == sub.size else _sse(pc[sub], gc[sub])
    return SquaredErrorStats(sse, count * channels)


def disjoint_rectangles(boxes: np.ndarray) -> list[tuple[int, int, int, int]]:
    """The union of (N, 4) boxes (clipped, max exclusive) as disjoint ``(x0, y0, x1, y1)`` rectangles.

    Sweep over the rows between consecutive box edges; in each such band the x-intervals of the
    boxes spanning it are merged. Every pixel of the union is in exactly one rectangle.
    """
    edges = sorted(set(boxes[:, 1].tolist()) | set(boxes[:, 3].tolist()))
    out: list[tuple[int, int, int, int]] = []
    for y0, y1 in zip(edges[:-1], edges[1:], strict=False):
        spans = sorted(
            (int(b[0]), int(b[2])) for b in boxes if b[1] <= y0 and b[3] >= y1
        )
        merged: list[list[int]] = []
        for x0, x1 in spans:
            if merged and x0 <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], x1)
            else:
                merged.append([x0, x1])
        out.extend((x0, y0, x1, y1) for x0, x1 in merged)
    return out


def psnr_from_stats(stats: SquaredErrorStats, *, data_range: float = 1.0) -> float:
    """PSNR in dB from ``SquaredErrorStats``; ``math.inf`` when the squared error is 0."""
    data_range = check_data_range(data_range)
    if stats.count <= 0:
        raise InputError(f"PSNR needs at least one value, got count={stats.count}")
    if stats.sse == 0.0:
        return math.inf
    mse = stats.sse / stats.count
    return 10.0 * math.log10(data_range * data_range / mse)


def psnr(
    pred: object,
    gt: object,
    *,
    data_range: float = 1.0,
    mask: object = None,
    boxes: object = None,
) -> float:
    """Peak signal-to-noise ratio in dB, over the whole image, a mask, or the union of boxes.

    Args:
        pred, gt: (H, W) or (H, W, C) numpy arrays or torch tensors of equal shape, channel
            last; float in [0, data_range] (float16 is upcast) or integers with ``data_range``
            set (255 for uint8). Values outside [0, data_range] (beyond a 1e-3 * data_range
            rounding tolerance) and integers with ``data_range <= 1`` are refused.
        data_range: peak value L, explicit (never inferred from the pixels).
        mask: optional bool (H, W): PSNR of the masked pixels alone (MSE divided by the mask's
            pixel count, never by the frame's).
        boxes: optional (N, 4) int ``[x_min, y_min, x_max, y_max]``, max exclusive; the union of
            the boxes clipped to the image, each pixel counted once.

    Returns:
        ``10 * log10(L**2 / MSE)`` in dB as a Python float; ``math.inf`` for identical images.

    Raises:
        InputError: shapes differ, channel-first layout, values outside [0, data_range] (e.g.
            uint8 with data_range=1), NaN/Inf pixels, bad mask/boxes/data_range.
        EmptyRegionError: the mask or boxes hold no pixel.
    """
    stats = squared_error_stats(pred, gt, mask=mask, boxes=boxes, data_range=data_range)
    return psnr_from_stats(stats, data_range=data_range)


def psnr_float32(pred: object, gt: object, *, data_range: float = 1.0, clip: bool = False) -> float:
    """PSNR in dB from a float32 mean squared error (as NeRFBaselines and torchmetrics compute it).

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range].
        data_range: peak value L.
        clip: clip both images to [0, 1] first (NeRFBaselines' input normalisation).

    Returns:
        ``10 log10(L^2 / MSE)`` as a Python float; ``math.inf`` for identical images.
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    p32, g32 = p.astype(np.float32), g.astype(np.float32)
    if clip:
        p32, g32 = np.clip(p32, 0, 1), np.clip(g32, 0, 1)
    d = p32 - g32
    mse = float(np.mean(d * d, dtype=np.float32))
    if mse == 0.0:
        return math.inf
    return 10.0 * math.log10(data_range * data_range / mse)


QUANTIZE_MODES = ("none", "round", "truncate")


def quantize(img: object, mode: str = "none") -> np.ndarray:
    """Quantise a float image in [0, 1] to 8 bit and back, as other evaluators do before scoring.

    Args:
        img: (H, W) or (H, W, C) float array/tensor in [0, 1] (values outside are clipped first).
        mode: ``"none"`` (returned unchanged, as float32/float64), ``"round"``
            (``round(x * 255) / 255``, numpy rounding, ties to even; what ``np.round(x * 255)
            .astype(np.uint8)`` writers do) or ``"truncate"`` (``floor(x * 255) / 255``, what
            ``(x * 255).astype(np.uint8)`` does).

    Returns:
        Float array of the same shape, values k/255 (float32 unless the input was float64).

    Raises:
        InputError: unknown mode, non-numeric input or NaN/Inf pixels.
    """
    if mode not in QUANTIZE_MODES:
        raise InputError(f"quantize mode must be one of {', '.join(QUANTIZE_MODES)}, got {mode!r}")
    arr, _ = check_pair(img, img)
    if mode == "none":
        return arr
    scaled = np.clip(arr, 0.0, 1.0) * 255.0
    q = np.round(scaled) if mode == "round" else np.floor(scaled)
    return (q / 255.0).astype(arr.dtype)


def build_psnr(ctx: Any) -> Any:
    """The registry's PSNR for a run (``dynaeval.metrics.registry.FrameContext``): the protocol's
    whole-frame PSNR, dynaeval's ``psnr`` over a region (``{"boxes": ...}`` / ``{"mask": ...}``)."""
    return WholeOrRegion(ctx.whole().whole_psnr, psnr, ctx.data_range)

"""Box geometry: the region format shared by detectors, motion masks, boxes files and metrics.

A box is ``[x_min, y_min, x_max, y_max]`` in integer pixels, **max exclusive** (the tight box of a
mask's pixels ``ys, xs`` is ``[xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]``), so that
``image[y_min:y_max, x_min:x_max]`` is exactly the box. A set of boxes is an ``(N, 4)`` int64 array.
IoU and NMS also take float boxes (a detector's raw output), same ``xyxy`` order.

Ground floor: numpy only; every layer (io, metrics, regions, evaluate) may import it. Expansion
presets and merging stay in ``dynaeval.regions.expand`` (no metric needs them).
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.errors import InputError


def as_boxes(boxes: object) -> np.ndarray:
    """Return ``boxes`` as an ``(N, 4)`` int64 array (``N`` may be 0); raise InputError otherwise.

    ``boxes``: one box or ``(N, 4)`` ``[x_min, y_min, x_max, y_max]`` in whole pixels, any numeric
    dtype (a float array is accepted when every value is an integer, e.g. ``10.0``). Refused:
    fractional coordinates (say how to round, as a detector's raw output needs: floor the min,
    ceil the max, as ``dynaeval``'s detectors do) and inverted boxes (``x_max < x_min`` or
    ``y_max < y_min``); an empty box (``max == min``) is accepted and holds no pixel.
    """
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 4), dtype=np.int64)
    if arr.ndim == 1 and arr.shape[0] == 4:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise InputError(f"boxes must have shape (N, 4) as [x_min, y_min, x_max, y_max], got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("boxes contain NaN or Inf coordinates")
    fractional = np.flatnonzero((arr != np.round(arr)).any(axis=1))
    if fractional.size:
        i = int(fractional[0])
        raise InputError(
            f"box {i} {arr[i].tolist()} has fractional pixel coordinates: boxes are whole pixels "
            "[x_min, y_min, x_max, y_max], max exclusive; round outwards first "
            "(np.floor of x_min, y_min and np.ceil of x_max, y_max)"
        )
    out = arr.astype(np.int64)
    inverted = np.flatnonzero((out[:, 2] < out[:, 0]) | (out[:, 3] < out[:, 1]))
    if inverted.size:
        raise InputError(f"box {int(inverted[0])}: {inverted_box_problem(out[inverted[0]])}")
    return out


def inverted_box_problem(box: object) -> str | None:
    """What is wrong with a box whose corners are swapped (``x_max < x_min`` or ``y_max <
    y_min``), as a message with the fix; None when the box is in order (empty boxes included).

    ``box``: ``[x_min, y_min, x_max, y_max]``, 4 integers.
    """
    x0, y0, x1, y1 = (int(v) for v in box)  # type: ignore[attr-defined]
    if x1 >= x0 and y1 >= y0:
        return None
    axis = "x" if x1 < x0 else "y"
    return (f"inverted box {[x0, y0, x1, y1]}: {axis}_max must be >= {axis}_min (the order is "
            "[x_min, y_min, x_max, y_max]; swap the corners)")


def clip_boxes(boxes: object, height: int, width: int) -> np.ndarray:
    """Clip boxes to an image of ``height x width`` pixels; boxes left empty are dropped.

    Negative coordinates (an expanded box near the border) are clipped to 0, never wrapped around
    as Python slicing would do with ``image[-5:20]``.
    """
    b = as_boxes(boxes).copy()
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, width)
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, height)
    keep = (b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])
    return b[keep]


def boxes_to_mask(boxes: object, height: int, width: int) -> np.ndarray:
    """Union of the boxes as a boolean ``(height, width)`` mask (a pixel in two boxes counts once)."""
    mask = np.zeros((height, width), dtype=bool)
    for x0, y0, x1, y1 in clip_boxes(boxes, height, width):
        mask[y0:y1, x0:x1] = True
    return mask


def mask_to_box(mask: np.ndarray) -> np.ndarray | None:
    """Tight box of the True pixels of a 2-D mask, max exclusive; None when the mask is empty."""
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return None
    return np.array([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], dtype=np.int64)


def grow_box(box: np.ndarray, min_h: int, min_w: int, height: int, width: int, *,
             odd_pixel: str = "after") -> np.ndarray:
    """Grow a box symmetrically to at least ``min_h x min_w``, shifted to stay inside the image.

    ``box``: ``[x_min, y_min, x_max, y_max]`` int px, max exclusive, inside a ``height x width``
    image. Returns a ``(4,)`` int64 box. The added pixels are the real neighbours of the box (never
    zero padding). When an odd number of pixels is added, ``odd_pixel`` says where the extra one
    goes: ``"after"`` (right / below; SSIM and LPIPS crops) or ``"before"`` (left / above; the tLP
    crop). If the image itself is smaller than the minimum in a dimension, that dimension becomes
    the whole image. A side already at least the minimum is left as is.
    """
    if odd_pixel not in ("after", "before"):
        raise InputError(f"odd_pixel must be 'after' or 'before', got {odd_pixel!r}")
    after = odd_pixel == "after"
    x0, y0, x1, y1 = (int(v) for v in box)
    x0, x1 = _grow_1d(x0, x1, min_w, width, after)
    y0, y1 = _grow_1d(y0, y1, min_h, height, after)
    return np.array([x0, y0, x1, y1], dtype=np.int64)


def _grow_1d(lo: int, hi: int, size: int, extent: int, after: bool) -> tuple[int, int]:
    if hi - lo >= size:
        return lo, hi
    if size >= extent:
        return 0, extent
    extra = size - (hi - lo)
    lo -= extra // 2 if after else (extra + 1) // 2
    hi = lo + size
    if lo < 0:
        lo, hi = 0, size
    if hi > extent:
        lo, hi = extent - size, extent
    return lo, hi


def box_iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of boxes ``a (M, 4)`` with ``b (N, 4)`` (xyxy) as ``(M, N)``; 0 where the union is 0.

    Float boxes are used in their own dtype; integer (or bool) boxes as float64."""
    a, b = (x if np.issubdtype(x.dtype, np.floating) else x.astype(np.float64)
            for x in (np.asarray(a), np.asarray(b)))
    iw = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    ih = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def nms(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float, block: int = 256) -> np.ndarray:
    """Greedy non-maximum suppression (same rule as ``torchvision.ops.nms``).

    ``boxes``: ``(N, 4)`` float xyxy; ``scores``: ``(N,)``. Returns int64 indices of the kept boxes
    by decreasing score; a box is dropped when its IoU with a kept, higher-scored box is
    ``> iou_threshold``. IoUs are computed for ``block`` boxes at a time against all lower-scored
    ones (memory ``block x N``), then the greedy pass only ORs boolean rows. The cost is quadratic
    in ``N`` (about N^2 / 2 IoUs): keep the score threshold above the detector's noise floor.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    order = np.argsort(-np.asarray(scores, dtype=np.float64), kind="stable")
    b = boxes[order]
    n = b.shape[0]
    removed = np.zeros(n, dtype=bool)
    keep: list[int] = []
    for lo in range(0, n, block):
        hi = min(n, lo + block)
        suppress = box_iou_matrix(b[lo:hi], b[lo:]) > iou_threshold  # (hi - lo, n - lo)
        for r in range(hi - lo):
            if removed[lo + r]:
                continue
            keep.append(lo + r)
            removed[lo:] |= suppress[r]  # rows before lo + r are already decided
    return order[np.asarray(keep, dtype=np.int64)]


def batched_nms(boxes: np.ndarray, scores: np.ndarray, class_ids: np.ndarray, iou_threshold: float) -> np.ndarray:
    """NMS within each class independently (boxes of different classes never suppress each other).

    Same contract as ``nms``; implemented by shifting each class's boxes to its own disjoint area.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if boxes.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    span = float(boxes.max() - min(boxes.min(), 0.0)) + 1.0
    shifted = boxes + (np.asarray(class_ids, dtype=np.float64) * span)[:, None]
    return nms(shifted, scores, iou_threshold)

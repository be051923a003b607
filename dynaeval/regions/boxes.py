"""Boxes: the region format shared by detectors, motion masks, boxes files and focused metrics.

A box is ``[x_min, y_min, x_max, y_max]`` in integer pixels, **max exclusive** (the tight box of a
mask's pixels ``ys, xs`` is ``[xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]``), so that
``image[y_min:y_max, x_min:x_max]`` is exactly the box. A set of boxes is an ``(N, 4)`` int64 array.
"""

from __future__ import annotations

import numpy as np

from dynaeval.errors import InputError


def as_boxes(boxes: object) -> np.ndarray:
    """Return ``boxes`` as an ``(N, 4)`` int64 array (``N`` may be 0); raise InputError otherwise."""
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 4), dtype=np.int64)
    if arr.ndim == 1 and arr.shape[0] == 4:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise InputError(f"boxes must have shape (N, 4) as [x_min, y_min, x_max, y_max], got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("boxes contain NaN or Inf coordinates")
    return np.round(arr).astype(np.int64)


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

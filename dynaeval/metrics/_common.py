"""Shared input checks for the image metrics: image pairs, masks and boxes -> one region.

Everything here is numpy only (no torch import): a torch tensor is recognised by duck typing and
copied to a numpy array, so ``import dynaeval.metrics`` and PSNR/SSIM stay light.
"""

from __future__ import annotations

import numpy as np

from dynaeval.boxes import boxes_to_mask, clip_boxes
from dynaeval.boxes import grow_box as grow_box  # re-export: structural.py and perceptual.py use it
from dynaeval.errors import EmptyRegionError, InputError


def is_torch_tensor(x: object) -> bool:
    """True when ``x`` is a torch tensor (checked without importing torch)."""
    return type(x).__module__.startswith("torch") and hasattr(x, "detach")


def to_numpy(x: object, name: str) -> np.ndarray:
    """``x`` (numpy array, torch tensor or nested sequence) as a numpy array, without copying numpy input."""
    if is_torch_tensor(x):
        x = x.detach().cpu().numpy()  # type: ignore[attr-defined]
    arr = np.asarray(x)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(
            f"{name} must hold numbers (float in [0, data_range] or integers), got dtype {arr.dtype}"
        )
    return arr


def check_pair(pred: object, gt: object, *, finite: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Validate an image pair and return it as numpy arrays of a float type.

    Accepts (H, W) or (H, W, C) arrays/tensors of equal shape; float16 and integer input is upcast
    to float32 (float64 stays float64). Raises InputError on a shape mismatch, a wrong rank, an
    empty image, or (unless ``finite=False``: the caller checks later) NaN/Inf pixels — a silent
    NaN score is never returned.
    """
    p = to_numpy(pred, "pred")
    g = to_numpy(gt, "gt")
    if p.shape != g.shape:
        raise InputError(
            f"pred and gt must have the same shape, got pred {p.shape} and gt {g.shape}; "
            "render the prediction at the ground truth's resolution"
        )
    if p.ndim not in (2, 3):
        raise InputError(f"images must be (H, W) or (H, W, C), got shape {p.shape}")
    if p.size == 0:
        raise InputError(f"images are empty (shape {p.shape})")
    if p.dtype != np.float64 and p.dtype != np.float32:
        p = p.astype(np.float32)
    if g.dtype != np.float64 and g.dtype != np.float32:
        g = g.astype(np.float32)
    if finite:
        check_finite(p, g)
    return p, g


def check_finite(p: np.ndarray, g: np.ndarray) -> None:
    """Raise InputError naming the image and the count when ``p`` or ``g`` holds NaN or Inf."""
    for name, a in (("pred", p), ("gt", g)):
        if not np.isfinite(a).all():
            bad = int(np.count_nonzero(~np.isfinite(a)))
            raise InputError(
                f"{name} contains {bad} NaN or Inf values; a metric of such pixels is undefined "
                "(fix the renderer output or replace them, e.g. np.nan_to_num, before scoring)"
            )


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


def region_mask(mask: object, boxes: object, height: int, width: int) -> np.ndarray | None:
    """The region to score as a boolean (height, width) mask, or None for the whole image.

    ``mask``: boolean (height, width) array (0/1 integers are accepted). ``boxes``: (N, 4)
    ``[x_min, y_min, x_max, y_max]`` max exclusive, clipped to the image; their union counts each
    pixel once. Passing both raises InputError; a region with no pixel raises EmptyRegionError.
    """
    if mask is not None and boxes is not None:
        raise InputError("pass either mask or boxes, not both (intersect them yourself if that is meant)")
    if mask is None and boxes is None:
        return None
    if mask is not None:
        m = mask.detach().cpu().numpy() if is_torch_tensor(mask) else np.asarray(mask)  # type: ignore[union-attr]
        if m.ndim == 3 and m.shape[2] == 1:
            m = m[..., 0]
        if m.shape != (height, width):
            raise InputError(
                f"mask must have the image's shape ({height}, {width}), got {m.shape}"
            )
        if m.dtype != bool:
            if not (np.issubdtype(m.dtype, np.integer) or np.issubdtype(m.dtype, np.floating)) or not np.isin(m, (0, 1)).all():
                raise InputError(
                    f"mask must be boolean (or 0/1), got dtype {m.dtype} with other values; "
                    "threshold soft weights first, e.g. mask = weights > 0.5"
                )
            m = m.astype(bool)
        if not m.any():
            raise EmptyRegionError("the mask holds no pixel: the metric is undefined for this frame")
        return m
    m = boxes_to_mask(boxes, height, width)
    if not m.any():
        raise EmptyRegionError(
            "no box has a pixel inside the image: the metric is undefined for this frame"
        )
    return m


def clipped_boxes(boxes: object, height: int, width: int) -> np.ndarray:
    """Boxes clipped to the image, (N, 4) int64; raise EmptyRegionError when none is left."""
    b = clip_boxes(boxes, height, width)
    if len(b) == 0:
        raise EmptyRegionError(
            "no box has a pixel inside the image: the metric is undefined for this frame"
        )
    return b

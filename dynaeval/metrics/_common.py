"""The region a metric scores: a mask or boxes -> one boolean mask, or clipped boxes.

Numpy only. The image checks live in the ground floor's ``dynaeval.core.validation``, the box
geometry in ``dynaeval.core.boxes``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from dynaeval.core.boxes import boxes_to_mask, clip_boxes
from dynaeval.core.errors import EmptyRegionError, InputError
from dynaeval.core.validation import is_torch_tensor


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


@dataclass(frozen=True)
class WholeOrRegion:
    """``fn(pred, gt, region)`` for the registry (PSNR, SSIM): a protocol's whole-frame
    variant ``whole(pred, gt, data_range=...)`` when ``region`` is ``{}`` or ``{"weights": ...}``
    (a given mask the protocol itself uses: ``Protocol.masks``), else dynaeval's
    ``regional(pred, gt, data_range=..., **region)`` (over ``boxes`` or ``mask``).

    ``on(region)`` is the function the region picks, ``(pred, gt) -> float``: a run's frame
    stage calls it directly, so the value comes from the metric with no hop between."""

    whole: Callable[..., float]
    regional: Callable[..., float]
    data_range: float

    def on(self, region: dict[str, Any]) -> Callable[[Any, Any], float]:
        """The metric function for ``region``, its arguments bound."""
        if "weights" in region:
            return partial(self.whole, data_range=self.data_range, weights=region["weights"])
        if region:
            return partial(self.regional, data_range=self.data_range, **region)
        return partial(self.whole, data_range=self.data_range)

    def __call__(self, pred: Any, gt: Any, region: dict[str, Any]) -> float:
        return self.on(region)(pred, gt)

"""Given masks as a frame's region: the weights for a protocol, the thresholded mask for
dynaeval's ``masked_*`` (``dynaeval.io.masks`` finds and reads them)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dynaeval.io.masks import THRESHOLD
from dynaeval.regions.focus import FrameRegions


def with_given_mask(r: FrameRegions, weights: np.ndarray, source: str) -> FrameRegions:
    """``r`` whose ``masked_*`` region is the given mask (weights > ``THRESHOLD``) instead of
    the motion mask, and whose ``weights`` are the mask's values for the protocol.

    Args:
        weights: (H, W) float32 in [0, 1], the frame's mask as read.
        source: the mask file, named when the mask holds no pixel.
    """
    m = weights > THRESHOLD
    reason = None if m.any() else f"the given mask {source} holds no pixel above {THRESHOLD}"
    return replace(r, mask=m if m.any() else None, mask_reason=reason, weights=weights)

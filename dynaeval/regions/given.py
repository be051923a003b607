"""Given masks as the frames' masked region (``dynaeval.io.masks`` finds and reads them).

They replace the motion masks wherever a mask is used: the ``masked_*`` metrics (pixels with
weight > ``THRESHOLD``), the static region of the temporal terms (pixels in no frame's mask) and
the report's mask outline. Boxes of ``--focus motion`` still come from the motion masks, the
only motion masks a run with given masks finds (``RegionSources.given_masks``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from dynaeval.core.outcome import Outcome, Status
from dynaeval.io.masks import THRESHOLD, MaskSet, read_mask
from dynaeval.regions.focus import CameraRegions, FrameRegions
from dynaeval.regions.packed import PackedMask
from dynaeval.regions.static_camera import CameraMotion, moving_camera_reason


def given_masks(regions: CameraRegions, gt_paths: Sequence[Path],
                masks: MaskSet, focus: str = "none") -> CameraRegions:
    """``regions`` with each frame's mask replaced by its given mask (weights > ``THRESHOLD``),
    or None with the reason when the given mask holds no such pixel, and the camera's
    moving-camera note (``CameraRegions.motion``) said for given masks: masked_* are
    theirs, so only flicker's static pixels (and ``motion`` boxes) are touched by a moving
    camera (it said "masked_* values are close to the whole-frame ones"). The same for
    regions found here and read from a prepared ground truth.

    Args:
        gt_paths: the ground-truth file of each frame (its mask is found from it).
        focus: the run's focus source (``motion`` boxes come from motion masks).
    """
    motion = regions.motion
    if motion is not None:
        px = motion.global_motion_px
        motion = CameraMotion(px, moving_camera_reason(px, None, focus, given_masks=True))
    out = []
    for r, gt in zip(regions.frames, gt_paths, strict=True):
        path = masks.path_of(gt)
        m = read_mask(path, masks.decode) > THRESHOLD
        reason = None if m.any() else f"the given mask {path} holds no pixel above {THRESHOLD}"
        out.append(replace(r, packed_mask=PackedMask.pack(m) if m.any() else None,
                           mask_missing=None if m.any() else Outcome(None, Status.EMPTY_REGION,
                                                                     reason)))
    return replace(regions, frames=out, motion=motion)


def with_weights(r: FrameRegions, gt_path: Path, masks: MaskSet) -> FrameRegions:
    """``r`` with the given mask's weights ((H, W) float32 in [0, 1]) for a protocol that uses
    them (``Protocol.masks`` ``multiply`` or ``covisible``)."""
    return replace(r, weights=read_mask(masks.path_of(gt_path), masks.decode))

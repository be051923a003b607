"""What a run's regions hold, and what to tell the user about them.

``regions_summary`` counts one camera's boxes per class and frames with boxes, and its motion
masks' share of the frame and global motion (the results' ``regions.cameras``);
``describe_regions`` makes its console line.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from dynaeval.regions.focus import CameraRegions


def regions_summary(camera: CameraRegions, source: str,
                    classes: Sequence[str] = ()) -> dict[str, Any]:
    """What one camera's regions hold, for the results' ``regions.cameras``: ``n_frames``,
    ``frames_with_boxes`` (frames with at least one box in the image), ``boxes`` (raw boxes per
    class, in the order of ``classes`` then as met; motion boxes are class ``motion``) and, with
    motion masks, ``mask_fraction`` (mean and max share of the frame's pixels marked moving, over
    the frames with a mask)."""
    counts: dict[str, int] = dict.fromkeys(classes, 0)
    regions = camera.frames
    for r in regions:
        if r.raw_boxes is None:
            continue
        if r.records is None:
            counts["motion"] = counts.get("motion", 0) + len(r.raw_boxes)
            continue
        for rec in r.records:
            counts[str(rec["class"])] = counts.get(str(rec["class"]), 0) + 1
    out: dict[str, Any] = {
        "source": source, "n_frames": len(regions),
        "frames_with_boxes": sum(r.boxes is not None for r in regions), "boxes": counts,
    }
    fractions = [float(r.mask.mean()) for r in regions if r.packed_mask is not None]
    if any(r.packed_mask is not None or r.mask_missing is not None for r in regions):
        out["mask_fraction"] = ({"mean": float(np.mean(fractions)), "max": max(fractions)}
                                if fractions else None)
    if camera.motion is not None:
        out["global_motion_px"] = camera.motion.global_motion_px
    return out


def describe_regions(camera: str, summary: dict[str, Any]) -> str:
    """One console line: ``cam07: 12 person and 3 ball boxes in 10 of 12 frames``."""
    parts = [f"{n} {c}" for c, n in summary["boxes"].items()]
    listed = (" and ".join([", ".join(parts[:-1]), parts[-1]]) if len(parts) > 1 else
              parts[0] if parts else "0")
    return (f"{camera}: {listed} boxes in {summary['frames_with_boxes']} of "
            f"{summary['n_frames']} frames ({summary['source']})")

"""Regions to score: boxes (detector, motion masks, boxes files) and motion masks.

Heavy dependencies (onnxruntime, cv2, scipy) are imported inside the functions that use them, so
importing this package stays light.
"""

from dynaeval.core.boxes import as_boxes, boxes_to_mask, clip_boxes, mask_to_box
from dynaeval.regions.boxes_file import (
    BOXES_SCHEMA,
    BoxesFile,
    frame_key,
    read_boxes_file,
    records_to_boxes,
    write_boxes_file,
)
from dynaeval.regions.detector import (
    Detections,
    Detector,
    DetectorConfig,
    detect,
    detect_folder,
    file_sha256,
    iter_detect,
)
from dynaeval.regions.expand import ExpandConfig, expand_box, expand_boxes, merge_boxes
from dynaeval.regions.motion import (
    LazyFrames,
    MotionConfig,
    importance_weights,
    iter_importance_weights,
    iter_motion_masks,
    mask_boxes,
    motion_mask,
)

__all__ = [
    "BOXES_SCHEMA",
    "BoxesFile",
    "Detections",
    "Detector",
    "DetectorConfig",
    "ExpandConfig",
    "LazyFrames",
    "MotionConfig",
    "as_boxes",
    "boxes_to_mask",
    "clip_boxes",
    "detect",
    "detect_folder",
    "expand_box",
    "expand_boxes",
    "file_sha256",
    "frame_key",
    "importance_weights",
    "iter_detect",
    "iter_importance_weights",
    "iter_motion_masks",
    "mask_boxes",
    "mask_to_box",
    "merge_boxes",
    "motion_mask",
    "read_boxes_file",
    "records_to_boxes",
    "write_boxes_file",
]

"""Regions to score: boxes (detector, motion masks, boxes files) and motion masks."""

from dynaeval.regions.boxes import as_boxes, boxes_to_mask, clip_boxes, mask_to_box

__all__ = ["as_boxes", "boxes_to_mask", "clip_boxes", "mask_to_box"]

"""Deprecated: the box geometry moved to ``dynaeval.boxes``; this re-export goes away soon."""

from dynaeval.boxes import as_boxes, boxes_to_mask, clip_boxes, mask_to_box  # noqa: F401

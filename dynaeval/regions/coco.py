"""COCO class-name lists in the two numberings detectors use (torchvision's 91, YOLO's 80)."""

from __future__ import annotations

# torchvision's COCO category list (91 indices, "N/A" for ids unused by COCO 2017); checked against
# torchvision.models.detection weights' meta["categories"] in the tests.
COCO91_NAMES: tuple[str, ...] = (
    "__background__", "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train",
    "truck", "boat", "traffic light", "fire hydrant", "N/A", "stop sign", "parking meter", "bench",
    "bird", "cat", "dog", "horse", "sheep", "cow", "elephant", "bear", "zebra", "giraffe", "N/A",
    "backpack", "umbrella", "N/A", "N/A", "handbag", "tie", "suitcase", "frisbee", "skis",
    "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard",
    "tennis racket", "bottle", "N/A", "wine glass", "cup", "fork", "knife", "spoon", "bowl",
    "banana", "apple", "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", "donut",
    "cake", "chair", "couch", "potted plant", "bed", "N/A", "dining table", "N/A", "N/A", "toilet",
    "N/A", "tv", "laptop", "mouse", "remote", "keyboard", "cell phone", "microwave", "oven",
    "toaster", "sink", "refrigerator", "N/A", "book", "clock", "vase", "scissors", "teddy bear",
    "hair drier", "toothbrush",
)  # fmt: skip
"""torchvision detection label index -> COCO name (index 1 is ``person``, 37 ``sports ball``)."""

COCO80_NAMES: tuple[str, ...] = tuple(n for n in COCO91_NAMES if n not in ("__background__", "N/A"))
"""YOLO's contiguous 80-class COCO list (index 0 is ``person``, 32 ``sports ball``)."""

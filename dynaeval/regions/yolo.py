"""The YOLO output convention (Ultralytics YOLOv8 / 11 exports) -> candidate boxes.

Input: one ``(1, 3, S, S)`` float32 RGB image in [0, 1], the frame *letterboxed* into it (aspect
kept, centred, padded with grey 114/255). Output: one ``(1, 4 + C, N)`` array: per candidate
``cx, cy, w, h`` in input pixels, then ``C`` class scores. A candidate's class is the arg-max over
all ``C`` scores (as Ultralytics does), its score that maximum. Candidates stay in input
(letterbox) pixels: as in Ultralytics' predictor (``ultralytics/utils/nms.py``
``non_max_suppression``, then ``ops.scale_boxes``), NMS runs there on the unclipped boxes and only
the kept boxes are mapped back through the letterbox (``to_image``) and clipped.

A decoder module offers ``fits``, ``default_names``, ``output_roles``, ``prepare``, ``decode``,
``to_image`` and ``n_classes`` (see ``dynaeval.regions.detector.Detector``, which picks one per
model).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.regions.coco import COCO80_NAMES

DEFAULT_SIDE = 640
"""Letterbox side (px) when the graph's input size is dynamic and no ``input_size`` is set."""


def fits(outputs: Sequence[Any]) -> bool:
    """True when the graph's outputs (onnxruntime ``NodeArg``) look like YOLO's: one 3-D output."""
    return len(outputs) == 1 and len(outputs[0].shape) == 3


def output_roles(outputs: Sequence[Any]) -> tuple[dict[str, int], None]:
    """``({"output": 0}, None)``: one output, nothing to match (no note)."""
    del outputs
    return {"output": 0}, None


def default_names(outputs: Sequence[Any]) -> dict[int, str]:
    """COCO's 80 names when the output has 4 + 80 rows (or a dynamic count), else ``{}`` (not a
    COCO model and no names: only integer class ids can select)."""
    rows = outputs[0].shape[1]
    if isinstance(rows, int) and rows - 4 != len(COCO80_NAMES):
        return {}
    return dict(enumerate(COCO80_NAMES))


def letterbox(image: np.ndarray, size_hw: tuple[int, int], pad_value: float = 114 / 255):
    """Resize keeping the aspect ratio and pad (centred) to ``size_hw``, as YOLO expects.

    ``image``: ``(H, W, 3)`` float32 in [0, 1]. Returns ``(canvas, scale_xy, offset_xy)`` where
    ``canvas`` is ``(th, tw, 3)`` float32, and a point ``(x, y)`` of the original image lands at
    ``(x * scale_x + off_x, y * scale_y + off_y)`` on the canvas (both scales equal the resize
    factor up to rounding of the resized size).
    """
    import cv2

    h, w = image.shape[:2]
    th, tw = size_hw
    r = min(th / h, tw / w)
    nh, nw = max(1, int(round(h * r))), max(1, int(round(w * r)))
    resized = image if (nh, nw) == (h, w) else cv2.resize(image, (nw, nh), interpolation=cv2.INTER_LINEAR)
    top, left = (th - nh) // 2, (tw - nw) // 2
    canvas = np.full((th, tw, 3), pad_value, dtype=np.float32)
    canvas[top : top + nh, left : left + nw] = resized
    return canvas, (nw / w, nh / h), (left, top)


def prepare(img: np.ndarray, input_hw: tuple[int | None, int | None], input_size: int | None):
    """The letterboxed ``(th, tw, 3)`` float32 canvas to feed, and ``(scale_xy, offset_xy)``.

    ``input_hw``: the graph's static input size (None where dynamic, then ``input_size`` or 640).
    """
    th, tw = input_hw
    side = input_size or DEFAULT_SIDE
    canvas, scale, offset = letterbox(img, (th or side, tw or side))
    return canvas, (scale, offset)


def _checked(outs: list[np.ndarray], path: Path | None) -> np.ndarray:
    (out,) = outs
    if out.ndim != 3 or out.shape[0] != 1 or out.shape[1] <= 4:
        raise InputError(f"YOLO-style output must be (1, 4+C, N), got {out.shape}", path=path)
    return out


def n_classes(outs: list[np.ndarray]) -> int:
    """The number of classes ``C`` the model predicts (from a ``(1, 4 + C, N)`` output)."""
    return int(outs[0].shape[1]) - 4


def decode(outs: list[np.ndarray], roles: dict[str, int] | None, path: Path | None = None):
    """Candidates of one run: float64 ``(N, 4)`` xyxy boxes in *input* (letterbox) pixels,
    unclipped, ``(N,)`` scores, ``(N,)`` int64 class ids (``to_image`` maps boxes back)."""
    del roles  # one output: nothing to match
    pred = _checked(outs, path)[0].T.astype(np.float64)  # (N, 4 + C)
    cx, cy, w, h = pred[:, 0], pred[:, 1], pred[:, 2], pred[:, 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
    cls = np.argmax(pred[:, 4:], axis=1).astype(np.int64)
    scores = pred[np.arange(pred.shape[0]), 4 + cls]
    return boxes, scores, cls


def to_image(boxes: np.ndarray, geometry) -> np.ndarray:
    """``(N, 4)`` xyxy boxes from letterbox pixels to original image pixels (unclipped): minus
    the padding, divided by the per-axis resize factor (as Ultralytics' ``scale_boxes``, which
    also uses ``new_w / w`` and ``new_h / h``). ``geometry``: what ``prepare`` returned."""
    (sx, sy), (ox, oy) = geometry
    out = np.asarray(boxes, dtype=np.float64).reshape(-1, 4).copy()
    out[:, [0, 2]] = (out[:, [0, 2]] - ox) / sx
    out[:, [1, 3]] = (out[:, [1, 3]] - oy) / sy
    return out

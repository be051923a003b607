"""The torchvision output convention (``torchvision.models.detection`` RetinaNet / Faster R-CNN /
FCOS exports) -> candidate boxes.

Input: one float32 RGB image in [0, 1], ``(3, H, W)`` (the plain export of a model called on a
list of images) or ``(1, 3, H, W)`` (a batch wrapper); the model resizes internally, so the image
is fed at its own size unless the graph fixes ``H, W`` or ``input_size`` is set (then it is
resized and boxes scaled back). Outputs: ``boxes (N, 4)`` x_min, y_min, x_max, y_max in input
pixels, ``scores (N,)``, ``labels (N,)`` int, each optionally with a leading batch dimension of
1; matched by name (containing ``box``, ``score``, ``label``/``class``) or else by dtype and shape.

Same decoder interface as ``dynaeval.regions.yolo``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.errors import InputError
from dynaeval.regions.coco import COCO91_NAMES


def fits(outputs: Sequence[Any]) -> bool:
    """True when the graph has at least three outputs (boxes, scores, labels)."""
    return len(outputs) >= 3


def default_names(outputs: Sequence[Any]) -> dict[int, str]:
    """torchvision's 91-index COCO list."""
    del outputs
    return dict(enumerate(COCO91_NAMES))


def prepare(img: np.ndarray, input_hw: tuple[int | None, int | None], input_size: int | None):
    """The ``(h, w, 3)`` float32 image to feed and the ``(x, y)`` factors back to the original.

    The graph's static size wins; else ``input_size`` resizes the longer side; else the image is
    fed as it is.
    """
    import cv2

    h, w = img.shape[:2]
    th, tw = input_hw
    if th is not None and tw is not None:
        size = (th, tw)
    elif input_size is not None:
        r = input_size / max(h, w)
        size = (max(1, int(round(h * r))), max(1, int(round(w * r))))
    else:
        size = (h, w)
    x = img if size == (h, w) else cv2.resize(img, (size[1], size[0]), interpolation=cv2.INTER_LINEAR)
    return x, (w / size[1], h / size[0])


def n_classes(outs: list[np.ndarray]) -> None:
    """Unknown: labels are class ids of any range."""
    del outs


def decode(outs: list[np.ndarray], output_names: Sequence[str], geometry, path: Path | None = None):
    """Candidates of one run: float64 ``(N, 4)`` xyxy boxes in original image pixels (unclipped),
    ``(N,)`` scores, ``(N,)`` int64 class ids. ``geometry``: what ``prepare`` returned."""
    boxes, scores, labels = _match(outs, output_names, path)
    fx, fy = geometry
    boxes = boxes.astype(np.float64)
    boxes[:, [0, 2]] *= fx
    boxes[:, [1, 3]] *= fy
    return boxes, scores.astype(np.float64), labels


def _roles_by_name(output_names: Sequence[str]) -> dict[str, int] | None:
    names = [n.lower() for n in output_names]
    roles: dict[str, int] = {}
    for role, keys in (("boxes", ("box",)), ("scores", ("score",)), ("labels", ("label", "class"))):
        hits = [i for i, n in enumerate(names) if any(k in n for k in keys)]
        if len(hits) == 1:
            roles[role] = hits[0]
    return roles if len(set(roles.values())) == 3 else None


def _roles_by_type(outs: list[np.ndarray]) -> dict[str, int] | None:
    ints = [i for i, a in enumerate(outs) if np.issubdtype(a.dtype, np.integer)]
    floats = [i for i, a in enumerate(outs) if np.issubdtype(a.dtype, np.floating)]
    if len(ints) != 1 or len(floats) != 2:
        return None
    n = outs[ints[0]].size
    is_boxes = [outs[i].size == 4 * n and outs[i].shape[-1:] == (4,) for i in floats]
    if is_boxes[0] == is_boxes[1]:
        return None
    b, s = (floats[0], floats[1]) if is_boxes[0] else (floats[1], floats[0])
    return {"boxes": b, "scores": s, "labels": ints[0]} if outs[s].size == n else None


def _squeeze(a: np.ndarray, ndim: int) -> np.ndarray:
    return a[0] if a.ndim == ndim + 1 and a.shape[0] == 1 else a


def _match(outs: list[np.ndarray], output_names: Sequence[str], path: Path | None):
    roles = _roles_by_name(output_names) or _roles_by_type(outs)
    if roles is None:
        got = ", ".join(f"{n} {a.shape} {a.dtype}" for n, a in zip(output_names, outs, strict=True))
        raise InputError(
            f"cannot find torchvision-style outputs boxes (N, 4) float, scores (N,) float, "
            f"labels (N,) int among [{got}]",
            path=path,
        )
    boxes = _squeeze(outs[roles["boxes"]], 2)
    scores = _squeeze(outs[roles["scores"]], 1)
    labels = _squeeze(outs[roles["labels"]], 1)
    n = boxes.shape[0] if boxes.ndim == 2 else -1
    if boxes.shape != (n, 4) or scores.shape != (n,) or labels.shape != (n,):
        raise InputError(
            f"torchvision-style outputs disagree: boxes {boxes.shape}, scores {scores.shape}, "
            f"labels {labels.shape}; expected (N, 4), (N,), (N,)",
            path=path,
        )
    if not np.issubdtype(labels.dtype, np.integer) and not np.all(labels == np.round(labels)):
        raise InputError("torchvision-style labels must be integer class ids", path=path)
    return boxes, scores, labels.astype(np.int64)

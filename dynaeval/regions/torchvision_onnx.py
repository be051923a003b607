"""The torchvision output convention (``torchvision.models.detection`` RetinaNet / Faster R-CNN /
FCOS exports) -> candidate boxes.

Input: one float32 RGB image in [0, 1], ``(3, H, W)`` (the plain export of a model called on a
list of images) or ``(1, 3, H, W)`` (a batch wrapper); the model resizes internally, so the image
is fed at its own size unless the graph fixes ``H, W`` or ``input_size`` is set (then it is
resized and boxes scaled back). Outputs: ``boxes (N, 4)`` x_min, y_min, x_max, y_max in input
pixels, ``scores (N,)``, ``labels (N,)`` int, each optionally with a leading batch dimension of
1. Which output is which is decided once, from the graph (``output_roles``): by name (containing
``box``, ``score``, ``label``/``class``) when the names agree with the dtypes, else by dtype and
shape (the one integer output is the labels, the float output with 4 columns the boxes), and the
decision is reported. torchvision's models return ``boxes, scores, labels`` (RetinaNet, FCOS) but
``boxes, labels, scores`` (Faster R-CNN): an export naming the outputs in the wrong order is
still read right.

Same decoder interface as ``dynaeval.regions.yolo``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
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


def decode(outs: list[np.ndarray], roles: dict[str, int] | None, path: Path | None = None):
    """Candidates of one run: float64 ``(N, 4)`` xyxy boxes in *input* pixels, ``(N,)`` scores,
    ``(N,)`` int64 class ids. ``roles``: ``output_roles``'s decision (None: decide from the
    arrays' dtypes and shapes)."""
    boxes, scores, labels = _match(outs, roles, path)
    return boxes.astype(np.float64), scores.astype(np.float64), labels


def to_image(boxes: np.ndarray, geometry) -> np.ndarray:
    """``(N, 4)`` xyxy boxes from input pixels to original image pixels (scaled by ``prepare``'s
    factors; identity when the image was fed at its own size)."""
    fx, fy = geometry
    out = np.asarray(boxes, dtype=np.float64).reshape(-1, 4).copy()
    out[:, [0, 2]] *= fx
    out[:, [1, 3]] *= fy
    return out


ROLES = ("boxes", "scores", "labels")


def _roles_by_name(names: Sequence[str]) -> dict[str, int] | None:
    names = [n.lower() for n in names]
    roles: dict[str, int] = {}
    for role, keys in (("boxes", ("box",)), ("scores", ("score",)), ("labels", ("label", "class"))):
        hits = [i for i, n in enumerate(names) if any(k in n for k in keys)]
        if len(hits) == 1:
            roles[role] = hits[0]
    return roles if len(set(roles.values())) == 3 else None


def _by_kind(is_int: list[bool], is_float: list[bool], wide: list[bool]) -> dict[str, int] | None:
    """Roles from dtypes and shapes: one integer output (labels), two float ones of which exactly
    one is ``wide`` (4 columns, or one more dimension: the boxes)."""
    ints = [i for i, v in enumerate(is_int) if v]
    floats = [i for i, v in enumerate(is_float) if v]
    if len(ints) != 1 or len(floats) != 2 or wide[floats[0]] == wide[floats[1]]:
        return None
    b, s = (floats[0], floats[1]) if wide[floats[0]] else (floats[1], floats[0])
    return {"boxes": b, "scores": s, "labels": ints[0]}


def _is_float_type(t: str) -> bool:
    return t in ("tensor(float)", "tensor(double)", "tensor(float16)")


def output_roles(outputs: Sequence[Any]) -> tuple[dict[str, int] | None, str | None]:
    """Which graph output (onnxruntime ``NodeArg``) is boxes, scores and labels, and a note when
    the names were overruled by the dtypes and shapes. None: undecided from the graph (then
    decided per run from the arrays)."""
    names = [o.name for o in outputs]
    ranks = [len(o.shape) for o in outputs]
    wide = [o.shape[-1:] == [4] or r == max(ranks) > min(ranks) for o, r in zip(outputs, ranks, strict=True)]
    is_int = ["int" in o.type for o in outputs]
    is_float = [_is_float_type(o.type) for o in outputs]
    by_type = _by_kind(is_int, is_float, wide)
    by_name = _roles_by_name(names)
    if by_name is None or by_type is None:
        return by_name or by_type, None
    b, s, lab = (by_name[r] for r in ROLES)
    agrees = (is_int[lab] or not any(is_int)) and is_float[b] and wide[b] and is_float[s] and not wide[s]
    if agrees:
        return by_name, None
    taken = ", ".join(f"{names[by_type[r]]!r} ({outputs[by_type[r]].type}) as {r}" for r in ROLES)
    return by_type, (f"the detector's output names disagree with their dtypes and shapes; took "
                     f"{taken} (torchvision's Faster R-CNN returns boxes, labels, scores; "
                     "RetinaNet and FCOS boxes, scores, labels)")


def _roles_by_type(outs: list[np.ndarray]) -> dict[str, int] | None:
    ints = [np.issubdtype(a.dtype, np.integer) for a in outs]
    floats = [np.issubdtype(a.dtype, np.floating) for a in outs]
    roles = _by_kind(ints, floats, [a.shape[-1:] == (4,) for a in outs])
    if roles is None:
        return None
    n = outs[roles["labels"]].size
    ok = outs[roles["boxes"]].size == 4 * n and outs[roles["scores"]].size == n
    return roles if ok else None


def _squeeze(a: np.ndarray, ndim: int) -> np.ndarray:
    return a[0] if a.ndim == ndim + 1 and a.shape[0] == 1 else a


def _match(outs: list[np.ndarray], roles: dict[str, int] | None, path: Path | None):
    roles = roles or _roles_by_type(outs)
    if roles is None:
        got = ", ".join(f"{a.shape} {a.dtype}" for a in outs)
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

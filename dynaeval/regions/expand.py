"""Box expansion (so that artefacts around a player count) and merging (so no pixel counts twice).

Rules (``ExpandConfig.rule``):

* ``"paper"``: the seed study's rule: each box is scaled about its centre, width x7 and height x2.5.
  Unlike the seed study, every box is kept (it kept only the one nearest the image centre).
* ``"margin"``: each side moves out by ``margin_px + margin_frac * size`` (size = box width for the
  left/right sides, box height for top/bottom).
* ``"none"``: boxes are used as given.

Expanded coordinates are rounded outwards (floor the min, ceil the max), so the expanded box always
contains the original one, then clipped to the image: a box reaching past the border is cut there,
never wrapped around (``image[-5:20]`` would take the *last* 5 rows and the first 20).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dynaeval.core.boxes import as_boxes, clip_boxes
from dynaeval.core.errors import InputError

EXPAND_RULES = ("paper", "margin", "none")
"""Names accepted by ``ExpandConfig.rule`` and ``ExpandConfig.preset``."""


@dataclass(frozen=True)
class ExpandConfig:
    """How boxes are grown before scoring. Use ``ExpandConfig.preset(name)`` for the named presets."""

    rule: str = "paper"
    """``"paper"`` (scale about the centre), ``"margin"`` (add a margin) or ``"none"``."""
    scale_x: float = 7.0
    """``paper`` rule: factor on the box width (the seed study's 7)."""
    scale_y: float = 2.5
    """``paper`` rule: factor on the box height (the seed study's 2.5)."""
    margin_px: float = 8.0
    """``margin`` rule: pixels added on every side."""
    margin_frac: float = 0.25
    """``margin`` rule: fraction of the box width (left/right) or height (top/bottom) added per side."""
    merge: bool = True
    """Merge overlapping or touching expanded boxes into their bounding box (see ``merge_boxes``)."""

    def __post_init__(self) -> None:
        if self.rule not in EXPAND_RULES:
            raise InputError(f"unknown expansion rule {self.rule!r}; choose one of {', '.join(EXPAND_RULES)}")
        for name in ("scale_x", "scale_y"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 1.0:
                raise InputError(f"{name} must be a finite factor >= 1 (boxes only grow), got {v!r}")
        for name in ("margin_px", "margin_frac"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0.0:
                raise InputError(f"{name} must be finite and >= 0, got {v!r}")

    @classmethod
    def preset(cls, name: str, **overrides: object) -> ExpandConfig:
        """The named preset (``paper``, ``margin``, ``none``), with optional field overrides."""
        if name not in EXPAND_RULES:
            raise InputError(f"unknown expansion preset {name!r}; choose one of {', '.join(EXPAND_RULES)}")
        return replace(cls(rule=name), **overrides)  # type: ignore[arg-type]


def _as_config(rule: ExpandConfig | str) -> ExpandConfig:
    return rule if isinstance(rule, ExpandConfig) else ExpandConfig.preset(rule)


def _expand_array(boxes: np.ndarray, cfg: ExpandConfig) -> np.ndarray:
    """Expand ``(N, 4)`` int64 boxes, unclipped (coordinates may be negative or past the image)."""
    b = boxes.astype(np.float64)
    w = b[:, 2] - b[:, 0]
    h = b[:, 3] - b[:, 1]
    if cfg.rule == "none":
        return boxes.copy()
    if cfg.rule == "paper":
        cx = (b[:, 0] + b[:, 2]) / 2
        cy = (b[:, 1] + b[:, 3]) / 2
        hw = w * cfg.scale_x / 2
        hh = h * cfg.scale_y / 2
        out = np.stack([cx - hw, cy - hh, cx + hw, cy + hh], axis=1)
    else:
        dx = cfg.margin_px + cfg.margin_frac * w
        dy = cfg.margin_px + cfg.margin_frac * h
        out = np.stack([b[:, 0] - dx, b[:, 1] - dy, b[:, 2] + dx, b[:, 3] + dy], axis=1)
    # Outwards rounding; the small epsilon keeps exact integers (e.g. 3.0000000001) from growing.
    eps = 1e-9
    lo = np.floor(out[:, :2] + eps)
    hi = np.ceil(out[:, 2:] - eps)
    return np.concatenate([lo, hi], axis=1).astype(np.int64)


def expand_box(box: object, *, rule: ExpandConfig | str = "paper") -> np.ndarray:
    """Expand one box ``[x_min, y_min, x_max, y_max]`` (int px, max exclusive) by ``rule``.

    Returns a ``(4,)`` int64 box, **not clipped**: coordinates may be negative or past the image;
    clip with ``clip_boxes`` (or use ``expand_boxes``) before indexing an image.
    """
    b = as_boxes(box)
    if b.shape[0] != 1:
        raise InputError(f"expand_box takes one box [x_min, y_min, x_max, y_max], got {b.shape[0]}")
    return _expand_array(b, _as_config(rule))[0]


def expand_boxes(boxes: object, config: ExpandConfig | str, height: int, width: int) -> np.ndarray:
    """Expand, clip to a ``height x width`` image and (if ``config.merge``) merge boxes.

    ``boxes``: ``(N, 4)`` int px, max exclusive. Returns ``(M, 4)`` int64 inside the image,
    ``M <= N``; boxes entirely outside the image are dropped. Every input box is kept (no
    "nearest to the centre" selection).
    """
    cfg = _as_config(config)
    out = clip_boxes(_expand_array(as_boxes(boxes), cfg), height, width)
    return merge_boxes(out) if cfg.merge else out


def _overlap_or_touch(b: np.ndarray) -> np.ndarray:
    """``(N, N)`` bool: boxes share a pixel or an edge/corner (max-exclusive: x_max == other x_min)."""
    x_ok = (b[:, None, 0] <= b[None, :, 2]) & (b[None, :, 0] <= b[:, None, 2])
    y_ok = (b[:, None, 1] <= b[None, :, 3]) & (b[None, :, 1] <= b[:, None, 3])
    return x_ok & y_ok


def merge_boxes(boxes: object) -> np.ndarray:
    """Merge overlapping or touching boxes into their bounding boxes until none overlap or touch.

    ``boxes``: ``(N, 4)`` int px, max exclusive. Returns ``(M, 4)`` int64, ``M <= N``, pairwise
    disjoint (and not touching), sorted by ``(y_min, x_min)``. Merging is iterated because the
    bounding box of two boxes can reach a third one.

    A merged box can cover **more than the union** of its inputs (two diagonal boxes merge into a
    rectangle holding two empty corners). When only the exact pixels matter, use
    ``boxes_to_mask(boxes, H, W)`` (the union, each pixel once) instead of the merged boxes; merged
    boxes are what crop-based metrics (SSIM / LPIPS on crops) need.
    """
    from scipy.sparse.csgraph import connected_components

    b = as_boxes(boxes)
    while b.shape[0] > 1:
        adj = _overlap_or_touch(b)
        n, labels = connected_components(adj, directed=False)
        if n == b.shape[0]:
            break
        merged = np.empty((n, 4), dtype=np.int64)
        merged[:, :2] = np.iinfo(np.int64).max
        merged[:, 2:] = np.iinfo(np.int64).min
        np.minimum.at(merged[:, 0], labels, b[:, 0])
        np.minimum.at(merged[:, 1], labels, b[:, 1])
        np.maximum.at(merged[:, 2], labels, b[:, 2])
        np.maximum.at(merged[:, 3], labels, b[:, 3])
        b = merged
    order = np.lexsort((b[:, 0], b[:, 1]))
    return b[order]


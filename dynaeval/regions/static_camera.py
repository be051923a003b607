"""Is a camera static? Motion masks (``dynaeval.regions.motion``) assume it is.

A motion mask marks the pixels that differ from the camera's temporal median: on a panning or
zooming camera every textured pixel differs, the mask covers most of the frame and the masked
(and ``--focus motion``) values equal the whole-frame ones, silently. Two checks, per camera,
on its ground truth:

* **global motion**: corners (Shi-Tomasi) tracked from frame ``t`` to ``t+1`` (pyramidal
  Lucas-Kanade), a similarity transform fitted to them with RANSAC
  (``cv2.estimateAffinePartial2D``), and the largest displacement of a frame corner under it;
  the camera moves when the median over its consecutive pairs exceeds ``MOVING_CAMERA_PX``. Moving
  objects are outliers of the fit as long as the background holds most of the tracked corners
  (at least ``MIN_INLIERS`` of them, else the pair gives no estimate);
* **mask area**: the mask covers more than ``MASK_FRACTION_MAX`` of the frame on average.

Measured (``python benchmarks/static_camera.py``, docs/regions.md "When the camera moves"): the
bundled sample's two static cameras give 0.00 px and masks of 2.7 % / 4.0 % of the frame; pans of
1, 2 and 4 px per frame over scikit-image's photographs give 1.00-4.02 px and masks of 45-95 % on
average. The mask area alone misses the slow pans of ``coffee`` and ``astronaut`` (45 %, 48 %):
the fit is the check that holds, the area a second one (flicker, exposure changes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dynaeval.regions.sources import focus_source

MOVING_CAMERA_PX = 0.5
"""Global motion (px per frame, median over consecutive pairs) above which a camera moves."""
MASK_FRACTION_MAX = 0.5
"""Mean share of the frame a motion mask may cover before it is taken to mark no object."""
MIN_INLIERS = 0.5
"""Share of tracked corners the fitted transform must explain for a pair to give an estimate."""
MAX_PAIRS = 16
"""At most this many consecutive pairs (evenly spaced) are fitted per camera."""
FIT_SIDE = 640
"""Frames are downscaled to at most this many pixels per side for the fit (px reported at the
frame's own size)."""


def _grey(frame: np.ndarray, scale: float) -> np.ndarray:
    """``(h, w)`` uint8 grey of a ``(H, W[, C])`` float frame in [0, 1] (the mean of its first
    three channels, or its only one), resized by ``scale`` (area interpolation)."""
    import cv2

    f = np.asarray(frame, dtype=np.float32)
    g = f if f.ndim == 2 else _mean3(f) if f.shape[2] >= 3 else f[..., 0]
    g8 = np.clip(np.round(g * 255.0), 0, 255).astype(np.uint8)
    if scale == 1.0:
        return g8
    h, w = g8.shape
    return cv2.resize(g8, (max(1, round(w * scale)), max(1, round(h * scale))), interpolation=cv2.INTER_AREA)


def _mean3(f: np.ndarray) -> np.ndarray:
    """``f[..., :3].mean(axis=2)`` of ``(H, W, C >= 3)`` float32, bit for bit (what numpy does:
    ``(c0 + c1) + c2`` in float32, then the division by the count as ``mean`` does it), as two
    whole-frame adds: numpy's reduction over the short channel axis took 30 ms a 1080p frame."""
    out = f[..., 0] + f[..., 1]
    out += f[..., 2]
    return np.true_divide(out, np.intp(3), out=out, casting="unsafe")


def global_motion(a: np.ndarray, b: np.ndarray) -> float | None:
    """Camera motion from frame ``a`` to ``b`` in pixels of ``a``'s size: the largest
    displacement of a frame corner under the similarity transform fitted to the tracked corners.

    ``a``, ``b``: ``(H, W, C)`` or ``(H, W)`` float in [0, 1], same shape. None when fewer than 8
    corners are tracked or the fit explains less than ``MIN_INLIERS`` of them.
    """
    scale = _fit_scale(a.shape)
    return _grey_motion(_grey(a, scale), _grey(b, scale), scale)


def _fit_scale(shape: tuple[int, ...]) -> float:
    """The downscale of a frame of ``shape`` for the fit (``FIT_SIDE``)."""
    return min(1.0, FIT_SIDE / max(shape[:2]))


def _grey_motion(ga: np.ndarray, gb: np.ndarray, scale: float) -> float | None:
    """``global_motion`` of two frames given as their ``_grey`` at ``scale``."""
    import cv2

    pts = cv2.goodFeaturesToTrack(ga, maxCorners=400, qualityLevel=0.01, minDistance=8)
    if pts is None or len(pts) < 8:
        return None
    nxt, status, _ = cv2.calcOpticalFlowPyrLK(ga, gb, pts, None)
    ok = status.ravel() == 1
    if ok.sum() < 8:
        return None
    m, inliers = cv2.estimateAffinePartial2D(pts[ok], nxt[ok], method=cv2.RANSAC,
                                             ransacReprojThreshold=1.0)
    if m is None or inliers.mean() < MIN_INLIERS:
        return None
    sh, sw = ga.shape
    corners = np.array([[0, 0], [sw, 0], [0, sh], [sw, sh]], np.float64)
    moved = corners @ m[:, :2].T + m[:, 2]
    return float(np.max(np.hypot(*(moved - corners).T)) / scale)


def camera_motion(load: Callable[[int], np.ndarray], n_frames: int) -> float | None:
    """Median ``global_motion`` over up to ``MAX_PAIRS`` evenly spaced consecutive pairs
    ``(i, i+1)`` of a camera's frames (``load(i)``); None when no pair gives an estimate. A frame
    in two pairs is loaded and turned grey once (the previous pair's second frame is kept)."""
    if n_frames < 2:
        return None
    starts = np.unique(np.linspace(0, n_frames - 2, min(MAX_PAIRS, n_frames - 1)).round().astype(int))
    found: list[float | None] = []
    last = None  # the previous pair's second frame: (index, shape, scale, grey)
    for i in (int(i) for i in starts):
        if last is not None and last[0] == i and last[2] == _fit_scale(last[1]):
            shape, ga = last[1], last[3]  # turned grey at the scale its own shape gives
        else:
            a = load(i)
            shape = a.shape
            ga = _grey(a, _fit_scale(shape))
        scale = _fit_scale(shape)  # a pair at the scale of its first frame, as global_motion
        b = load(i + 1)
        gb = _grey(b, scale)
        last = (i + 1, b.shape, scale, gb)
        found.append(_grey_motion(ga, gb, scale))
    found = [v for v in found if v is not None]
    return float(np.median(found)) if found else None


@dataclass(frozen=True)
class CameraMotion:
    """The static-camera check of one camera, found once from its ground truth (the results'
    ``regions.cameras.<camera>.global_motion_px``, and the camera's note when it moves)."""

    global_motion_px: float | None
    """``camera_motion``: the median global motion in px per frame; None: no pair gave one."""
    reason: str | None
    """``moving_camera_reason``: why the camera's motion masks cannot be trusted; None when it
    looks static."""


def static_check(load: Callable[[int], np.ndarray], n_frames: int, mask_fraction: float | None,
                 focus: str) -> CameraMotion:
    """The ``CameraMotion`` of a camera of ``n_frames`` frames (``load(i)``, ``(H, W, C)``
    float32 in [0, 1]); ``mask_fraction``, ``focus``: as ``moving_camera_reason`` takes them."""
    px = camera_motion(load, n_frames)
    return CameraMotion(px, moving_camera_reason(px, mask_fraction, focus))


def moving_camera_reason(motion_px: float | None, mask_fraction: float | None,
                         focus: str, given_masks: bool = False) -> str | None:
    """Why the camera's motion masks cannot be trusted, with the fix, or None when it looks
    static. ``motion_px``: ``camera_motion``; ``mask_fraction``: the mean share of the frame its
    masks cover (None: no mask); ``focus``: the focus source (``motion`` boxes are masks too);
    ``given_masks``: the run's masks are given (``--masks``, DyCheck's covisibility masks):
    masked_* and flicker's static pixels are theirs, the motion masks only make ``motion``
    boxes, so the text names only what the camera's motion touches."""
    moves = motion_px is not None and motion_px > MOVING_CAMERA_PX
    covers = mask_fraction is not None and mask_fraction > MASK_FRACTION_MAX
    if not (moves or covers):
        return None
    what = (f"its ground truth moves by {motion_px:.1f} px per frame (median; a static camera: "
            f"<= {MOVING_CAMERA_PX} px)" if moves else
            "its motion mask covers most of the frame")
    area = "" if mask_fraction is None else f"; the motion mask covers {mask_fraction:.0%} of each frame on average"
    from_motion = focus_source(focus).from_motion
    if given_masks:
        static = ("flicker's 'static' pixels (those outside every given mask) are not static "
                  "(masked_* are over the given masks, which the motion does not change)")
        if not from_motion:
            return f"a moving camera: {what}{area}: {static}"
        return (f"motion masks need a static camera, and {what}{area}: its --focus motion boxes "
                f"are close to the whole frame, and {static}. Score this footage with --focus "
                "detector or --focus boxes:FILE")
    uses = "masked_* values and --focus motion boxes" if from_motion else "masked_* values"
    return (f"motion masks need a static camera, and {what}{area}: its {uses} are close to the "
            "whole-frame ones and flicker's 'static' pixels are not static. Score this footage "
            "with --no-masked, and --focus detector or --focus boxes:FILE")

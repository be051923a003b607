"""Object presence: does the prediction still show each ground-truth object (the ball, every player)?

A box-averaged PSNR can stay high while the ball is simply gone: the ball is a few pixels of a box
of hundreds. Presence decides per object, then reports per class the fraction of ground-truth
objects the prediction shows (``presence_person``, ``presence_ball``).

Two tests, both on the object's **tight** box (its raw ground-truth box, not the expanded one used
by ``focused_*``, grown by ``PresenceConfig.margin`` pixels and clipped to the image):

* **region test** (detector-free, always run): the crop of the prediction is compared with the crop
  of the ground truth by

  - ``ncc``: zero-mean normalised cross-correlation over the crop's pixels and channels, in
    [-1, 1] (1: the same pattern, whatever the brightness and contrast; about 0: unrelated, e.g.
    the pitch where the ball should be). Undefined (``None``) when the ground-truth crop is
    uniform; 0 when only the prediction's crop is uniform (no structure of the object is there);
  - ``psnr``: PSNR in dB of the crop (``inf`` for identical crops);

  both the best over displacements of the prediction's crop by up to ``shift`` px; and
  - ``visibility``: the fraction of the object's contrast against its surroundings (background:
    the ground truth's margin ring) that the prediction shows, about the opacity of a *ghost*: a
    faded object keeps its pattern (high ``ncc``) but not its contrast; blur keeps it.

  The object passes when ``ncc >= ncc_min``, ``psnr >= psnr_min`` (per class,
  ``PresenceThresholds``, calibrated on the synthetic scenes by
  ``python -m reference_models.studies.presence``: values and provenance in
  ``CALIBRATED_THRESHOLDS``, docs/presence.md) and ``visibility >= visibility_min`` (0.5, by
  definition); an undefined ``ncc`` or ``visibility`` passes.
* **detector test** (when a detector made the ground-truth boxes): the same detector is run on the
  prediction and ground-truth objects are matched to its detections of the same class at
  IoU >= ``iou_min`` (0.5), greedily: all same-class pairs by decreasing IoU (ties: lower
  ground-truth index, then higher detection score first), a pair is taken when neither side is
  taken yet. Greedy and a maximum (Hungarian) matching can find different numbers of matches only
  when one detection overlaps two ground-truth objects at IoU >= 0.5 each: two same-class boxes
  overlapping heavily (players occluding each other), rare in practice.

An object is ``present`` when it passes the region test and, if the detector test ran, that too.

Images are ``(H, W)`` or ``(H, W, C)`` float in ``[0, data_range]`` (integers are upcast; values
outside the range are refused, ``dynaeval.core.validation``'s range rule); boxes
``[x_min, y_min, x_max, y_max]`` int pixels, max exclusive (``dynaeval.core.boxes``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dynaeval.core.boxes import as_boxes, box_iou_matrix, boxes_to_mask, clip_boxes
from dynaeval.core.errors import InputError
from dynaeval.core.validation import check_data_range, check_pair, values_known_in
from dynaeval.metrics.pixel import SquaredErrorStats, psnr_from_stats
from dynaeval.metrics.pixel import psnr as _psnr
from dynaeval.metrics.registry import PRESENCE_CLASSES, keys_of, result_key

PRESENCE_METRICS = tuple(keys_of("object"))
"""Result keys of the presence check (``presence_<class>``, ``tight_psnr_<class>``), from the
registry; the classes are ``PRESENCE_CLASSES``."""
"""Per-frame values ``frame_presence`` returns (names in the results and the metrics registry)."""


@dataclass(frozen=True)
class PresenceThresholds:
    """Region-test thresholds of one class: an object passes when both hold."""

    ncc_min: float
    """Lowest zero-mean normalised cross-correlation of the crops, in [-1, 1]."""
    psnr_min: float
    """Lowest PSNR of the crops in dB (at ``data_range``)."""


CALIBRATED_THRESHOLDS: dict[str, PresenceThresholds] = {
    "person": PresenceThresholds(ncc_min=0.40, psnr_min=20.5),
    "ball": PresenceThresholds(ncc_min=0.64, psnr_min=10.0),
}
"""Thresholds per class, calibrated on the synthetic scenes with the default margin (1 px), shift
(1 px) and ``visibility_min`` (0.5) by ``python -m reference_models.studies.presence`` (seed 1,
size small, 205 shown / 41 erased players and 120 shown / 24 erased balls; run 2026-11-22,
reproduced unchanged at commit 53152e7). Misses / false passes on that set: players 3.4 % / 2.4 %,
balls 6.7 % / 4.2 %. For the ball, any ``psnr_min`` from 5 to about 15 dB gives the same result
(``ncc`` and ``visibility`` decide); 10 dB is the middle of that run. Tables: docs/presence.md."""

FALLBACK_CLASS = "person"
"""Classes without thresholds of their own (e.g. ``motion`` boxes) use this class's thresholds."""


@dataclass(frozen=True)
class PresenceConfig:
    """How objects are compared between prediction and ground truth (goes into the settings)."""

    margin: int = 1
    """Pixels added on every side of an object's tight box (then clipped to the image), so that
    a 2-px ball's crop holds some of the pitch around it and a uniform crop is rare."""
    shift: int = 1
    """The prediction's crop is also compared displaced by up to this many pixels in x and y;
    ``ncc`` and ``psnr`` are the best over the displacements (each on its own): an object
    rendered one pixel off (camera calibration, rounding) is still there."""
    thresholds: Mapping[str, PresenceThresholds] = field(
        default_factory=lambda: dict(CALIBRATED_THRESHOLDS))
    """Region-test thresholds per class name; other classes use ``FALLBACK_CLASS``'s."""
    iou_min: float = 0.5
    """Detector test: lowest IoU of a ground-truth box and a same-class detection to match."""
    min_visible: float = 0.25
    """Ground-truth records with a ``visible`` field (the scene generator's unoccluded fraction)
    below this are skipped, neither present nor missing: a ball 90 % hidden behind a player
    leaves a few pixels that say nothing about the prediction. Records without it are kept."""
    visibility_min: float = 0.5
    """Lowest ``visibility`` (fraction of the object's contrast against its surroundings the
    prediction shows, see ``visibility``): an object shown at less than half its contrast, a
    ghost, counts as missing. Chosen, not calibrated: it is the definition of a ghost."""
    detector_min_input_side: float = 12.0
    """Detector test: shorter side (pixels *at the detector's input*: ``Detections.input_scale``;
    image pixels for detections that do not say) below which the detector's miss alone does not
    call an object missing. The detector's boxes of such objects move by a pixel between two
    nearly equal images, and at ``iou_min`` that is a miss: on ground truth plus noise of sigma
    0.01 the bundled detector re-finds 95-98 % of its 0-12 px objects, >= 99 % from 12 px up
    (``python -m reference_models.studies.detector_size``, docs/presence.md)."""
    sure_ncc: float = 0.99
    """With ``sure_psnr``: an object below ``detector_min_input_side`` that the detector misses
    is present when, besides the region test, its crop nearly equals the ground truth's (``ncc
    >= sure_ncc`` and ``psnr >= sure_psnr``). Measured on players-stadium and
    single-player-broadcast (seed 1, their 4-7 px players): predictions at noise sigma 0.01
    (about 40 dB) reach ncc >= 0.996 and psnr >= 38.4 dB, players that vanished at most 0.984
    and 32.7 dB; the region test alone passes a third of the vanished ones."""
    sure_psnr: float = 35.0
    """See ``sure_ncc`` (dB)."""
    data_range: float = 1.0
    """Peak value of the images (PSNR's L)."""

    def __post_init__(self) -> None:
        if isinstance(self.margin, bool) or not isinstance(self.margin, (int, np.integer)) \
                or self.margin < 0:
            raise InputError(f"presence margin must be an integer >= 0 (pixels), got {self.margin!r}")
        if isinstance(self.shift, bool) or not isinstance(self.shift, (int, np.integer)) \
                or not 0 <= self.shift <= 8:
            raise InputError(f"presence shift must be an integer in [0, 8] (pixels), got {self.shift!r}")
        if not 0.0 <= self.min_visible <= 1.0:
            raise InputError(f"presence min_visible must be in [0, 1], got {self.min_visible!r}")
        if not 0.0 <= self.visibility_min <= 1.0:
            raise InputError(f"presence visibility_min must be in [0, 1], got {self.visibility_min!r}")
        if not -1.0 <= self.sure_ncc <= 1.0:
            raise InputError(f"presence sure_ncc must be in [-1, 1], got {self.sure_ncc!r}")
        if not isinstance(self.sure_psnr, (int, float)) or self.sure_psnr != self.sure_psnr:
            raise InputError(f"presence sure_psnr must be a number (dB), got {self.sure_psnr!r}")
        if not self.detector_min_input_side >= 0.0:
            raise InputError("presence detector_min_input_side must be >= 0 (pixels), got "
                             f"{self.detector_min_input_side!r}")
        if not 0.0 < self.iou_min <= 1.0:
            raise InputError(f"presence iou_min must be in (0, 1], got {self.iou_min!r}")
        if FALLBACK_CLASS not in self.thresholds:
            raise InputError(
                f"presence thresholds must include {FALLBACK_CLASS!r} (used for other classes), "
                f"got classes {sorted(self.thresholds)}"
            )
        check_data_range(self.data_range)

    def for_class(self, cls: str) -> PresenceThresholds:
        """Thresholds of class ``cls`` (``FALLBACK_CLASS``'s when it has none)."""
        return self.thresholds.get(cls, self.thresholds[FALLBACK_CLASS])

    def describe(self) -> dict[str, Any]:
        """JSON-ready description for the results' settings."""
        return {
            "margin": int(self.margin),
            "shift": int(self.shift),
            "iou_min": float(self.iou_min),
            "visibility_min": float(self.visibility_min),
            "min_visible": float(self.min_visible),
            "detector_min_input_side": float(self.detector_min_input_side),
            "sure_ncc": float(self.sure_ncc), "sure_psnr": float(self.sure_psnr),
            "thresholds": {c: {"ncc_min": t.ncc_min, "psnr_min": t.psnr_min}
                           for c, t in sorted(self.thresholds.items())},
            "fallback_class": FALLBACK_CLASS,
            "rule": "present = ncc >= ncc_min and psnr >= psnr_min and visibility >= "
                    "visibility_min (an undefined ncc or visibility passes) on the tight box "
                    "grown by margin; with a detector also matched at IoU >= iou_min (greedy by "
                    "IoU, same class); an object below detector_min_input_side at the "
                    "detector's input that it misses is present when ncc >= sure_ncc and psnr >= "
                    "sure_psnr (objects[].decided_by says which rule decided)",
        }


@dataclass(frozen=True)
class FramePresence:
    """Presence of the objects of one frame."""

    objects: list[dict[str, Any]]
    """Per ground-truth object: ``class``, ``id``, ``box`` (tight box scored), ``present``,
    ``ncc`` (None when undefined), ``psnr`` (dB, ``inf`` when the crops are identical),
    ``visibility`` (None when undefined), ``detected`` (None without a detector test),
    ``decided_by``: ``region`` (no detector test), ``region+detector`` (the region test and the
    detector), or ``appearance`` (an object below ``detector_min_input_side`` the detector
    missed: the region test and a near-identical crop, ``sure_ncc`` / ``sure_psnr``)."""
    values: dict[str, float | None]
    """``presence_<class>`` (fraction of the class's objects present, in [0, 1]) and
    ``tight_psnr_<class>`` (PSNR in dB over the union of the class's tight boxes), for every class
    in ``PRESENCE_CLASSES``; None when the frame has no object of the class."""
    reasons: dict[str, str]
    """Why a value of ``values`` is None."""


def tight_box(box: object, height: int, width: int, margin: int = 0) -> np.ndarray | None:
    """An object's box grown by ``margin`` px per side and clipped to ``height x width``.

    Returns a (4,) int64 box, or None when nothing of it lies inside the image.
    """
    b = as_boxes(box)
    if len(b) != 1:
        raise InputError(f"expected one box [x_min, y_min, x_max, y_max], got {len(b)}")
    grown = b + np.array([-margin, -margin, margin, margin], dtype=np.int64)
    clipped = clip_boxes(grown, height, width)
    return clipped[0] if len(clipped) else None


ZNCC_EPS = 1e-6
"""A crop whose standard deviation is at most this (data units) is uniform for ``zncc``."""


def zncc(pred: object, gt: object, box: object = None, *, eps: float = ZNCC_EPS) -> float | None:
    """Zero-mean normalised cross-correlation of two images (or of their crops at ``box``).

    Args:
        pred, gt: (H, W) or (H, W, C) arrays of equal shape, float (integers are upcast).
        box: optional ``[x_min, y_min, x_max, y_max]`` (max exclusive): correlate only this crop.
        eps: a crop whose standard deviation is at most ``eps`` (in data units) is uniform.

    Returns:
        ``sum(p' g') / sqrt(sum(p'^2) sum(g'^2))`` over all pixels and channels of the crop, with
        ``p' = p - mean(p)``, computed in float64: in [-1, 1], invariant to brightness and
        contrast. None when the ground-truth crop is uniform (undefined); 0.0 when only the
        prediction's crop is uniform (none of the ground truth's pattern is there).

    Raises:
        InputError: shapes differ, NaN/Inf pixels, or the box holds no pixel of the image.
    """
    p, g = check_pair(pred, gt)
    if box is not None:
        b = clip_boxes(box, p.shape[0], p.shape[1])
        if len(b) != 1:
            raise InputError(f"box {np.asarray(box).tolist()} holds no pixel of the "
                             f"{p.shape[1]}x{p.shape[0]} image")
        x0, y0, x1, y1 = (int(v) for v in b[0])
        p, g = p[y0:y1, x0:x1], g[y0:y1, x0:x1]
    pd = p.astype(np.float64).ravel()
    gd = g.astype(np.float64).ravel()
    pd -= pd.mean()
    gd -= gd.mean()
    n = pd.size
    sg = math.sqrt(float(gd @ gd) / n)
    if sg <= eps:
        return None
    sp = math.sqrt(float(pd @ pd) / n)
    if sp <= eps:
        return 0.0
    value = float(pd @ gd) / (n * sp * sg)
    return min(1.0, max(-1.0, value))


def crop_similarity(
    pred: object, gt: object, box: object, *, shift: int = 0, data_range: float = 1.0
) -> tuple[float | None, float]:
    """Best ``zncc`` and PSNR of the ground truth's crop at ``box`` against the prediction's crop
    at ``box`` displaced by up to ``shift`` px in x and y (displacements leaving the image are
    skipped).

    Args:
        pred, gt: (H, W) or (H, W, C) float in [0, ``data_range``], equal shapes.
        box: ``[x_min, y_min, x_max, y_max]`` inside the image (max exclusive).
        shift: largest displacement in pixels (0: the same crop only).
        data_range: peak value for PSNR.

    Returns:
        ``(ncc, psnr)``: the largest ``zncc`` over the displacements (None when the ground-truth
        crop is uniform) and the largest PSNR in dB (``inf`` when a displaced crop is identical);
        each is maximised on its own.
    """
    p, g = check_pair(pred, gt, data_range=data_range)
    h, w = p.shape[:2]
    b = clip_boxes(box, h, w)
    if len(b) != 1 or not np.array_equal(b[0], as_boxes(box)[0]):
        raise InputError(f"box {np.asarray(box).tolist()} must lie inside the {w}x{h} image")
    x0, y0, x1, y1 = (int(v) for v in b[0])
    # fast path of max over displacements of zncc (the readable reference; a test holds them
    # together): the ground truth's zero-mean crop and its norm once, then per displacement
    # sum(p * g') = sum((p - mean p) * g') since g' sums to 0 (np.sum of products: np.vdot copies
    # strided crops and is several times slower)
    p64, g64 = p.astype(np.float64), g[y0:y1, x0:x1].astype(np.float64)
    gz = g64 - g64.mean()
    n = gz.size
    sg = math.sqrt(float(np.sum(gz * gz)) / n)
    best_ncc: float | None = None
    best_sse = math.inf
    for dy in range(-shift, shift + 1):
        for dx in range(-shift, shift + 1):
            if y0 + dy < 0 or x0 + dx < 0 or y1 + dy > h or x1 + dx > w:
                continue
            pc = p64[y0 + dy:y1 + dy, x0 + dx:x1 + dx]
            best_sse = min(best_sse, float(np.sum(np.square(pc - g64))))
            if sg <= ZNCC_EPS:
                continue  # the ground truth's crop is uniform: ncc undefined
            mean = float(pc.mean())
            sp = math.sqrt(max(float(np.sum(pc * pc)) / n - mean * mean, 0.0))
            ncc = 0.0 if sp <= ZNCC_EPS else min(1.0, max(-1.0, float(np.sum(pc * gz)) / (n * sp * sg)))
            if best_ncc is None or ncc > best_ncc:
                best_ncc = ncc
    return best_ncc, psnr_from_stats(SquaredErrorStats(best_sse, n), data_range=data_range)


def visibility(
    pred: object, gt: object, box: object, inner: object, *, data_range: float = 1.0,
    min_contrast: float = 0.01,
    min_snr: float = 3.0,
) -> float | None:
    """How much of the object's contrast against its surroundings the prediction shows.

    The background is estimated from the ground truth alone: the per-channel median of the crop
    ``box`` outside the object's own box ``inner`` (the margin ring). With ``M(x)`` the sum over
    the crop of ``x - background`` (one value per channel), the visibility is the projection
    ``<M(pred), M(gt)> / <M(gt), M(gt)>``: 1 when the prediction shows the object's full
    contrast, ``a`` for a ghost blended in at opacity ``a`` over that background, about 0 when
    the object is erased. A blur that keeps the object's light inside the crop keeps the sum, so
    blur barely lowers it (unlike ``zncc`` and PSNR); noise averages out.

    Args:
        pred, gt: (H, W) or (H, W, C) float in [0, ``data_range``], equal shapes.
        box: the crop ``[x0, y0, x1, y1]`` inside the image (the tight box grown by a margin).
        inner: the object's own box, inside ``box``.
        data_range: peak value.
        min_contrast: below this mean contrast per object pixel (fraction of ``data_range``) the
            object does not stand out from its background and the visibility is undefined.
        min_snr: the object's summed contrast must also exceed ``min_snr`` times what the
            background's texture alone sums to (robust sigma of the ring x sqrt(crop pixels)),
            else the background estimate decides the ratio and the visibility is undefined.

    Returns:
        The visibility (unitless, about [0, 1], may exceed 1 when the prediction over-brightens),
        or None when undefined: no margin ring (the box is the object's box), or the object's
        summed contrast is below ``min_contrast`` or ``min_snr``.
    """
    p, g = check_pair(pred, gt, data_range=data_range)
    x0, y0, x1, y1 = (int(v) for v in as_boxes(box)[0])
    ix0, iy0, ix1, iy1 = (int(v) for v in as_boxes(inner)[0])
    gc = g[y0:y1, x0:x1].astype(np.float64)
    pc = p[y0:y1, x0:x1].astype(np.float64)
    if gc.ndim == 2:
        gc, pc = gc[..., None], pc[..., None]
    ring = np.ones(gc.shape[:2], dtype=bool)
    ring[max(iy0 - y0, 0):max(iy1 - y0, 0), max(ix0 - x0, 0):max(ix1 - x0, 0)] = False
    if not ring.any():
        return None
    background = np.median(gc[ring], axis=0)
    # spread of the background (MAD as a robust sigma): the sum of a textured background over the
    # crop fluctuates by about sigma * sqrt(pixels), which an object's sum must clearly exceed
    sigma = 1.4826 * np.median(np.abs(gc[ring] - background), axis=0)
    mass_gt = (gc - background).sum(axis=(0, 1))
    mass_pred = (pc - background).sum(axis=(0, 1))
    energy = float(mass_gt @ mass_gt)
    n_inner = max(1, (ix1 - ix0) * (iy1 - iy0))
    floor = max(min_contrast * data_range * n_inner,
                min_snr * float(np.linalg.norm(sigma)) * math.sqrt(gc.shape[0] * gc.shape[1]))
    if math.sqrt(energy) <= floor:
        return None
    return float(mass_pred @ mass_gt) / energy


def match_objects(
    gt_boxes: object,
    gt_classes: Sequence[str],
    det_boxes: object,
    det_classes: Sequence[str],
    *,
    iou_min: float = 0.5,
    det_scores: object = None,
) -> np.ndarray:
    """Match ground-truth objects to detections of the same class at IoU >= ``iou_min``.

    Greedy by IoU: all same-class pairs with IoU >= ``iou_min`` are taken in order of decreasing
    IoU (ties: lower ground-truth index, then higher detection score, then lower detection index);
    a pair is kept when neither its object nor its detection is matched yet.

    Args:
        gt_boxes: (M, 4) ground-truth boxes; ``gt_classes`` their M class names.
        det_boxes: (N, 4) detections on the prediction; ``det_classes`` their N class names.
        iou_min: lowest IoU (boxes as continuous rectangles, area = width x height) of a match.
        det_scores: optional (N,) detection scores (tie-break only).

    Returns:
        (M,) int64: index of the matched detection, -1 for an unmatched ground-truth object.
    """
    g = as_boxes(gt_boxes).astype(np.float64)
    d = as_boxes(det_boxes).astype(np.float64)
    if len(gt_classes) != len(g) or len(det_classes) != len(d):
        raise InputError(
            f"need one class per box: {len(g)} ground-truth boxes with {len(gt_classes)} classes, "
            f"{len(d)} detections with {len(det_classes)} classes"
        )
    out = np.full(len(g), -1, dtype=np.int64)
    if len(g) == 0 or len(d) == 0:
        return out
    scores = np.zeros(len(d)) if det_scores is None else np.asarray(det_scores, np.float64)
    iou = box_iou_matrix(g, d)
    same = np.asarray(gt_classes, dtype=object)[:, None] == np.asarray(det_classes, dtype=object)[None, :]
    gi, di = np.nonzero(same & (iou >= iou_min))
    order = sorted(range(len(gi)), key=lambda k: (-iou[gi[k], di[k]], gi[k], -scores[di[k]], di[k]))
    used = np.zeros(len(d), dtype=bool)
    for k in order:
        if out[gi[k]] < 0 and not used[di[k]]:
            out[gi[k]] = di[k]
            used[di[k]] = True
    return out


def frame_presence(
    pred: object,
    gt: object,
    objects: Iterable[Mapping[str, Any]],
    *,
    detections: Any = None,
    config: PresenceConfig | None = None,
) -> FramePresence:
    """Presence of every ground-truth object of one frame, and the per-class fractions.

    Args:
        pred, gt: (H, W[, C]) prediction and ground truth, float in [0, ``config.data_range``].
        objects: ground-truth records ``{"class": str, "box": [x0, y0, x1, y1], "id"?: int,
            "visible"?: float}`` (boxes-file records, or ``Detections.records()`` of the detector
            on the ground truth). Boxes outside the image, and records whose ``visible`` is below
            ``config.min_visible``, are left out (they show nothing to compare).
        detections: optional detections on the *prediction* (``dynaeval.regions.Detections``, or
            anything with ``boxes`` (N, 4), ``classes`` (N names) and optionally ``scores``): runs
            the detector test.
        config: margin, thresholds, IoU; default ``PresenceConfig()``.

    Returns:
        ``FramePresence`` (objects, ``presence_*`` and ``tight_psnr_*`` values, reasons).

    Raises:
        InputError: bad images (shapes, channel-first, values outside [0, data_range]) or
            records.
    """
    cfg = config or PresenceConfig()
    p, g = check_pair(pred, gt, data_range=cfg.data_range)
    with values_known_in(cfg.data_range):  # checked once here, not again for every crop
        return _presence_of(p, g, objects, detections, cfg)


def _presence_of(p: np.ndarray, g: np.ndarray, objects: Iterable[Mapping[str, Any]],
                 detections: Any, cfg: PresenceConfig) -> FramePresence:
    """``frame_presence`` of checked images."""
    h, w = p.shape[:2]
    kept: list[dict[str, Any]] = []
    for i, rec in enumerate(objects):
        cls = rec.get("class") if isinstance(rec, Mapping) else None
        if not isinstance(cls, str) or not cls or "box" not in rec:
            raise InputError(f"object {i}: expected a record with 'class' (str) and 'box', got {rec!r}")
        inner = clip_boxes(rec["box"], h, w)
        if len(inner) == 0 or float(rec.get("visible", 1.0)) < cfg.min_visible:
            continue  # outside the image, or mostly occluded: nothing to compare
        kept.append({"class": cls, "id": rec.get("id", i), "inner": inner[0],
                     "box": tight_box(inner[0], h, w, cfg.margin)})
    detected: list[bool | None] = [None] * len(kept)
    if detections is not None:
        match = match_objects(
            as_boxes([o["inner"] for o in kept]), [o["class"] for o in kept],
            detections.boxes, list(detections.classes), iou_min=cfg.iou_min,
            det_scores=getattr(detections, "scores", None),
        )
        detected = [bool(m >= 0) for m in match]
    out: list[dict[str, Any]] = []
    scale = getattr(detections, "input_scale", None) or 1.0
    for obj, det in zip(kept, detected, strict=True):
        box = obj["box"]
        # the window the displaced crops can reach: the images are checked once, crops are small
        wx0, wy0 = max(0, int(box[0]) - cfg.shift), max(0, int(box[1]) - cfg.shift)
        wx1, wy1 = min(w, int(box[2]) + cfg.shift), min(h, int(box[3]) + cfg.shift)
        pw, gw = p[wy0:wy1, wx0:wx1], g[wy0:wy1, wx0:wx1]
        off = np.array([wx0, wy0, wx0, wy0], dtype=np.int64)
        ncc, value = crop_similarity(pw, gw, box - off, shift=cfg.shift, data_range=cfg.data_range)
        vis = visibility(pw, gw, box - off, obj["inner"] - off, data_range=cfg.data_range)
        th = cfg.for_class(obj["class"])
        passed = ((ncc is None or ncc >= th.ncc_min) and value >= th.psnr_min
                  and (vis is None or vis >= cfg.visibility_min))
        rule = _decided_by(det, obj["inner"], scale, cfg)
        sure = ncc is not None and ncc >= cfg.sure_ncc and value >= cfg.sure_psnr
        shown = {"region": True, "region+detector": bool(det), "appearance": sure}[rule]
        out.append({"class": obj["class"], "id": obj["id"], "box": [int(v) for v in box],
                    "present": bool(passed and shown), "ncc": ncc, "psnr": value,
                    "visibility": vis, "detected": det, "decided_by": rule})
    values, reasons = _class_values(p, g, out, cfg.data_range)
    return FramePresence(out, values, reasons)


def _decided_by(detected: bool | None, inner: np.ndarray, scale: float,
                cfg: PresenceConfig) -> str:
    """Which rule decides an object: ``region`` without a detector test; ``appearance`` when the
    detector missed it and its ``inner`` box's shorter side times ``scale`` (model-input px per
    image px) is below ``cfg.detector_min_input_side``; else ``region+detector``."""
    if detected is None:
        return "region"
    side = min(int(inner[2] - inner[0]), int(inner[3] - inner[1])) * scale
    return "appearance" if not detected and side < cfg.detector_min_input_side else "region+detector"


def _class_values(
    p: np.ndarray, g: np.ndarray, objects: list[dict[str, Any]], data_range: float
) -> tuple[dict[str, float | None], dict[str, str]]:
    """Per class: the fraction of its objects present and the PSNR over their tight boxes."""
    values: dict[str, float | None] = dict.fromkeys(PRESENCE_METRICS)
    reasons: dict[str, str] = {}
    for cls in PRESENCE_CLASSES:
        present, tight = result_key("presence", cls=cls), result_key("tight_psnr", cls=cls)
        mine = [o for o in objects if o["class"] == cls]
        if not mine:
            reasons[present] = reasons[tight] = f"no {cls} in the ground truth of this frame"
            continue
        values[present] = sum(o["present"] for o in mine) / len(mine)
        union = boxes_to_mask([o["box"] for o in mine], *p.shape[:2])
        values[tight] = _psnr(p[union], g[union], data_range=data_range)
    return values, reasons

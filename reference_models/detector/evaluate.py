"""Detector quality on held-out scenes, through the real runtime (``dynaeval.regions.detector``).

Per preset, image size and class: AP at IoU 0.5 (all-point interpolated precision-recall area, as
PASCAL VOC 2010+), and recall and precision of the boxes the runtime keeps at its default score
threshold. Detections are matched greedily by decreasing score to the unmatched ground-truth box
of the same class with the highest IoU (>= 0.5).

*Ignored* ground truth (neither a miss when not found nor a false positive when found): boxes with
the generator's ``visible`` < ``MIN_VISIBLE`` (mostly occluded), or whose shorter side is below
``MIN_SIDE`` px once letterboxed to the model's input (e.g. a 1920-px-wide frame is shrunk 4.6x
to 416 px: a ball under ~9 px there is ignored). A detection whose best match is an ignored box
counts for nothing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from reference_models.detector.data import EVAL_SEED0, cached_shard, render_eval_shard, shard_path
from reference_models.detector.train import MIN_SIDE, MIN_VISIBLE
from reference_models.scenes import PRESETS

CLASSES = ("person", "ball")


@dataclass(frozen=True)
class EvalSet:
    """One held-out image size: ``seeds`` scenes per preset, ``cameras`` x ``frames`` views each."""

    name: str
    """Label in the table (e.g. ``320x180``)."""
    width: int
    """Image width in px."""
    height: int
    """Image height in px."""
    spp: int
    """Samples per pixel of the renders."""
    seeds: int = 5
    """Scenes per preset (seeds ``EVAL_SEED0 ..``)."""
    cameras: int = 4
    """Views per scene: the evaluation cameras first, then spread training cameras."""
    frames: int = 2
    """Frames per camera."""


EVAL_SETS = (EvalSet("320x180", 320, 180, 4), EvalSet("960x540", 960, 540, 1, seeds=3))
"""The sets of the docs table: the generator's ``small`` size (5 scenes per preset), and 3x larger
(1 spp and 3 scenes per preset, for render time)."""
TINY_SETS = (EvalSet("64x36", 64, 36, 4, seeds=1, cameras=1, frames=1),)
"""A set that renders in seconds (tests)."""


def average_precision(scores: np.ndarray, tp: np.ndarray, n_gt: int) -> float | None:
    """All-point interpolated AP of detections (``scores`` (N,), ``tp`` (N,) bool) against
    ``n_gt`` ground-truth boxes; None when ``n_gt`` is 0 (undefined, not 0)."""
    if n_gt == 0:
        return None
    order = np.argsort(-np.asarray(scores, dtype=np.float64), kind="stable")
    hit = np.asarray(tp, dtype=bool)[order]
    ctp, cfp = np.cumsum(hit), np.cumsum(~hit)
    recall = ctp / n_gt
    precision = ctp / np.maximum(ctp + cfp, 1)
    r = np.concatenate([[0.0], recall, [recall[-1] if recall.size else 0.0]])
    p = np.concatenate([[1.0], precision, [0.0]])
    p = np.maximum.accumulate(p[::-1])[::-1]
    return float(np.sum((r[1:] - r[:-1]) * p[1:]))


def _iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a, b = a.astype(np.float64)[:, None], b.astype(np.float64)[None]
    iw = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    ih = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    inter = iw * ih
    area = lambda x: (x[..., 2] - x[..., 0]) * (x[..., 3] - x[..., 1])  # noqa: E731
    union = area(a) + area(b) - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def match(det_boxes: np.ndarray, det_scores: np.ndarray, gt_boxes: np.ndarray, gt_ignore: np.ndarray,
          iou: float = 0.5) -> tuple[np.ndarray, np.ndarray, int]:
    """Greedy matching of one image and class.

    Returns ``(tp (N,) bool, counted (N,) bool, n_found)``: ``tp`` a detection matched a counted
    ground-truth box, ``counted`` False for detections matching only ignored boxes, ``n_found`` the
    counted ground-truth boxes matched.
    """
    n = det_boxes.shape[0]
    tp, counted = np.zeros(n, dtype=bool), np.ones(n, dtype=bool)
    if gt_boxes.shape[0] == 0 or n == 0:
        return tp, counted, 0
    ious = _iou_matrix(det_boxes, gt_boxes)
    taken = np.zeros(gt_boxes.shape[0], dtype=bool)
    for i in np.argsort(-det_scores, kind="stable"):
        cand = np.where(~taken & ~gt_ignore, ious[i], -1.0)
        j = int(np.argmax(cand))
        if cand[j] >= iou:
            tp[i], taken[j] = True, True
        elif gt_ignore.any() and np.max(np.where(gt_ignore, ious[i], -1.0)) >= iou:
            counted[i] = False
    return tp, counted, int(taken.sum())


def ignored(records: list[dict], height: int, width: int, input_size: int) -> np.ndarray:
    """Which ground-truth records are ignored (see the module docstring), ``(N,)`` bool."""
    scale = min(input_size / height, input_size / width)
    out = []
    for r in records:
        x0, y0, x1, y1 = r["box"]
        out.append(r.get("visible", 1.0) < MIN_VISIBLE or min(x1 - x0, y1 - y0) * scale < MIN_SIDE)
    return np.asarray(out, dtype=bool)


def per_class(view: dict, det, input_size: int):  # noqa: ANN201
    """Yield ``(class, gt (G, 4), ignored (G,), det boxes (D, 4), det scores (D,))`` of one view."""
    h, w = view["image"].shape[:2]
    ign_all = ignored(view["boxes"], h, w, input_size)
    for c in CLASSES:
        sel = [k for k, r in enumerate(view["boxes"]) if r["class"] == c]
        gt = np.array([view["boxes"][k]["box"] for k in sel], dtype=np.int64).reshape(-1, 4)
        ign = ign_all[sel] if sel else np.zeros(0, dtype=bool)
        dm = np.array([n == c for n in det.classes], dtype=bool)
        yield c, gt, ign, det.boxes[dm], det.scores[dm].astype(np.float64)


def default_thresholds(det) -> dict[str, float]:
    """Per class, the minimum score a box needs in the runtime's defaults: ``score_threshold``
    and the model's own ``score_thresholds`` metadata (``Detector.class_thresholds``)."""
    out = {}
    for c in CLASSES:
        ids = [i for i, n in det.class_names.items() if n == c]
        out[c] = max([det.config.score_threshold, *(det.class_thresholds.get(i, 0.0) for i in ids)])
    return out


def evaluate(model: str | Path, cache: str | Path, sets: tuple[EvalSet, ...] = EVAL_SETS,
             presets: tuple[str, ...] = PRESETS, progress=None) -> dict:
    """Run ``model`` through ``dynaeval.regions.detector`` on the held-out views; return a dict
    with one row per (set, preset, class): ``ap50``, ``recall``, ``precision`` (None when
    undefined), ``gt``, ``ignored``, ``kept`` (boxes kept at the default thresholds: the runtime's
    ``score_threshold`` and the model's per-class ``score_thresholds``), and timings."""
    from dynaeval.regions.detector import Detector, DetectorConfig

    low = Detector(DetectorConfig(model=model, classes=CLASSES, score_threshold=0.01,
                                  model_thresholds=False))
    thresholds = default_thresholds(Detector(DetectorConfig(model=model, classes=CLASSES)))
    input_size = int(low._input_hw()[0] or 640)
    rows, det_seconds, n_images = [], 0.0, 0
    for es in sets:
        for preset in presets:
            acc = {c: {"scores": [], "tp": [], "counted": [], "gt": 0, "ign": 0, "found": 0,
                       "found_def": 0} for c in CLASSES}
            for i in range(es.seeds):
                seed = EVAL_SEED0 + i
                path = shard_path(Path(cache), f"eval-{es.name}-{es.spp}-{es.cameras}x{es.frames}", preset, seed)
                views = cached_shard(path, lambda p=preset, s=seed, e=es: render_eval_shard(
                    p, s, e.width, e.height, e.cameras, e.frames, e.spp))
                for v in views:
                    t = time.perf_counter()
                    det = low(v["image"])
                    det_seconds += time.perf_counter() - t
                    n_images += 1
                    for c, gt, ign, db, ds in per_class(v, det, input_size):
                        tp, counted, found = match(db, ds, gt, ign)
                        keep = ds > thresholds[c]
                        _, _, found_def = match(db[keep], ds[keep], gt, ign)
                        a = acc[c]
                        a["scores"].append(ds)
                        a["tp"].append(tp)
                        a["counted"].append(counted)
                        a["gt"] += int((~ign).sum())
                        a["ign"] += int(ign.sum())
                        a["found"] += found
                        a["found_def"] += found_def
                if progress is not None:
                    progress(f"{es.name} {preset} seed {seed}")
            for c in CLASSES:
                a = acc[c]
                scores = np.concatenate(a["scores"]) if a["scores"] else np.zeros(0)
                tp = np.concatenate(a["tp"]) if a["tp"] else np.zeros(0, dtype=bool)
                counted = np.concatenate(a["counted"]) if a["counted"] else np.zeros(0, dtype=bool)
                scores, tp = scores[counted], tp[counted]
                kept = scores > thresholds[c]
                n_kept, n_tp = int(kept.sum()), int((tp & kept).sum())
                rows.append({
                    "set": es.name, "preset": preset, "class": c, "gt": a["gt"], "ignored": a["ign"],
                    "ap50": average_precision(scores, tp, a["gt"]),
                    "recall": a["found_def"] / a["gt"] if a["gt"] else None,
                    "precision": n_tp / n_kept if n_kept else None,
                    "kept": n_kept,
                })
    return {"rows": rows, "images": n_images, "detect_seconds": det_seconds,
            "score_threshold": thresholds, "input_size": input_size,
            "min_visible": MIN_VISIBLE, "min_side": MIN_SIDE}


def _fmt(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3f}"


def to_markdown(result: dict, command: str, seconds: float, model_sha: str) -> str:
    """The results table as Markdown, with the command, model hash and wall time."""
    lines = [
        f"Command: `{command}` (wall {seconds:.0f} s including renders not cached; "
        f"{result['images']} images, detection {1000 * result['detect_seconds'] / max(1, result['images']):.0f} ms/image "
        f"on this shared 2-core machine). Model SHA-256 `{model_sha[:16]}...`.",
        "",
        f"Recall and precision at the runtime's default score thresholds "
        f"({', '.join(f'{c} {t:.2f}' for c, t in result['score_threshold'].items())}); "
        f"IoU >= 0.5. Ignored ground truth: visible < {result['min_visible']} or shorter side < "
        f"{result['min_side']} px at the {result['input_size']}-px model input.",
        "",
        "| size | preset | class | GT boxes | ignored | AP@0.5 | recall | precision | kept boxes |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in result["rows"]:
        lines.append(f"| {r['set']} | {r['preset']} | {r['class']} | {r['gt']} | {r['ignored']} | "
                     f"{_fmt(r['ap50'])} | {_fmt(r['recall'])} | {_fmt(r['precision'])} | {r['kept']} |")
    return "\n".join(lines) + "\n"

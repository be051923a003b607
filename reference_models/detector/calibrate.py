"""Per-class score thresholds of the default detector, chosen on calibration renders and stored
in the ONNX file's metadata (``score_thresholds``), which ``dynaeval.regions.detector`` applies.

Calibration scenes are seeds ``CALIB_SEED0 ..`` of each preset: neither training scenes (seeds >=
1000) nor the held-out evaluation scenes (seeds 0-4, which ``evaluate`` reports on; the bundled
sample is seed 0). Per class, the threshold with the highest F1 (recall and precision at IoU 0.5,
ignored ground truth as in ``evaluate``) over all calibration views of both sizes; ties: the lower
threshold.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from reference_models.detector.data import cached_shard, render_eval_shard, shard_path
from reference_models.detector.evaluate import CLASSES, EVAL_SETS, EvalSet, match, per_class
from reference_models.scenes import PRESETS

CALIB_SEED0 = 5
"""Calibration scenes: seeds 5, 6, ... (the evaluation uses 0-4, training >= 1000)."""
GRID = tuple(round(0.25 + 0.01 * i, 2) for i in range(56))
"""Thresholds tried: 0.25 (the runtime's floor) to 0.80 in steps of 0.01."""


def sweep(model: str | Path, cache: str | Path, sets: tuple[EvalSet, ...] = EVAL_SETS,
          seed0: int = CALIB_SEED0, grid: tuple[float, ...] = GRID, progress=None) -> dict:
    """Counts per class and threshold over the views of seeds ``seed0 ..``: ``{class: {"gt": n,
    "kept": (T,), "tp": (T,), "found": (T,)}}`` (lists, one entry per ``grid`` threshold)."""
    from dynaeval.regions.detector import Detector, DetectorConfig

    det = Detector(DetectorConfig(model=model, classes=CLASSES, score_threshold=min(grid),
                                  model_thresholds=False))
    input_size = int(det._input_hw()[0] or 640)
    acc = {c: {"gt": 0, "kept": np.zeros(len(grid), int), "tp": np.zeros(len(grid), int),
               "found": np.zeros(len(grid), int)} for c in CLASSES}
    for es in sets:
        for preset in PRESETS:
            for seed in range(seed0, seed0 + es.seeds):
                path = shard_path(Path(cache), f"calib-{es.name}-{es.spp}-{es.cameras}x{es.frames}",
                                  preset, seed)
                views = cached_shard(path, lambda p=preset, s=seed, e=es: render_eval_shard(
                    p, s, e.width, e.height, e.cameras, e.frames, e.spp))
                for v in views:
                    _count(det(v["image"]), v, input_size, grid, acc)
                if progress is not None:
                    progress(f"calibration {es.name} {preset} seed {seed}")
    return {c: {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in a.items()}
            for c, a in acc.items()}


def _count(det, view: dict, input_size: int, grid: tuple[float, ...], acc: dict) -> None:
    for c, gt, ign, db, ds in per_class(view, det, input_size):
        acc[c]["gt"] += int((~ign).sum())
        for t, thr in enumerate(grid):
            keep = ds > thr  # the runtime keeps scores above a threshold
            tp, counted, found = match(db[keep], ds[keep], gt, ign)
            acc[c]["kept"][t] += int(counted.sum())
            acc[c]["tp"][t] += int(tp.sum())
            acc[c]["found"][t] += found


def choose(counts: dict, grid: tuple[float, ...] = GRID) -> dict[str, dict]:
    """Per class the F1-best threshold with its recall, precision and F1 on the calibration set."""
    out = {}
    for c, a in counts.items():
        kept, tp, found = (np.asarray(a[k], dtype=float) for k in ("kept", "tp", "found"))
        recall = found / max(a["gt"], 1)
        precision = np.divide(tp, kept, out=np.ones_like(tp), where=kept > 0)
        f1 = np.divide(2 * recall * precision, recall + precision,
                       out=np.zeros_like(recall), where=recall + precision > 0)
        best = int(np.argmax(f1))  # first maximum: the lowest threshold among ties
        out[c] = {"threshold": grid[best], "recall": float(recall[best]),
                  "precision": float(precision[best]), "f1": float(f1[best]), "gt": a["gt"]}
    return out


def write_thresholds(model: str | Path, out: str | Path, thresholds: dict[str, float],
                     command: str) -> None:
    """Copy ``model`` to ``out`` with ``score_thresholds`` (and how they were made) in its
    metadata; the weights and graph are unchanged."""
    import shutil

    from dynaeval.regions.fetch import write_onnx_metadata

    if Path(model).resolve() != Path(out).resolve():
        shutil.copyfile(model, out)
    write_onnx_metadata(out, {"score_thresholds": repr({c: float(t) for c, t in thresholds.items()}),
                              "score_thresholds_by": command})


CALIB_SETS = tuple(replace(s, seeds=s.seeds) for s in EVAL_SETS)
"""The calibration sets: the evaluation's sizes and counts, other seeds."""

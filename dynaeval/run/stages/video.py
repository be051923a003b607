"""The video stage: video metrics (``jod``) once per camera over its whole frame sequence."""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from dynaeval.core.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.core.outcome import CameraTerm, Status
from dynaeval.io import FramePair
from dynaeval.io.video import video_fps
from dynaeval.run.stages.base import CameraWork, Stage, consecutive, metric_outcome

if TYPE_CHECKING:
    from dynaeval.run.plan import RunPlan


class Video(Stage):
    """``fn(pred_frames, gt_frames, fps, region)`` of every video metric of the plan
    (``RunPlan.camera_fns``), the camera's time split evenly between them."""

    name = "video"

    def applies(self, plan: RunPlan) -> bool:
        return bool(plan.camera_fns)

    def camera(self, plan: RunPlan, work: CameraWork) -> dict[str, CameraTerm]:
        t0 = time.perf_counter()
        out = video_metrics_of(plan, work)
        work.executor.add_time({name: (time.perf_counter() - t0) / len(plan.camera_fns)
                                for name in plan.camera_fns})
        return out


class _Clip:
    """One side of a camera's frames as a sequence read on demand (through the camera's cache)."""

    def __init__(self, pairs: list[FramePair], read: Callable[[FramePair], np.ndarray]) -> None:
        self.pairs, self.read = pairs, read

    def __len__(self) -> int:
        return len(self.pairs)

    def __getitem__(self, i: int) -> np.ndarray:
        return self.read(self.pairs[i])


def camera_fps(pairs: list[FramePair], fps: float) -> float:
    """The frame rate a camera is played at: its ground-truth video file's, else ``fps``
    (``ScoreConfig.fps``)."""
    ref = pairs[0].gt
    found = video_fps(ref.path) if ref.index is not None else None
    return found if found else fps


def video_metrics_of(plan: RunPlan, work: CameraWork) -> dict[str, CameraTerm]:
    """The video metrics (``jod``, ``focused_jod``) of one camera by result key: null with the
    reason for frames that differ in shape (``work.differ``) or are not consecutive, and for a
    focused window with no box in any frame."""
    camera, pairs, differ = work.name, work.pairs, work.differ
    status, reason = (
        (Status.NOT_A_VIDEO, differ.reason()) if differ is not None else
        (Status.NOT_CONSECUTIVE,
         "frames are not consecutive (some were skipped): a video metric needs the sequence")
        if not consecutive(pairs) else (Status.OK, None))
    fps = camera_fps(pairs, plan.config.fps)
    if reason is not None:
        return dict.fromkeys(plan.camera_fns, CameraTerm.null(status, reason))
    cache = work.cache
    pred = _Clip(pairs, lambda p: plan.read_pair(p, cache)[0])
    gt = _Clip(pairs, lambda p: plan.read_gt(p, cache))
    out: dict[str, CameraTerm] = {}
    for key, (region, fn) in plan.camera_fns.items():
        kw = {"boxes": [r.boxes for r in work.regions.frames]} if region == "focused" else {}
        try:
            out[key] = CameraTerm(metric_outcome(key, partial(fn, pred, gt, fps, kw)))
        except (EmptyRegionError, UndefinedMetricError) as err:
            status = Status.EMPTY_REGION if isinstance(err, EmptyRegionError) else Status.UNDEFINED
            out[key] = CameraTerm.null(status, str(err))
        except InputError as err:
            if err.path is not None:
                raise
            raise InputError(f"camera {camera!r}: {key}: {err}",
                             path=str(pairs[0].pred.path.parent)) from err
    return out

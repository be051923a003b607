"""Scoring one camera: its regions from the ground truth, then a loop over the plan's stages.

``dynaeval.run.plan.build_plan`` resolves the run once (a frozen ``RunPlan``); ``score_camera``
scores one camera with it: the regions (``camera_regions_of``), every frame through the frame
stages (per-frame metrics, presence; ``dynaeval.run.stages``) on the executor's pool, then the
camera stages (temporal terms, video metrics), and the camera's warnings.
``dynaeval.run.evaluate.score`` loops over the cameras and assembles the results.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import CameraTerm, Outcome, Status, note, warning
from dynaeval.core.progress import Progress
from dynaeval.core.validation import values_known_in
from dynaeval.io import FramePair
from dynaeval.io.images import FrameCache
from dynaeval.metrics.registry import METRICS
from dynaeval.regions.focus import CameraRegions, FrameRegions, camera_regions, fit_to
from dynaeval.regions.given import given_masks, with_weights
from dynaeval.regions.summary import regions_summary
from dynaeval.run.executor import RunWorkers, Stopped
from dynaeval.run.plan import RunPlan
from dynaeval.run.stages import CameraWork, FrameWork, Stage, active_stages


@dataclass
class CameraScores:
    """What one camera contributes to the results."""

    rows: list[dict[str, Any]]
    warnings: list[dict]
    temporal: dict[str, CameraTerm] | None
    """The camera-level terms (temporal, video) by result key; None: no camera stage ran."""
    regions: dict[str, Any] | None = None
    """``regions_summary`` of the camera (None with focus none and no motion masks)."""


# --------------------------------------------------------------------------------------------
# Regions


def camera_regions_of(camera: str, pairs: list[FramePair], plan: RunPlan, executor: RunWorkers,
                      cache: FrameCache, on_frame: Callable[[float], None] | None = None
                      ) -> CameraRegions:
    """The regions of a camera and its every frame, from its ground truth (timed as ``regions``);
    ``on_frame(share)``: progress within the camera (``regions.focus.camera_regions``)."""
    t0 = time.perf_counter()
    regions = plan.prepared.regions(camera) if plan.prepared is not None else None
    try:
        if regions is None:  # not prepared (dynaeval prepare): found here
            first_gt = plan.read_gt(pairs[0], cache)
            regions = camera_regions(
                camera, [p.frame for p in pairs],
                lambda i: plan.read_gt(pairs[i], cache),
                first_gt.shape[:2], plan.sources, executor.pool, paths=[p.gt for p in pairs],
                on_frame=on_frame,
            )
        if plan.masks is not None:
            regions = given_masks(regions, [p.gt.path for p in pairs], plan.masks,
                                  plan.focus.source)
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {camera!r}: regions of the ground truth: {err}",
                         path=str(pairs[0].gt.path.parent)) from err
    executor.add_time({"regions": time.perf_counter() - t0})
    return regions


def _summary_of(regions: CameraRegions, plan: RunPlan) -> dict[str, Any] | None:
    """The camera's ``regions_summary`` (None when it has neither boxes nor masks)."""
    focus = plan.focus
    if not focus.kind.gives_boxes and not focus.masked:
        return None
    return regions_summary(regions, focus.source, plan.sources.classes)


# --------------------------------------------------------------------------------------------
# Frames


def score_frame(pair: FramePair, regions: FrameRegions, plan: RunPlan, cache: FrameCache,
                executor: RunWorkers, stages: Sequence[Stage] | None = None,
                frames: Future | None = None, on_frame: Callable[[], None] | None = None,
                ) -> tuple[dict[str, Any], list[dict]]:
    """The results row of one frame (its values from the frame ``stages``, default the plan's;
    inf kept, None for undefined) and its warnings; ``frames``: the pair's ``plan.read_pair``
    read beforehand (``ReadAhead``), its error raised here; ``on_frame()``: called once the
    frame is scored (progress). An InputError that names no file is raised again naming the
    pair's files."""
    t0 = time.perf_counter()
    try:
        pred, gt = plan.read_pair(pair, cache) if frames is None else frames.result()
        elapsed = {"read": time.perf_counter() - t0}
        regions = fit_to(regions, gt.shape[:2], plan.focus)
        if plan.masks is not None and plan.protocol.uses_masks():
            regions = with_weights(regions, pair.gt.path, plan.masks)
        row: dict[str, Any] = {"camera": pair.camera, "frame": pair.frame, "index": pair.index,
                               "pred": str(pair.pred), "gt": str(pair.gt)}
        work = FrameWork(pair, pred, gt, regions, row, elapsed)
        with values_known_in(1.0, finite=True):  # read by dynaeval.io.images: in [0, 1] and
            # finite, no range or NaN/Inf pass per metric
            values = [v for stage in (active_stages(plan) if stages is None else stages)
                      for v in stage.frame(plan, work)]
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {pair.camera!r} frame {pair.frame!r} (ground truth {pair.gt}): "
                         f"{err}", path=str(pair.pred)) from err
    warnings: list[dict] = []
    for name, got in values:
        value = got.value
        if value is not None and math.isnan(value):  # inputs are checked finite before this point
            raise RuntimeError(f"{name} is NaN for {pair.pred}")
        if got.status is not Status.OK:
            warnings.append(warning(got.status, got.detail, camera=pair.camera, frame=pair.frame,
                                    metric=name))
        row[name] = value
    executor.add_time(elapsed)
    if on_frame is not None:
        on_frame()
    return row, warnings


class ReadAhead:
    """The frames of a camera's pairs read one pair ahead on a thread of their own, for a run
    without worker threads: decoding the prediction of frame i + 1 (and reading its ground
    truth) overlaps the metrics of frame i, which keep one core busy. Only the order of the
    work changes (the same ``plan.read_pair``, whose frames the cache keeps as before), so no
    number does; a read's error is raised at its own frame. ``close`` waits for the read in
    flight."""

    def __init__(self, plan: RunPlan, cache: FrameCache, pairs: list[FramePair]) -> None:
        self._plan, self._cache, self._pairs = plan, cache, pairs
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="dynaeval-read")
        self._ahead: dict[int, Future] = {}
        self._submit(0)

    def _submit(self, i: int) -> None:
        if i < len(self._pairs) and i not in self._ahead:
            self._ahead[i] = self._pool.submit(self._plan.read_pair, self._pairs[i], self._cache)

    def take(self, i: int) -> Future:
        """The read of pair ``i`` (started now if it was not), the read of ``i + 1`` started."""
        self._submit(i)
        fut = self._ahead.pop(i)
        self._submit(i + 1)
        return fut

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


# --------------------------------------------------------------------------------------------
# Cameras


def _not_video_warning(camera: str, pairs: list[FramePair], err: Any) -> dict:
    """The one warning of a camera whose frames differ in shape, naming the first odd file."""
    return warning(Status.NOT_A_VIDEO, camera=camera, detail=(
        f"{err.reason()}: {pairs[err.index].gt} differs from {pairs[0].gt}; its frames are "
        "scored one by one, its temporal and motion-mask values are null"))


class CameraProgress:
    """One camera's share of the run's ``Progress``: its frames, its temporal pairs (those it
    could not score count as done at the end) and its video step; the regions phase moves as
    each frame's regions are found (``region_frame``; it sat at one count while a camera's
    motion masks and detector ran), up to the camera's ``frames``; ``stop`` (a
    ``threading.Event``, cameras scored at once) is checked at every frame and pair and
    ``Stopped`` raised once it is set."""

    def __init__(self, progress: Progress, camera: str, stop: threading.Event | None,
                 frames: int) -> None:
        self.progress, self.camera, self.stop, self.frames = progress, camera, stop, frames
        self.pairs, self.regions = 0, 0.0
        progress.set_note(f"camera {camera}")

    def tick(self, phase: str, units: float = 1) -> None:
        if self.stop is not None and self.stop.is_set():
            raise Stopped(f"camera {self.camera} stopped: another camera failed")
        self.progress.advance(phase, units)

    def region_frame(self, share: float) -> None:
        """``share`` of a frame's regions found (a motion mask, a detector pass)."""
        step = min(share, self.frames - self.regions)
        if step > 0:
            self.regions += step
            self.tick("regions", step)

    def regions_found(self) -> None:
        """The camera's regions are all found: the rest of its frames (prepared, boxes)."""
        self.progress.advance("regions", self.frames - self.regions)

    def frame(self) -> None:
        self.tick("frames")

    def pair(self) -> None:
        self.pairs += 1
        self.tick("pairs")

    def done(self, n_pairs: int | None) -> None:
        """The camera is scored: those of its ``n_pairs`` temporal pairs not ticked (None: no
        temporal terms in the run), its video step."""
        if n_pairs is not None:
            self.progress.advance("pairs", n_pairs - self.pairs)
        self.progress.advance("video")


def score_camera(camera: str, pairs: list[FramePair], stop: threading.Event | None = None, *,
                 plan: RunPlan, executor: RunWorkers, progress: Progress,
                 on_regions: Callable | None = None) -> CameraScores:
    """Regions, per-frame values and camera-level terms of one camera (its frames in order).

    ``on_regions(camera, pairs, frame_regions)`` is called before the frames are scored; the frames,
    temporal pairs and the video step advance ``progress`` (``CameraProgress``; ``stop``: set
    when another camera scored at the same time has failed). Cameras may be scored at the same
    time with one ``executor`` (its pool is shared; nothing here depends on order). Without
    worker threads the frames are scored here, one after the other (read one ahead), not
    through the executor: no hop between the camera and its frames.
    """
    ticks = CameraProgress(progress, camera, stop, frames=len(pairs))
    cache = executor.frame_cache()  # dropped at the end
    regions = camera_regions_of(camera, pairs, plan, executor, cache, ticks.region_frame)
    ticks.regions_found()
    if on_regions is not None:
        on_regions(camera, pairs, regions.frames)
    stages = active_stages(plan)
    score = partial(score_frame, plan=plan, cache=cache, executor=executor, stages=stages,
                    on_frame=ticks.frame)
    if executor.pool is not None:
        outputs = list(executor.pool.map(score, pairs, regions.frames))
    else:
        ahead = ReadAhead(plan, cache, pairs) if len(pairs) > 1 else None
        try:
            outputs = [score(p, r, frames=None if ahead is None else ahead.take(i))
                       for i, (p, r) in enumerate(zip(pairs, regions.frames, strict=True))]
        finally:
            if ahead is not None:
                ahead.close()
    rows = [row for row, _ in outputs]
    warnings = [w for _, ws in outputs for w in ws]
    cam = CameraWork(camera, pairs, regions, cache, executor, differ=regions.not_video,
                     on_pair=ticks.pair)
    temporal = None
    for stage in stages:
        terms = stage.camera(plan, cam)
        if terms is not None:
            temporal = {**(temporal or {}), **terms}
    differ = cam.differ
    if differ is not None:
        warnings.insert(0, _not_video_warning(camera, pairs, differ))
    if regions.motion is not None and regions.motion.reason is not None:
        warnings.insert(0, note(regions.motion.reason, camera=camera))
    if temporal is not None and differ is None:
        temporal, named = name_regionless_frames(camera, pairs, regions.frames, temporal)
        warnings.extend(named)
    ticks.done(len(pairs) - 1 if plan.temporal is not None else None)
    return CameraScores(rows, warnings, temporal, _summary_of(regions, plan))


def name_regionless_frames(camera: str, pairs: list[FramePair], regions: list[FrameRegions],
                           temporal: dict[str, CameraTerm]
                           ) -> tuple[dict[str, CameraTerm], list[dict]]:
    """The terms with the frames without boxes named in the focused ones: a term null for the
    whole camera for want of a region gets them as its reason; one scored on the other pairs
    gets them as ``pair_null`` (why its null pairs are null) and one camera warning. Returns the
    terms and the warnings."""
    missing = [(p.frame, r.boxes_missing and r.boxes_missing.detail)
               for p, r in zip(pairs, regions, strict=True) if r.boxes is None]
    if not missing or len(pairs) < 2:
        return temporal, []
    why = "; ".join(dict.fromkeys(r or "no box" for _, r in missing))
    shown = ", ".join(repr(f) for f, _ in missing[:8]) + (" ..." if len(missing) > 8 else "")
    frames = f"{len(missing)} of {len(pairs)} frames have no box ({why}): {shown}"
    out, terms = [], dict(temporal)
    for key, term in temporal.items():
        if METRICS[key].variant != "focused":
            continue
        if term.outcome.value is None:
            if term.outcome.status is Status.NO_REGION:  # not another cause (too few frames, ...)
                terms[key] = replace(term, outcome=Outcome(
                    None, Status.NO_REGION,
                    f"{frames}; no pair of consecutive frames has boxes in both"))
        elif METRICS[key].kind == "camera":
            out.append(note(f"over the union of the boxes of the frames that have them; {frames}",
                            camera=camera, metric=key))
        else:
            terms[key] = replace(term, pair_null=Outcome(
                None, Status.NO_REGION, f"this frame or the previous one has no box ({why})"))
            out.append(note(f"scored on the pairs of frames that both have boxes; {frames}",
                            camera=camera, metric=key))
    return terms, out

"""The temporal stage: warp error, tOF, tLP and flicker over a camera's consecutive frames
(``dynaeval.metrics.temporal``), or every term null with the reason."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from dynaeval.core.errors import InputError, UndefinedMetricError
from dynaeval.core.outcome import CameraTerm, Status
from dynaeval.core.validation import values_known_in
from dynaeval.io import FramePair
from dynaeval.io.frames import gap_positions
from dynaeval.metrics.flow import check_flow_size
from dynaeval.metrics.perceptual import MIN_SIZE
from dynaeval.metrics.registry import SPECS, temporal_keys
from dynaeval.metrics.temporal import TemporalRun, temporal_metrics
from dynaeval.regions.focus import CameraRegions, FocusConfig, FramesDiffer, same_shape
from dynaeval.regions.packed import union
from dynaeval.run.stages.base import CameraWork, Stage

if TYPE_CHECKING:
    from dynaeval.run.plan import RunPlan


class Temporal(Stage):
    """The camera's temporal terms (timed as ``temporal``); frames found to differ in shape here
    are recorded in ``CameraWork.differ``."""

    name = "temporal"

    def applies(self, plan: RunPlan) -> bool:
        return plan.temporal is not None

    def camera(self, plan: RunPlan, work: CameraWork) -> dict[str, CameraTerm]:
        # the camera's pairs run on the pool (flows dominate: 3 per pair); the frames are
        # decoded here meanwhile (and, with cameras at once, the other camera's work goes on)
        t0 = time.perf_counter()
        terms, work.differ = _temporal_or_reason(plan, work)
        work.executor.add_time({"temporal": time.perf_counter() - t0})
        return terms


def _temporal_or_reason(plan: RunPlan, work: CameraWork) -> tuple[dict[str, CameraTerm], Any]:
    """The camera's temporal terms, or every term null with the reason: frames that differ in
    shape (``work.differ``: the ``FramesDiffer`` found by the regions; or found here, returned
    beside the terms), frames too small for optical flow. InputErrors that name no file are
    raised naming the camera."""
    camera, pairs, differ = work.name, work.pairs, work.differ
    def nulls(status: Status, reason: str) -> dict[str, CameraTerm]:
        return dict.fromkeys(temporal_keys(), CameraTerm.null(status, reason))

    if differ is not None:
        return nulls(Status.NOT_A_VIDEO, differ.reason()), differ
    shape = plan.read_gt(pairs[0], work.cache).shape
    try:
        check_flow_size(shape)
    except UndefinedMetricError as err:
        return nulls(Status.UNDEFINED, f"temporal terms of camera {camera!r}: {err}"), None
    try:
        return temporal_of_camera(plan, work, shape), None
    except FramesDiffer as err:
        return nulls(Status.NOT_A_VIDEO, err.reason()), err
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {camera!r}: temporal terms: {err}",
                         path=str(pairs[0].pred.path.parent)) from err


def _with_gaps(pairs: list[FramePair], terms: dict[str, CameraTerm]) -> dict[str, CameraTerm]:
    """The terms with per-pair values given the reason of each gap's null value
    (``CameraTerm.gaps``: ``Status.NOT_CONSECUTIVE``)."""
    gaps = gap_positions(pairs)
    if not gaps:
        return terms
    reasons = {k: (f"not a pair of consecutive frames: the ground-truth frame(s) between "
                   f"{pairs[k].frame!r} and {pairs[k + 1].frame!r} have no prediction "
                   "(--allow-missing)") for k in gaps}
    return {k: replace(t, gaps=reasons) if t.per_pair else t for k, t in terms.items()}


def _small_for_tlp(plan: RunPlan, h: int, w: int) -> str | None:
    """Why tLP is undefined for frames of (h, w), or None (LPIPS's backbone has a minimum)."""
    net = plan.temporal.lpips_net
    if "lpips" not in plan.fns or not plan.temporal.tlp or min(h, w) >= MIN_SIZE.get(net, 0):
        return None
    return (f"tLP needs frames of at least {MIN_SIZE[net]}x{MIN_SIZE[net]} pixels (LPIPS {net}), "
            f"got {w}x{h}")


def static_pixels(regions: CameraRegions, focus: FocusConfig,
                  shape: tuple[int, ...]) -> np.ndarray | None:
    """The camera's static pixels, ``(H, W) = shape[:2]`` bool: never moving in any frame's
    motion mask. A static camera whose motion masks are all empty (nothing moves: a fact, not a
    missing mask) is static everywhere. None: no masked metrics, no motion masks (too few frames,
    frames that differ in shape), or a camera that does not look static with no moving pixel."""
    if not focus.masked:
        return None
    frames = regions.frames
    moving = union(r.packed_mask for r in frames if r.packed_mask is not None)
    if moving is not None:
        return ~moving
    looks_static = regions.motion is not None and regions.motion.reason is None
    nothing_moves = bool(frames) and looks_static and all(
        r.mask_missing is not None and r.mask_missing.status is Status.EMPTY_REGION
        for r in frames)
    return np.ones(shape[:2], dtype=bool) if nothing_moves else None


def region_items(regions: CameraRegions, focus: FocusConfig) -> list | None:
    """Each frame's focus region for the temporal terms (its boxes; None for a frame without),
    or None when the run has no focus (``focus: none``)."""
    return [r.boxes for r in regions.frames] if focus.kind.gives_boxes else None


def temporal_of_camera(plan: RunPlan, work: CameraWork,
                       shape: tuple[int, ...]) -> dict[str, CameraTerm]:
    """The temporal terms of the camera of ``work`` (``dynaeval.metrics.temporal
    .temporal_metrics``), its ground truth of ``shape`` (the first frame's), with the reasons
    of the gaps of missing frames; tLP null with the reason when the frames are smaller than
    LPIPS accepts."""
    pairs, regions, cache, prepared = work.pairs, work.regions, work.cache, plan.prepared
    static = static_pixels(regions, plan.focus, shape)
    region_masks = region_items(regions, plan.focus)  # a frame's None: its pairs' focused: None
    small = _small_for_tlp(plan, *shape[:2])
    tcfg = plan.temporal if "lpips" in plan.fns and small is None else replace(plan.temporal, tlp=False)
    gt_of = same_shape(lambda i: plan.read_gt(pairs[i], cache), shape)
    with values_known_in(1.0, finite=True):  # frames read by dynaeval.io.images: no NaN/Inf pass
        out = temporal_metrics(
            (plan.read_pair(p, cache)[0] for p in pairs),
            (gt_of(i) for i in range(len(pairs))),
            static_mask=static,
            region_masks=region_masks,
            config=tcfg,
            frame_indices=[p.index for p in pairs],
            run=TemporalRun(
                executor=work.executor.pool,
                window=work.executor.window,  # pairs in flight, all cameras: 2 x workers
                on_pair=work.on_pair,
                flow_cache=prepared.flow_cache() if prepared is not None else None,
                gt_flicker=None if static is None or prepared is None
                else prepared.gt_flicker(pairs[0].camera, static),
                gt_pairs=None if prepared is None else prepared.ground_truth_pairs(pairs[0].camera),
            ),
        )
    terms = _with_gaps(pairs, out)
    if small is not None:
        terms.update(dict.fromkeys(SPECS["tlp"].keys(), CameraTerm.null(Status.UNDEFINED, small)))
    return terms

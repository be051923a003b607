"""The one orchestration: find the frames, prepare the run, score camera by camera, assemble.

``score(pred, gt, config)`` returns a ``Results`` (a dict in the results-JSON layout of
``dynaeval.report.results``) and is exactly what ``dynaeval score`` calls, with the same defaults
(``ScoreConfig``'s).

Order of work, camera by camera (so memory is bounded by one camera's regions,
``dynaeval.run.scoring``; with ``workers`` > 1, up to ``workers`` cameras at a time, sharing the
frame cache budget):

1. regions from the ground truth only (``dynaeval.regions.focus``): boxes (detector, boxes file
   or motion) expanded and merged, and motion masks;
2. per frame (``workers`` threads): every registered per-frame metric over the whole frame, the
   boxes (``focused_*``) and the motion mask (``masked_*``), and object presence;
3. per camera: temporal terms over consecutive frames (``dynaeval.metrics.temporal``).

Run-level warnings (a metric unavailable, render folders scored as a sequence, a summary that is
null) are in ``results["warnings"]`` and are also issued as Python warnings
(``DynaevalWarning``).
"""

from __future__ import annotations

import time
import warnings as pywarnings
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import CameraTerm, Status, note, warning, warning_line
from dynaeval.core.progress import Progress
from dynaeval.core.runtime import worker_opencv_threads
from dynaeval.core.version import VERSION
from dynaeval.io import FramePair
from dynaeval.io.frames import (
    consecutive_pairs,
    missing_frames_warning,
    pairs_by_camera,
    select_shard,
)
from dynaeval.io.layouts import detect_layout
from dynaeval.io.masks import check_masks, find_masks, unused_mask_folders
from dynaeval.io.video import close_videos
from dynaeval.metrics.protocols import get_protocol
from dynaeval.metrics.registry import SPECS
from dynaeval.regions.focus import FrameRegions
from dynaeval.report.results import RunRecord, build_results
from dynaeval.run.config import ScoreConfig
from dynaeval.run.executor import RunWorkers
from dynaeval.run.plan import RunPlan, Scope, build_plan
from dynaeval.run.prepared_gt import open_prepared
from dynaeval.run.scoring import score_camera
from dynaeval.run.stages import metric_names

__all__ = ["DynaevalWarning", "Results", "ScoreConfig", "score"]

RegionsCallback = Callable[[str, list[FramePair], list[FrameRegions]], None]


class DynaevalWarning(UserWarning):
    """A run-level warning of ``score`` (also recorded in ``results["warnings"]``)."""


class Results(dict):
    """Results of a scoring run: a dict in the results-JSON layout, plus table accessors."""

    def to_dataframe(self, level: str = "frames"):
        """Per-frame (``level="frames"``) or per-camera (``"cameras"``) values as a pandas DataFrame."""
        import pandas as pd

        if level == "frames":
            return pd.DataFrame(self["frames"])
        if level == "cameras":
            return pd.DataFrame.from_dict(self["cameras"], orient="index").rename_axis("camera")
        raise ValueError(f"level must be 'frames' or 'cameras', got {level!r}")


def score(
    pred_dir: str | Path,
    gt_dir: str | Path | None = None,
    config: ScoreConfig | None = None,
    *,
    on_regions: RegionsCallback | None = None,
    **overrides: Any,
) -> Results:
    """Score predicted frames against ground-truth frames.

    Args:
        pred_dir: predictions: images (flat, or one sub-folder per camera) or videos; or a
            render folder of a known layout (NeRFBaselines ``color/`` + ``gt-color/``,
            ``ns-render`` ``rgb/`` + ``gt-rgb/``, a 3DGS-family ``MODEL`` or
            ``MODEL/test/ours_<N>``: ``config.iteration`` / ``config.split`` choose) with
            ``gt_dir`` None, or a K-Planes evaluation stack ``step<N>.mp4`` (or its log folder)
            alone (``dynaeval.io.layouts``, ``dynaeval.io.kplanes``).
        gt_dir: ground truth in the same layout; frames are paired by relative path with the
            extension ignored (``dynaeval.io.frames`` gives the rules).
        config: settings (default ``ScoreConfig()``, the CLI's defaults); keyword
            ``overrides`` replace its fields (``score(p, g, workers=2)``); ``focus`` takes the
            CLI's strings too (``score(p, g, focus="motion")`` is ``--focus motion``).
        on_regions: called once per camera, before its frames are scored, with the camera name,
            its pairs and their regions (``FrameRegions``, same order): how a report keeps the
            boxes and masks it draws without ``score`` holding every camera's masks.

    Returns:
        Results: per-frame values, per-camera and overall means, settings and timing (the layout
        of the results JSON, see docs/results-format.md).

    Raises:
        InputError: bad input or settings (missing frames, size mismatch, unreadable file, NaN
            pixels, an unknown metric, ...), raised before the work where it can be.
    """
    config = replace(config or ScoreConfig(), **overrides)  # __post_init__ checks the fields
    t_start = time.perf_counter()
    layout = detect_layout(pred_dir, gt_dir, iteration=config.iteration, split=config.split)
    pairing = _pair_layout(layout, config)
    masks, mask_warnings = _given_masks(config, layout, pairing.pairs)
    scope = per_frame_only(config, layout, masks)
    progress = run_progress(pairing.pairs, scope.temporal, config.progress)  # before the metrics load
    try:
        plan = build_plan(config, scope=scope, masks=masks,
                          prepared=_prepared_opener(config, layout, pairing.pairs))
    except BaseException:
        progress.close(completed=False)
        raise
    progress.restart()  # loading the metrics is no unit of work
    gaps = consecutive_pairs(pairing)
    run_warnings = [*plan.warnings, *_input_warnings(config, layout, pairing, mask_warnings, gaps,
                                                     scope)]
    rows, warnings, temporal, regions, timing = _score_cameras(pairing.pairs, plan, on_regions,
                                                               progress)
    kind = layout.kind
    run_name = (kind.run_folder(layout, Path(pred_dir)).resolve().name if kind.render_folder
                else None)
    results = _assemble(layout, run_name, pairing, plan, rows, [*run_warnings, *warnings],
                        temporal, {"total_s": time.perf_counter() - t_start, **timing}, regions)
    if gaps and scope.temporal:
        results["inputs"]["temporal_pairs"] = {
            c: {"scored": g["scored"], "expected": g["expected"]} for c, g in gaps.items()}
    for w in results["warnings"]:
        if "camera" not in w:
            pywarnings.warn(warning_line(w), DynaevalWarning, stacklevel=2)
    return results


def _prepared_opener(config: ScoreConfig, layout: Any, pairs: list[FramePair]) -> Any:
    """``build_plan``'s ``prepared``: opens ``config.prepared`` against the run (its ground-truth
    folder, pairs, region sources and temporal terms), or None without ``--prepared``."""
    if config.prepared is None:
        return None

    return lambda sources, temporal: open_prepared(config.prepared, layout.gt, pairs, config,
                                                   sources, temporal=temporal)


def _input_warnings(config: ScoreConfig, layout: Any, pairing: Any, mask_warnings: list[dict],
                    gaps: dict, scope: Scope) -> list[dict]:
    """Run-level warnings about the inputs, in the order the results list them: damaged video
    files, given masks, the layout's notes, missing frames, a render folder scored under another
    protocol than its own, frames scored as separate views."""
    warnings = [*pairing.warnings, *mask_warnings, *(note(text) for text in layout.notes)]
    if gaps:
        warnings.append(missing_frames_warning(gaps, scope.temporal))
    own = layout.kind.own_protocol(layout) or config.protocol
    if config.protocol != own:
        warnings.append(note(
            f"{layout.details['family']} render folder scored under --protocol "
            f"{config.protocol}: the numbers of its own metrics.py are --protocol {own} / "
            f"protocol='{own}'"))
    if scope.sequence is not None and scope.sequence["skipped"]:
        warnings.append(warning(Status.NOT_A_VIDEO, scope.sequence["reason"]))
    return warnings


def _pair_layout(layout: Any, config: ScoreConfig) -> Any:
    """The frame pairs of ``layout`` (a ``dynaeval.io.layouts`` Layout), this run's shard of
    them when ``config.shard`` is set: a ``Pairing``."""
    pairing = layout.kind.pairing(layout, config.allow_missing)
    if config.shard is not None:
        pairing = select_shard(pairing, *config.shard)
    return pairing


def per_frame_only(config: ScoreConfig, layout: Any, masks: Any) -> Scope:
    """What the run scores of its frames (``dynaeval.run.plan.Scope``): what ``config`` asks when
    they are a video, less when they are separate views; with the results'
    ``settings["sequence"]`` (None for frames that are a video by default: nothing changes).

    Separate views (``layout.sequence`` False unless ``config.frames_are_video``, or
    ``frames_are_video=False``) are scored per frame: no temporal terms, no motion masks (and no
    ``masked_*`` unless ``masks``, given masks, are there), since neither means anything across
    unrelated photos. ``Scope.sequence`` = ``{"video", "reason", "skipped"}``.

    Raises:
        InputError: ``--focus motion`` or a video metric (``jod``) asked for on separate views.
    """
    video = layout.sequence if config.frames_are_video is None else config.frames_are_video
    what = (f"the {layout.name} render folder's frames" if layout.kind.render_folder
            else "the frames")
    if video:
        return Scope(config.temporal, config.focus.masked, None if layout.sequence else {
            "video": True, "skipped": [],
            "reason": f"frames_are_video: {what} are scored as one video per camera"})
    why = ("are separate test views, not a video" if config.frames_are_video is None
           else "are scored as separate views (frames_are_video=False)")
    fix = ("pass --frames-are-video (frames_are_video=True) if they are one camera's video"
           if config.frames_are_video is None else "drop frames_are_video=False")
    video_metrics = [n for n in config.metrics if SPECS[n].kind == "camera"]
    if config.focus.kind.from_motion or video_metrics:
        asked = (f"--focus {config.focus.source}" if config.focus.kind.from_motion
                 else f"--{video_metrics[0]}")
        raise InputError(f"{asked} needs each camera's frames as a video, but {what} {why}; "
                         f"{fix}, or drop {asked}", path=layout.pred)
    masked = config.focus.masked and masks is not None  # over the given masks only
    skipped = [*(["temporal terms"] if config.temporal else []),
               *(["motion masks and masked_*"] if config.focus.masked and not masked else [])]
    reason = (f"{what} {why}: scored per frame only"
              + (f" ({' and '.join(skipped)} skipped, meaningless across unrelated views); {fix}"
                 if skipped else ""))
    return Scope(False, masked, {"video": False, "skipped": skipped, "reason": reason})


def _given_masks(config: ScoreConfig, layout: Any, pairs: list[FramePair]) -> tuple[Any, list[dict]]:
    """The run's given masks (``dynaeval.io.masks.find_masks``), checked for every frame before
    the work, and warnings about mask folders left unused or a protocol missing its masks.

    Raises:
        InputError: a missing mask, a mask of another size, masks for video frames.
    """
    protocol = get_protocol(config.protocol)
    gt_files = [p.gt.path for p in pairs if p.gt.index is None]
    masks = find_masks(config.masks, layout.gt, gt_files, layout.root, protocol.decode_rule())
    if masks is not None:
        if len(gt_files) != len(pairs):
            raise InputError("given masks need ground truth as image files, not video frames",
                             path=masks.folder)
        masks = check_masks(masks, [(p.gt.path, p.gt.size() if hasattr(p.gt, "size") else None)
                                    for p in pairs])  # a DyCheck render's panel: its own size
    warnings = []
    roots = [layout.pred, layout.gt, *([layout.root] if layout.root is not None else [])]
    for folder in unused_mask_folders(masks, roots):
        warnings.append(note(
            f"mask folder {folder} is not used (NeRFBaselines or DyCheck would apply it): pass "
            "--masks with it to score masked_* over it, and the protocol's masked numbers"))
    if masks is not None and not config.focus.masked and not protocol.uses_masks():
        warnings.append(note(f"masks {masks.folder} are not used: --no-masked skips masked_*"))
    if masks is None and protocol.mask_regions():
        warnings.append(note(
            f"protocol {protocol.name}: no covisibility masks found, so mpsnr, mssim and mlpips "
            "are not computed; pass --masks DATASET/covisible/<factor>x/<split>"))
    return masks, warnings


def run_progress(pairs: list[FramePair], temporal: bool, enabled: bool) -> Any:
    """The run's ``dynaeval.core.progress.Progress`` (silent unless ``enabled``): regions and scored
    frames per frame, temporal pairs per consecutive pair (with ``temporal`` terms), video
    metrics per camera."""
    cams = pairs_by_camera(pairs)
    n_pairs = sum(len(c) - 1 for c in cams.values()) if temporal else 0
    return Progress({"regions": len(pairs), "frames": len(pairs), "pairs": n_pairs,
                     "video": len(cams)}, enabled=enabled)


def _score_cameras(pairs: list[FramePair], plan: RunPlan, on_regions: RegionsCallback | None,
                   progress: Any) -> tuple[list, list, dict, dict, dict]:
    """Every camera's rows, warnings, temporal terms and regions summary, in camera order, and
    the run's seconds per phase.

    With ``workers`` > 1 and several cameras, up to ``workers`` cameras are scored at the same
    time (``RunWorkers.lanes``), all feeding the one pool of ``workers`` threads: a camera's serial
    steps (regions, decoding, folding the pairs) overlap another's frames and flows, and the
    pool does not drain between a camera's phases. Each camera's numbers do not depend on it.
    """
    cams = pairs_by_camera(pairs)
    executor = RunWorkers(plan.config.workers, len(cams), cache_mb=plan.config.cache_mb,
                        decoded=plan.prepared.decoded if plan.prepared is not None else None)

    score = partial(score_camera, plan=plan, executor=executor, progress=progress,
                    on_regions=on_regions)
    completed = False
    try:
        with worker_opencv_threads(executor.workers):
            scored = ([score(c, p) for c, p in cams.items()] if executor.lanes == 1
                      else executor.cameras_at_once(cams, score))
        completed = True
    finally:
        progress.close(completed)
        executor.shutdown(completed)
        close_videos()
    rows: list[dict] = []
    warnings: list[dict] = []
    temporal: dict[str, dict[str, CameraTerm]] = {}
    regions: dict[str, dict] = {}
    for cam, scores in zip(cams, scored, strict=True):
        rows.extend(scores.rows)
        warnings.extend(scores.warnings)
        if scores.temporal is not None:
            temporal[cam] = scores.temporal
        if scores.regions is not None:
            regions[cam] = scores.regions
    return rows, warnings, temporal, regions, dict(executor.timing)


def _assemble(layout: Any, run_name: str | None, pairing: Any, plan: RunPlan, rows: list,
              warnings: list, temporal: dict, timing: dict, regions: dict) -> Results:
    """The results document; method and scene default to the folders' names (the render
    folder's, ``run_name``, for a known layout)."""
    config = plan.config
    method = config.method or run_name or layout.pred.resolve().name
    scene = config.scene or run_name or layout.gt.resolve().name
    inputs_extra = ({} if run_name is None else
                    {"layout": {"name": layout.name, "root": str(layout.root), **layout.details,
                                **layout.kind.describe(layout, pairing)}})
    return Results(build_results(RunRecord(
        rows=rows, metric_names=metric_names(plan), method=method, scene=scene,
        pred_dir=str(layout.pred), gt_dir=str(layout.gt), settings=dict(plan.settings),
        unscored_cameras=pairing.unscored_cameras, shard=config.shard,
        skipped=pairing.skipped, warnings=warnings, timing=timing,
        version=VERSION, temporal=temporal, inputs_extra=inputs_extra,
        regions=_regions_doc(plan, regions),
    )))


def _regions_doc(plan: RunPlan, cameras: dict[str, dict]) -> dict[str, Any] | None:
    """The results' ``regions``: where the boxes came from and what each camera's regions hold."""
    if not cameras:
        return None
    det = plan.sources.detector
    return {"source": plan.focus.source,
            "bundled_detector": det is not None and det.bundled, "cameras": cameras}

"""Scoring one camera: its regions, every frame's per-frame metrics and presence, its temporal terms.

``prepare_run`` turns a checked ``ScoreConfig`` into a ``Run`` (the built metric functions, the
opened region sources, the presence step, the temporal settings, and the ``settings`` that go
into the results); ``score_camera`` scores one camera with it. ``dynaeval.evaluate.score`` loops
over the cameras and assembles the results.
"""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dynaeval.config import ScoreConfig
from dynaeval.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.io import FramePair
from dynaeval.io.cache import FrameCache
from dynaeval.io.frames import gap_positions
from dynaeval.metrics.flow import check_flow_size
from dynaeval.metrics.registry import (
    COVISIBLE_RULE,
    METRICS,
    REGION_RULES,
    FrameFn,
    region_argument,
    temporal_keys,
)
from dynaeval.regions.focus import FrameRegions
from dynaeval.report.results import INFINITE_MARK
from dynaeval.validation import values_known_in

PresenceStep = Callable[[FramePair, np.ndarray, np.ndarray, FrameRegions],
                        tuple[dict[str, float | None], dict[str, str], list[dict]]]


@dataclass
class Run:
    """Per-run state shared by every camera."""

    config: ScoreConfig
    """The run's settings (``quantize`` and ``lpips_net`` resolved to the protocol's)."""
    fns: dict[str, tuple[str, FrameFn]]
    """Result key -> (region variant, function), from the registry."""
    settings: dict[str, Any]
    """The results' ``settings``."""
    warnings: list[dict]
    """Run-level warnings so far (a metric unavailable, ...)."""
    sources: Any
    """``dynaeval.regions.focus.RegionSources``: the opened detector or boxes file."""
    presence: PresenceStep | None = None
    """The per-frame presence step, or None when it does not run."""
    temporal: Any = None
    """``TemporalConfig`` of the temporal terms, or None when they do not run."""
    pool: ThreadPoolExecutor | None = None
    """Worker threads (``workers > 1``)."""
    timing: dict[str, float] = field(default_factory=lambda: defaultdict(float))
    """Seconds per phase and metric, summed over frames."""
    lock: threading.Lock = field(default_factory=threading.Lock)
    """Guards ``timing``."""
    lanes: int = 1
    """Cameras scored at the same time (``dynaeval.evaluate``); their frame caches share
    ``config.cache_mb``."""
    every: dict[str, int] = field(default_factory=dict)
    """Result key -> K: that per-frame metric is scored on frames whose index % K == 0 only."""
    camera_fns: dict[str, tuple[str, Any]] = field(default_factory=dict)
    """Video metrics (``jod``): result key -> (region variant, ``fn(pred_frames, gt_frames,
    fps, region)``), one value per camera."""
    masks: Any = None
    """``dynaeval.io.masks.MaskSet`` of given masks (``masked_*`` over them), or None."""
    protocol: Any = None
    """The run's ``dynaeval.metrics.protocols.Protocol``."""
    prepared: Any = None
    """``dynaeval.prepare.PreparedGT`` of ``--prepared`` (regions and flows read), or None."""

    def add_time(self, times: dict[str, float]) -> None:
        with self.lock:
            for k, v in times.items():
                self.timing[k] += v

    @property
    def metric_names(self) -> list[str]:
        """Result keys of the per-frame values, in report order."""
        from dynaeval.metrics.presence import PRESENCE_METRICS

        return [*self.fns, *(PRESENCE_METRICS if self.presence else ())]


def prepare_run(config: ScoreConfig, masks: Any = None) -> Run:
    """Build the metrics, open the region sources and describe the run (before any frame is read).

    ``masks``: the given masks (``dynaeval.io.masks.MaskSet``) or None: ``masked_*`` are then
    computed over them instead of the motion masks, and a protocol that uses masks
    (``Protocol.masks``) gets their weights.

    Raises:
        InputError: an unusable detector or boxes file.
    """
    from dynaeval.metrics.protocols import get_protocol, run_metrics
    from dynaeval.metrics.registry import SPECS, FrameContext, build_frame_metrics
    from dynaeval.regions.focus import open_sources
    from dynaeval.runtime import resolve_device

    config = replace(config, quantize=config.resolved_quantize(),
                     lpips_net=config.resolved_lpips_net())
    protocol = get_protocol(config.protocol)
    device = resolve_device(config.device)
    ctx = FrameContext(data_range=config.data_range, protocol=protocol, device=device,
                       lpips_net=config.lpips_net, lpips_backend=config.lpips_backend,
                       options=config.metric_options, fps=config.fps)
    regions = ("whole",
               *(("focused",) if config.focus.source != "none" else ()),
               *(("masked",) if config.focus.masked else ()),
               *(("covisible",) if masks is not None and protocol.masks == "covisible" else ()))
    built = build_frame_metrics(ctx, run_metrics(protocol, config.metrics), regions)
    warnings = [{"metric": name, "reason": f"{SPECS[name].title} not computed: {why}"}
                for name, why in built.unavailable.items()]
    settings: dict[str, Any] = {
        "data_range": config.data_range, "quantize": config.quantize,
        "background": config.background, "allow_missing": config.allow_missing,
        **built.settings,
        "regions": {**REGION_RULES, **({"covisible": COVISIBLE_RULE} if "covisible" in regions else {})},
        "summary": "mean of per-frame values (frames weighted equally, not pooled error)",
        "protocol": protocol.describe(),
    }
    if masks is not None:  # else masked_* are over the motion masks (settings.focus.motion)
        settings["masks"] = masks.describe()
    sources = open_sources(config.focus)
    settings["focus"] = sources.settings
    warnings.extend(sources.warnings)
    run = Run(config, built.fns, settings, warnings, sources, every=built.every,
              camera_fns=built.camera_fns, masks=masks, protocol=protocol)
    run.presence = _presence_step(config, sources, settings)
    if config.temporal:
        from dynaeval.metrics.flow import FlowConfig
        from dynaeval.metrics.temporal import TemporalConfig

        run.temporal = TemporalConfig(flow=FlowConfig(method=config.flow),
                                      tlp="lpips" in built.fns,  # tLP is LPIPS over time
                                      lpips_net=config.lpips_net, lpips_device=device,
                                      lpips_backend=config.lpips_backend)
        settings["temporal"] = run.temporal.describe()
    return run


def _presence_step(config: ScoreConfig, sources: Any, settings: dict) -> PresenceStep | None:
    """The per-frame presence step, ``(pair, pred, gt, regions) -> (values, reasons, objects)``
    (the ground-truth objects are ``regions.records``), or None when it does not run
    (``settings["presence"]`` says why)."""
    src = config.focus.source
    if not config.presence or src not in ("detector", "boxes"):
        why = ("disabled (presence=False)" if not config.presence else
               f"needs boxes with classes (focus detector or boxes:FILE), focus is {src!r}")
        settings["presence"] = {"enabled": False, "reason": why}
        return None
    from dynaeval.metrics.presence import PRESENCE_METRICS, PresenceConfig, frame_presence
    from dynaeval.regions.boxes_file import frame_key

    pcfg = PresenceConfig(data_range=config.data_range)
    detector = sources.detector  # --focus detector's, or the one that wrote the boxes file
    settings["presence"] = {
        "enabled": True, **pcfg.describe(), "detector_test": detector is not None,
        "objects": "the boxes file's records" if src == "boxes" else "the detector on the ground truth",
        **({"detector_test_skipped": sources.detector_note} if sources.detector_note else {}),
    }

    def step(pair: FramePair, pred: np.ndarray, gt: np.ndarray, regions: FrameRegions):
        records = regions.records
        if records is None:
            why = f"frame {frame_key(pair.camera, pair.frame)!r} is not in the boxes file"
            return dict.fromkeys(PRESENCE_METRICS), dict.fromkeys(PRESENCE_METRICS, why), []
        detections = detector(pred) if detector is not None else None
        fp = frame_presence(pred, gt, records, detections=detections, config=pcfg)
        return fp.values, fp.reasons, fp.objects

    return step


# --------------------------------------------------------------------------------------------
# Frames


def load_gt(pair: FramePair, config: ScoreConfig, cache: FrameCache) -> np.ndarray:
    """The ground truth of ``pair`` as the metrics see it (quantised when asked)."""
    from dynaeval.metrics import quantize

    gt = cache.read(pair.gt, config.background, _decode(config))
    return gt if config.quantize == "none" else quantize(gt, config.quantize)


def _decode(config: ScoreConfig) -> str:
    """The protocol's 16-bit PNG rule (``dynaeval.io.images.DECODES``)."""
    from dynaeval.metrics.protocols import get_protocol

    return get_protocol(config.protocol).decode


def load_pair(pair: FramePair, config: ScoreConfig,
              cache: FrameCache) -> tuple[np.ndarray, np.ndarray]:
    """Prediction and ground truth of ``pair`` as the metrics see them; InputError when their
    sizes or channel counts differ."""
    from dynaeval.metrics import quantize

    pred = cache.read(pair.pred, config.background, _decode(config))
    gt = cache.read(pair.gt, config.background, _decode(config))
    if pred.shape[:2] != gt.shape[:2]:
        raise InputError(
            f"prediction is {pred.shape[1]}x{pred.shape[0]} px but its ground truth {pair.gt} is "
            f"{gt.shape[1]}x{gt.shape[0]} px; render at the ground truth's size",
            path=str(pair.pred),
        )
    if pred.shape[2] != gt.shape[2]:
        raise InputError(
            f"prediction has {pred.shape[2]} channel(s) but its ground truth {pair.gt} has "
            f"{gt.shape[2]}; both must be RGB or both grayscale",
            path=str(pair.pred),
        )
    if config.quantize != "none":
        pred = quantize(pred, config.quantize)
        gt = quantize(gt, config.quantize)
    return pred, gt


def _warning(pair: FramePair, metric: str, reason: str) -> dict:
    return {"camera": pair.camera, "frame": pair.frame, "metric": metric, "reason": reason}


Value = tuple[str, "float | None", "str | None"]


def _metric_values(pair: FramePair, pred: np.ndarray, gt: np.ndarray, regions: FrameRegions,
                   run: Run, elapsed: dict[str, float]) -> list[Value]:
    """``(key, value or None, reason)`` of every per-frame metric of one frame."""
    values: list[Value] = []
    for name, (region, fn) in run.fns.items():
        if pair.index % run.every.get(name, 1):
            continue  # not one of the frames it scores (``every``): no value, not null
        if region == "focused" and regions.boxes is None:
            values.append((name, None, regions.boxes_reason))
            continue
        if region == "masked" and regions.packed_mask is None:
            values.append((name, None, regions.mask_reason))
            continue
        kw = region_argument(region, name, run.protocol, regions)
        if kw is None:
            values.append((name, None, "no covisibility mask for this frame"))
            continue
        t0 = time.perf_counter()
        try:
            values.append((name, float(fn(pred, gt, kw)), None))
        except (EmptyRegionError, UndefinedMetricError) as err:  # e.g. smaller than SSIM's window
            values.append((name, None, str(err)))
        except InputError as err:
            raise InputError(f"{name}: {err}", path=str(pair.pred)) from err
        elapsed[name] = time.perf_counter() - t0
    return values


def score_frame(pair: FramePair, regions: FrameRegions, run: Run,
                cache: FrameCache) -> tuple[dict[str, Any], list[dict]]:
    """The results row of one frame (its metric values; inf kept, None for undefined) and its
    warnings. An InputError that names no file is raised again naming the pair's files."""
    try:
        return _score_frame(pair, regions, run, cache)
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {pair.camera!r} frame {pair.frame!r} (ground truth {pair.gt}): "
                         f"{err}", path=str(pair.pred)) from err


def _score_frame(pair: FramePair, regions: FrameRegions, run: Run,
                 cache: FrameCache) -> tuple[dict[str, Any], list[dict]]:
    from dynaeval.regions.focus import fit_to

    t0 = time.perf_counter()
    pred, gt = load_pair(pair, run.config, cache)
    elapsed = {"read": time.perf_counter() - t0}
    regions = fit_to(regions, gt.shape[:2], run.config.focus)
    if run.masks is not None and run.protocol.masks != "region":
        from dynaeval.regions.given import with_weights

        regions = with_weights(regions, pair.gt.path, run.masks)
    row: dict[str, Any] = {"camera": pair.camera, "frame": pair.frame, "index": pair.index,
                           "pred": str(pair.pred), "gt": str(pair.gt)}
    with values_known_in(1.0):  # read by dynaeval.io.images: in [0, 1], no range pass per metric
        values = _metric_values(pair, pred, gt, regions, run, elapsed)
        if run.presence is not None:
            t0 = time.perf_counter()
            found, reasons, row["objects"] = run.presence(pair, pred, gt, regions)
            values.extend((name, v, reasons.get(name)) for name, v in found.items())
            elapsed["presence"] = time.perf_counter() - t0
    warnings: list[dict] = []
    for name, value, reason in values:
        if value is None:
            warnings.append(_warning(pair, name, reason or "undefined"))
        elif math.isnan(value):  # inputs are checked finite before this point
            raise RuntimeError(f"{name} is NaN for {pair.pred}")
        elif math.isinf(value):
            warnings.append(_warning(pair, name, "prediction equals ground truth in the scored "
                                     f"region: {INFINITE_MARK}, written as null"))
        row[name] = value
    run.add_time(elapsed)
    return row, warnings


# --------------------------------------------------------------------------------------------
# Cameras


@dataclass
class CameraScores:
    """What one camera contributes to the results."""

    rows: list[dict[str, Any]]
    warnings: list[dict]
    temporal: dict[str, dict] | None
    regions: dict[str, Any] | None = None
    """``regions_summary`` of the camera (None with focus none and no motion masks)."""


def camera_regions_of(camera: str, pairs: list[FramePair], run: Run,
                      cache: FrameCache) -> list[FrameRegions]:
    """The regions of every frame of a camera, from its ground truth (timed as ``regions``)."""
    from dynaeval.regions.focus import camera_regions

    t0 = time.perf_counter()
    regions = run.prepared.regions(camera) if run.prepared is not None else None
    try:
        if regions is None:  # not prepared (dynaeval prepare): found here
            first_gt = load_gt(pairs[0], run.config, cache)
            regions = camera_regions(
                camera, [p.frame for p in pairs],
                lambda i: load_gt(pairs[i], run.config, cache),
                first_gt.shape[:2], run.sources, run.pool, paths=[p.gt for p in pairs],
            )
        if run.masks is not None:
            from dynaeval.regions.given import given_masks

            regions = given_masks(regions, [p.gt.path for p in pairs], run.masks)
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {camera!r}: regions of the ground truth: {err}",
                         path=str(pairs[0].gt.path.parent)) from err
    run.add_time({"regions": time.perf_counter() - t0})
    return regions


def _not_video_warning(camera: str, pairs: list[FramePair], err: Any) -> dict:
    """The one warning of a camera whose frames differ in shape, naming the first odd file."""
    return {"camera": camera, "reason": (
        f"{err.reason()}: {pairs[err.index].gt} differs from {pairs[0].gt}; its frames are "
        "scored one by one, its temporal and motion-mask values are null")}


def score_camera(camera: str, pairs: list[FramePair], run: Run, *,
                 on_regions: Callable | None = None,
                 on_frame: Callable[[], None] | None = None,
                 on_pair: Callable[[], None] | None = None) -> CameraScores:
    """Regions, per-frame values and temporal terms of one camera (its frames in order).

    ``on_regions(camera, pairs, regions)`` is called before the frames are scored; ``on_frame()``
    after each frame and ``on_pair()`` after each temporal pair (progress). Cameras may be
    scored at the same time on one ``run`` (its pool is shared; nothing here depends on order).
    """
    cache = FrameCache(run.config.cache_mb * 2**20 // max(1, run.lanes),  # dropped at the end
                       decoded=run.prepared.decoded if run.prepared is not None else None)
    regions = camera_regions_of(camera, pairs, run, cache)
    if on_regions is not None:
        on_regions(camera, pairs, regions)

    def work(item: tuple[FramePair, FrameRegions]) -> tuple[dict[str, Any], list[dict]]:
        out = score_frame(item[0], item[1], run, cache)
        if on_frame is not None:
            on_frame()
        return out

    items = list(zip(pairs, regions, strict=True))
    outputs = list(run.pool.map(work, items)) if run.pool else [work(it) for it in items]
    rows = [row for row, _ in outputs]
    warnings = [w for _, ws in outputs for w in ws]
    differ = regions[0].not_video if regions else None
    temporal = None
    if run.temporal is not None:
        # the camera's pairs run on the pool (flows dominate: 3 per pair); the frames are
        # decoded here meanwhile (and, with cameras at once, the other camera's work goes on)
        t0 = time.perf_counter()
        temporal, differ = _temporal_or_reason(camera, pairs, regions, run, cache, differ,
                                               on_pair)
        run.add_time({"temporal": time.perf_counter() - t0})
    if run.camera_fns:
        t0 = time.perf_counter()
        temporal = {**(temporal or {}), **video_metrics_of(camera, pairs, regions, run, cache,
                                                           differ)}
        run.add_time({name: (time.perf_counter() - t0) / len(run.camera_fns)
                      for name in run.camera_fns})
    if differ is not None:
        warnings.insert(0, _not_video_warning(camera, pairs, differ))
    motion = regions[0].camera_motion if regions else None
    if motion is not None and motion["reason"] is not None:
        warnings.insert(0, {"camera": camera, "reason": motion["reason"]})
    if temporal is not None and differ is None:
        warnings.extend(name_regionless_frames(camera, pairs, regions, temporal))
    return CameraScores(rows, warnings, temporal, _summary_of(regions, run))


def _summary_of(regions: list[FrameRegions], run: Run) -> dict[str, Any] | None:
    """The camera's ``regions_summary`` (None when it has neither boxes nor masks)."""
    from dynaeval.regions.summary import regions_summary

    focus = run.config.focus
    if focus.source == "none" and not focus.masked:
        return None
    return regions_summary(regions, focus.source, run.sources.classes)


def name_regionless_frames(camera: str, pairs: list[FramePair], regions: list[FrameRegions],
                           temporal: dict[str, dict]) -> list[dict]:
    """Name the frames without boxes in the focused temporal terms, in place: a term null for the
    whole camera gets them as its reason; one scored on the other pairs gets ``pair_reason``
    (the reason of its null pairs) and one camera warning. Returns the warnings."""
    missing = [(p.frame, r.boxes_reason) for p, r in zip(pairs, regions, strict=True)
               if r.boxes is None]
    if not missing or len(pairs) < 2:
        return []
    why = "; ".join(dict.fromkeys(r or "no box" for _, r in missing))
    shown = ", ".join(repr(f) for f, _ in missing[:8]) + (" ..." if len(missing) > 8 else "")
    frames = f"{len(missing)} of {len(pairs)} frames have no box ({why}): {shown}"
    out = []
    for key, entry in temporal.items():
        if METRICS[key].variant != "focused":
            continue
        reason = entry.get("reason") or ""
        if entry.get("value") is None:
            if reason.startswith(REGIONLESS_REASONS):  # not another cause (too few frames, ...)
                entry["reason"] = f"{frames}; no pair of consecutive frames has boxes in both"
        elif METRICS[key].kind == "camera":
            out.append({"camera": camera, "metric": key, "reason": (
                f"over the union of the boxes of the frames that have them; {frames}")})
        else:
            entry["pair_reason"] = f"this frame or the previous one has no box ({why})"
            out.append({"camera": camera, "metric": key, "reason": (
                f"scored on the pairs of frames that both have boxes; {frames}")})
    return out


REGIONLESS_REASONS = ("no pair of consecutive frames has a region", "no frame has a region")
"""How ``temporal_metrics`` says a focused term is null because frames had no region."""


def consecutive(pairs: list[FramePair]) -> bool:
    """True when the frames' indices run without a gap (none skipped): a sequence the temporal
    and video metrics can use."""
    return not gap_positions(pairs)


class _Clip:
    """One side of a camera's frames as a sequence read on demand (through the camera's cache)."""

    def __init__(self, pairs: list[FramePair], read: Callable[[FramePair], np.ndarray]) -> None:
        self.pairs, self.read = pairs, read

    def __len__(self) -> int:
        return len(self.pairs)

    def __getitem__(self, i: int) -> np.ndarray:
        return self.read(self.pairs[i])


def camera_fps(pairs: list[FramePair], config: ScoreConfig) -> float:
    """The frame rate a camera is played at: its ground-truth video file's, else ``config.fps``."""
    from dynaeval.io.video import video_fps

    ref = pairs[0].gt
    found = video_fps(ref.path) if ref.index is not None else None
    return found if found else config.fps


def video_metrics_of(camera: str, pairs: list[FramePair], regions: list[FrameRegions], run: Run,
                     cache: FrameCache, differ: Any) -> dict[str, dict]:
    """The video metrics (``jod``, ``focused_jod``) of one camera, ``{key: {"value", "reason",
    "fps"}}``: null with the reason for frames that differ in shape or are not consecutive, and
    for a focused window with no box in any frame."""
    reason = (differ.reason() if differ is not None else
              "frames are not consecutive (some were skipped): a video metric needs the sequence"
              if not consecutive(pairs) else None)
    fps = camera_fps(pairs, run.config)
    if reason is not None:
        return {k: {"value": None, "reason": reason, "fps": fps} for k in run.camera_fns}
    pred = _Clip(pairs, lambda p: load_pair(p, run.config, cache)[0])
    gt = _Clip(pairs, lambda p: load_gt(p, run.config, cache))
    out: dict[str, dict] = {}
    for key, (region, fn) in run.camera_fns.items():
        kw = {"boxes": [r.boxes for r in regions]} if region == "focused" else {}
        try:
            out[key] = {"value": float(fn(pred, gt, fps, kw)), "reason": None, "fps": fps}
        except (EmptyRegionError, UndefinedMetricError) as err:
            out[key] = {"value": None, "reason": str(err), "fps": fps}
        except InputError as err:
            if err.path is not None:
                raise
            raise InputError(f"camera {camera!r}: {key}: {err}",
                             path=str(pairs[0].pred.path.parent)) from err
    return out


def _temporal_or_reason(camera: str, pairs: list[FramePair], regions: list[FrameRegions],
                        run: Run, cache: FrameCache, differ: Any,
                        on_pair: Callable[[], None] | None = None) -> tuple[dict[str, dict], Any]:
    """The camera's temporal terms, or every term null with the reason: frames that differ in
    shape (``differ``: the ``FramesDiffer`` found by the regions, or found here), frames too
    small for optical flow. InputErrors that name no file are raised naming the camera."""
    from dynaeval.regions.focus import FramesDiffer

    def nulls(reason: str) -> dict[str, dict]:
        return {n: {"value": None, "reason": reason} for n in temporal_keys()}

    if differ is not None:
        return nulls(differ.reason()), differ
    shape = load_gt(pairs[0], run.config, cache).shape
    try:
        check_flow_size(shape)
    except UndefinedMetricError as err:
        return nulls(f"temporal terms of camera {camera!r}: {err}"), None
    try:
        return temporal_of_camera(pairs, regions, run, cache, shape, on_pair), None
    except FramesDiffer as err:
        return nulls(err.reason()), err
    except InputError as err:
        if err.path is not None:
            raise
        raise InputError(f"camera {camera!r}: temporal terms: {err}",
                         path=str(pairs[0].pred.path.parent)) from err


def _name_gaps(pairs: list[FramePair], temporal: dict[str, dict]) -> None:
    """Give the per-pair entries the reason of each gap's null value (``pair_reasons``: pair
    position -> reason, read by ``dynaeval.report.results.place_temporal``), in place."""
    gaps = gap_positions(pairs)
    if not gaps:
        return
    reasons = {k: (f"not a pair of consecutive frames: the ground-truth frame(s) between "
                   f"{pairs[k].frame!r} and {pairs[k + 1].frame!r} have no prediction "
                   "(--allow-missing)") for k in gaps}
    for entry in temporal.values():
        if entry.get("per_pair"):
            entry["pair_reasons"] = reasons


def _small_for_tlp(run: Run, h: int, w: int) -> str | None:
    """Why tLP is undefined for frames of (h, w), or None (LPIPS's backbone has a minimum)."""
    from dynaeval.metrics.perceptual import MIN_SIZE

    net = run.temporal.lpips_net
    if "lpips" not in run.fns or not run.temporal.tlp or min(h, w) >= MIN_SIZE.get(net, 0):
        return None
    return (f"tLP needs frames of at least {MIN_SIZE[net]}x{MIN_SIZE[net]} pixels (LPIPS {net}), "
            f"got {w}x{h}")


def static_pixels(regions: list[FrameRegions], config: ScoreConfig) -> np.ndarray | None:
    """The camera's static pixels, ``(H, W)`` bool: never moving in any frame's motion mask
    (None: no masked metrics, or no frame has a mask)."""
    from dynaeval.regions.packed import union

    if not config.focus.masked:
        return None
    moving = union(r.packed_mask for r in regions if r.packed_mask is not None)
    return None if moving is None else ~moving


def temporal_of_camera(pairs: list[FramePair], regions: list[FrameRegions], run: Run,
                       cache: FrameCache, shape: tuple[int, ...],
                       on_pair: Callable[[], None] | None = None) -> dict[str, dict]:
    """The temporal terms of one camera (``dynaeval.metrics.temporal.temporal_metrics`` output),
    its ground truth of ``shape`` (the first frame's); tLP null with the reason when the frames
    are smaller than LPIPS accepts."""
    from dynaeval.metrics.registry import SPECS
    from dynaeval.metrics.temporal import temporal_metrics
    from dynaeval.regions.focus import same_shape

    config = run.config
    static = static_pixels(regions, config)
    region_masks = None  # a frame without boxes: None, the pairs with it have no focused value
    if config.focus.source != "none":
        region_masks = [r.boxes for r in regions]
    small = _small_for_tlp(run, *shape[:2])
    tcfg = run.temporal if "lpips" in run.fns and small is None else replace(run.temporal, tlp=False)
    gt_of = same_shape(lambda i: load_gt(pairs[i], config, cache), shape)
    out = temporal_metrics(
        (load_pair(p, config, cache)[0] for p in pairs),
        (gt_of(i) for i in range(len(pairs))),
        static_mask=static,
        region_masks=region_masks,
        config=tcfg,
        flow_cache=run.prepared.flow_cache() if run.prepared is not None else None,
        executor=run.pool,
        window=max(2, 2 * config.workers // run.lanes),  # pairs in flight, all cameras: 2 x workers
        on_pair=on_pair,
        gt_static_std=None if static is None or run.prepared is None
        else run.prepared.gt_static_std(pairs[0].camera, static),
        frame_indices=[p.index for p in pairs],
    )
    _name_gaps(pairs, out)
    if small is not None:
        out.update({k: {"value": None, "reason": small, "per_pair": []} for k in SPECS["tlp"].keys()})
    return out

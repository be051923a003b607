"""``RunPlan``: a scoring run's settings resolved once, before any frame is read, and never changed.

``build_plan`` turns the user's ``ScoreConfig`` (kept as given, ``RunPlan.config``) and what the
inputs decide (``Scope``: a video per camera or separate views; given masks; a prepared ground
truth) into the built metric functions, the opened region sources, the presence step, the
temporal settings and the ``settings`` that go into the results. The scoring of a camera
(``dynaeval.run.scoring``) reads it; what changes while a run goes (the worker pool, the frame caches,
the timing) is the executor's (``dynaeval.run.executor``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import Status, unavailable_reason, warning
from dynaeval.core.runtime import resolve_device
from dynaeval.io import FramePair
from dynaeval.io.images import FrameCache
from dynaeval.metrics import quantize
from dynaeval.metrics.flow import FlowConfig
from dynaeval.metrics.presence import PRESENCE_METRICS, PresenceConfig, frame_presence
from dynaeval.metrics.protocols import get_protocol
from dynaeval.metrics.registry import (
    COVISIBLE_RULE,
    REGION_RULES,
    SPECS,
    FrameContext,
    FrameFn,
    build_frame_metrics,
)
from dynaeval.metrics.temporal import TemporalConfig
from dynaeval.regions.boxes_file import frame_key
from dynaeval.regions.focus import FocusConfig, FrameRegions, RegionSources, open_sources
from dynaeval.run.config import ScoreConfig

if TYPE_CHECKING:
    from dynaeval.io.masks import MaskSet
    from dynaeval.metrics.protocols import Protocol
    from dynaeval.metrics.temporal import TemporalConfig
    from dynaeval.run.prepared_gt import PreparedGT

PresenceStep = Callable[[FramePair, np.ndarray, np.ndarray, FrameRegions],
                        tuple[dict[str, float | None], dict[str, str], list[dict]]]
"""``(pair, pred, gt, regions) -> (values, reasons, objects)`` of one frame's object presence."""

VideoFn = Callable[..., float]
"""A video metric: ``fn(pred_frames, gt_frames, fps, region) -> float`` (``MetricSpec.build``)."""


@dataclass(frozen=True)
class Scope:
    """What a run scores of its frames: one video per camera, or separate views
    (``dynaeval.run.evaluate.per_frame_only`` decides it from the layout and the config)."""

    temporal: bool
    """The temporal terms run (``config.temporal``, off for separate views)."""
    masked: bool
    """``masked_*`` run (``config.focus.masked``; for separate views only over given masks)."""
    sequence: dict[str, Any] | None = None
    """The results' ``settings["sequence"]`` (``{"video", "reason", "skipped"}``), or None for
    frames that are a video by default."""

    @classmethod
    def of(cls, config: ScoreConfig) -> Scope:
        """The scope ``config`` asks for, the frames taken as a video."""
        return cls(temporal=config.temporal, masked=config.focus.masked)


@dataclass(frozen=True, kw_only=True)
class RunPlan:
    """A run resolved once (frozen: nothing changes it while cameras are scored). Built with
    every field named (``build_plan``, ``ground_truth_plan``): 15 fields, several of the same
    type, are not told apart by their position."""

    config: ScoreConfig
    """The settings as the user gave them (``dynaeval.score``'s ``config`` with its overrides)."""
    protocol: Protocol
    """The run's ``dynaeval.metrics.protocols.Protocol``."""
    quantize: str
    """The 8-bit step applied to both images: ``config.quantize`` resolved to the protocol's."""
    lpips_net: str
    """The LPIPS backbone: ``config.lpips_net``, else the protocol's."""
    focus: FocusConfig
    """The focus scored: ``config.focus``, ``masked`` off for separate views without masks."""
    fns: Mapping[str, tuple[str, FrameFn]]
    """Per-frame metrics: result key -> (region variant, ``fn(pred, gt, region)``), from the
    registry, in report order."""
    every: Mapping[str, int]
    """Result key -> K: that per-frame metric is scored on frames whose index % K == 0 only."""
    camera_fns: Mapping[str, tuple[str, VideoFn]]
    """Video metrics (``jod``): result key -> (region variant, ``fn(pred_frames, gt_frames,
    fps, region)``), one value per camera."""
    sources: RegionSources
    """The opened detector or boxes file (``dynaeval.regions.focus.open_sources``)."""
    masks: MaskSet | None
    """Given masks (``masked_*`` over them, ``dynaeval.io.masks``), or None."""
    presence: PresenceStep | None
    """The per-frame presence step, or None when it does not run (``settings["presence"]``
    says why)."""
    temporal: TemporalConfig | None
    """Settings of the temporal terms, or None when they do not run."""
    prepared: PreparedGT | None
    """The ``--prepared`` ground truth (regions, flows, decodings read from it), or None."""
    settings: Mapping[str, Any]
    """The results' ``settings`` (every setting that changes a number)."""
    warnings: tuple[dict, ...]
    """Run-level warnings of the set-up: metrics unavailable, the region sources', the prepared
    ground truth's cameras computed again."""

    @property
    def decode(self) -> str:
        """The protocol's 16-bit PNG rule (``dynaeval.io.images.DECODES``)."""
        return self.protocol.decode_rule()

    def read_gt(self, pair: FramePair, cache: FrameCache) -> np.ndarray:
        """The ground truth of ``pair`` as the metrics see it, ``(H, W, C)`` float32 in [0, 1]
        (quantised when asked)."""
        gt = cache.read(pair.gt, self.config.background, self.decode)
        return gt if self.quantize == "none" else quantize(gt, self.quantize)

    def read_pair(self, pair: FramePair, cache: FrameCache) -> tuple[np.ndarray, np.ndarray]:
        """Prediction and ground truth of ``pair`` as the metrics see them, both ``(H, W, C)``
        float32 in [0, 1].

        Raises:
            InputError: their sizes or channel counts differ (naming both files).
        """
        pred = cache.read(pair.pred, self.config.background, self.decode)
        gt = cache.read(pair.gt, self.config.background, self.decode)
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
        if self.quantize != "none":
            pred = quantize(pred, self.quantize)
            gt = quantize(gt, self.quantize)
        return pred, gt


def build_plan(config: ScoreConfig, *, scope: Scope | None = None, masks: MaskSet | None = None,
               prepared: Callable[[RegionSources, bool], PreparedGT] | None = None) -> RunPlan:
    """Build the metrics, open the region sources and describe the run (before any frame is read).

    Args:
        config: the checked settings, as given.
        scope: a video per camera or separate views (default ``Scope.of(config)``).
        masks: the given masks (``dynaeval.io.masks.MaskSet``) or None: ``masked_*`` are then
            computed over them instead of the motion masks, and a protocol that uses masks
            (``Protocol.masks``) gets their weights.
        prepared: ``(sources, temporal) -> PreparedGT``: opens the ``--prepared`` ground truth
            and checks it against the run's region sources and whether it has temporal terms
            (``dynaeval.run.prepared_gt.open_prepared``), or None.

    Raises:
        InputError: an unusable detector or boxes file; a prepared ground truth that does not
            match.
    """
    scope = scope or Scope.of(config)
    focus = config.focus if scope.masked == config.focus.masked else replace(
        config.focus, masked=scope.masked)
    quantize, lpips_net = config.resolved_quantize(), config.resolved_lpips_net()
    protocol = get_protocol(config.protocol)
    device = resolve_device(config.device)
    ctx = FrameContext(data_range=config.data_range, protocol=protocol, device=device,
                       lpips_net=lpips_net, lpips_backend=config.lpips_backend,
                       options=config.metric_options, fps=config.fps)
    regions = ("whole",
               *(("focused",) if focus.kind.gives_boxes else ()),
               *(("masked",) if focus.masked else ()),
               *(protocol.mask_regions() if masks is not None else ()))
    built = build_frame_metrics(ctx, protocol.run_metrics(config.metrics), regions)
    warnings = [warning(Status.UNAVAILABLE, metric=name,
                        reason=unavailable_reason(SPECS[name].title, why) + (
                            f" (to leave it out: {SPECS[name].flag}; in the library, leave "
                            f"{name!r} out of metrics)" if SPECS[name].default else ""))
                for name, why in built.unavailable.items()]
    warnings += [warning(Status.PLUGIN_FAILED, metric=name,
                         reason=unavailable_reason(SPECS[name].title, why))
                 for name, why in built.failed.items()]
    settings = _settings(config, quantize, built.settings, regions, protocol, masks)
    sources = open_sources(focus)
    sources.given_masks = masks is not None  # they replace the motion masks (regions.given)
    settings["focus"] = sources.settings
    warnings.extend(sources.warnings)
    presence = _presence_step(config, sources, settings)
    temporal = None
    if scope.temporal:
        temporal = TemporalConfig(flow=FlowConfig(method=config.flow),
                                  tlp="lpips" in built.fns,  # tLP is LPIPS over time
                                  lpips_net=lpips_net, lpips_device=device,
                                  lpips_backend=config.lpips_backend)
        settings["temporal"] = temporal.describe()
    found = prepared(sources, scope.temporal) if prepared is not None else None
    if found is not None:  # checked against the files and settings before the work
        settings["prepared"] = found.describe()
        warnings.extend(found.warnings())
    if scope.sequence is not None:
        settings["sequence"] = scope.sequence
    return RunPlan(config=config, protocol=protocol, quantize=quantize, lpips_net=lpips_net,
                   focus=focus, fns=built.fns, every=built.every, camera_fns=built.camera_fns,
                   sources=sources, masks=masks, presence=presence, temporal=temporal,
                   prepared=found, settings=settings, warnings=tuple(warnings))


def _settings(config: ScoreConfig, quantize: str, metric_settings: dict[str, dict],
              regions: tuple[str, ...], protocol: Protocol, masks: MaskSet | None) -> dict[str, Any]:
    """The results' ``settings`` of the reading, the metrics, the region rules and the protocol
    (``build_plan`` adds the focus, presence, temporal, prepared and sequence sections)."""
    settings: dict[str, Any] = {
        "data_range": config.data_range, "quantize": quantize,
        "background": config.background, "allow_missing": config.allow_missing,
        **metric_settings,
        "regions": {**REGION_RULES, **({"covisible": COVISIBLE_RULE} if "covisible" in regions else {})},
        "summary": "mean of per-frame values (frames weighted equally, not pooled error)",
        # the backbone this run uses (one the protocol accepts), not the protocol's default:
        # under 4dgaussians it said "vgg" when --lpips-net alex was used
        "protocol": {**protocol.describe(), "lpips_net": config.resolved_lpips_net()},
    }
    if masks is not None:  # else masked_* are over the motion masks (settings.focus.motion)
        settings["masks"] = masks.describe()
    return settings


def ground_truth_plan(config: ScoreConfig, sources: RegionSources) -> RunPlan:
    """The plan of ``dynaeval prepare``: the ground truth's regions only (no metric is built)."""
    return RunPlan(config=config, protocol=get_protocol(config.protocol),
                   quantize=config.resolved_quantize(), lpips_net=config.resolved_lpips_net(),
                   focus=config.focus, fns={}, every={}, camera_fns={}, sources=sources,
                   masks=None, presence=None, temporal=None, prepared=None, settings={},
                   warnings=tuple(sources.warnings))


def _presence_step(config: ScoreConfig, sources: Any, settings: dict) -> PresenceStep | None:
    """The per-frame presence step, ``(pair, pred, gt, regions) -> (values, reasons, objects)``
    (the ground-truth objects are ``regions.records``), or None when it does not run
    (``settings["presence"]`` says why)."""
    src = config.focus.source
    if not config.presence or not config.focus.kind.classed:
        why = ("disabled (presence=False)" if not config.presence else
               f"needs boxes with classes (focus detector or boxes:FILE), focus is {src!r}")
        settings["presence"] = {"enabled": False, "reason": why}
        return None

    pcfg = PresenceConfig(data_range=config.data_range)
    detector = sources.detector  # --focus detector's, or the one that wrote the boxes file
    settings["presence"] = {
        "enabled": True, **pcfg.describe(), "detector_test": detector is not None,
        "objects": ("the boxes file's records" if config.focus.kind.reads_file
                    else "the detector on the ground truth"),
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

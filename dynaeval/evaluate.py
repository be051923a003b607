"""The one orchestration: pair frames, compute regions, score every pair, summarise.

``score(pred_dir, gt_dir, config)`` returns a ``Results`` (a dict in the results-JSON layout of
``dynaeval.report.results``) and is what ``dynaeval score`` calls.

Order of work, camera by camera (so memory is bounded by one camera's regions):

1. regions from the ground truth only (``dynaeval.regions.focus``): boxes (detector, boxes file
   or motion) expanded and merged, and motion masks;
2. per frame (``workers`` threads): PSNR, SSIM, LPIPS over the whole frame, ``focused_*`` over
   the boxes, ``masked_*`` over the motion mask;
3. per camera: temporal terms over consecutive frames (``dynaeval.metrics.temporal``).
"""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.errors import EmptyRegionError, InputError, WeightsUnavailableError
from dynaeval.io import FramePair, pair_frames
from dynaeval.io.cache import FrameCache
from dynaeval.io.frames import select_shard
from dynaeval.metrics.perceptual import resolve_device
from dynaeval.regions.focus import FocusConfig, FrameRegions

BASE_METRICS = ("psnr", "ssim", "lpips")


@dataclass
class ScoreConfig:
    """Every setting of a scoring run; those that change a number go into ``settings``."""

    method: str | None = None
    """Name of the method whose predictions are scored (leaderboard row); default: PRED's name."""
    scene: str | None = None
    """Name of the scene (leaderboard column); default: GT's folder name."""
    lpips: bool = True
    """Compute LPIPS (needs torch, torchvision and the lpips package, and the backbone weights)."""
    lpips_net: str = "alex"
    """LPIPS backbone: ``alex`` (default, as most NeRF papers report) or ``vgg``."""
    lpips_backend: str = "torch"
    """Runtime of the LPIPS network: ``torch`` (the lpips package) or ``onnxruntime`` (the same
    network exported, ~1.2x faster on CPU, equal to 1e-6: docs/benchmarks.md)."""
    data_range: float = 1.0
    """Value range of the images after reading (files are mapped to [0, 1] by their dtype)."""
    quantize: str = "none"
    """Quantise both images to 8 bit before scoring: ``none``, ``round`` or ``truncate``
    (``floor(x*255)``), to reproduce evaluators that save renders as 8-bit files."""
    background: str = "white"
    """Colour RGBA frames are composited over: ``white`` (Blender/NeRF-synthetic convention) or
    ``black``."""
    allow_missing: bool = False
    """Score the frames present when a camera misses some predictions (else an error)."""
    focus: FocusConfig = field(default_factory=lambda: FocusConfig(source="none", masked=False))
    """Regions for ``focused_*`` and ``masked_*`` metrics (``FocusConfig.parse`` reads the CLI
    form). The library default scores the whole frame only; the CLI's default is the detector."""
    presence: bool = True
    """Decide per ground-truth object whether the prediction shows it: ``presence_person``,
    ``presence_ball``, ``tight_psnr_*`` and ``objects`` per frame (``dynaeval.metrics.presence``).
    Needs boxes with classes: focus ``detector`` or ``boxes``."""
    temporal: bool = True
    """Compute the temporal terms (warp_error, tof, tlp, flicker) per camera."""
    flow: str = "dis"
    """Optical flow for the temporal terms: ``dis``, ``farneback`` or ``tvl1``."""
    workers: int = 1
    """Frames scored concurrently (threads). Never changes a number."""
    device: str = "cpu"
    """Torch device for LPIPS: ``cpu``, ``cuda`` or ``auto``."""
    progress: bool = True
    """Show a progress bar on stderr."""
    cache_mb: int = 1024
    """Decoded frames kept for reuse (MiB; one camera is scored at a time), so the passes over a
    camera (regions, metrics, temporal) decode each file once where it fits. Never changes a number."""
    shard: tuple[int, int] | None = None
    """Score only slice ``(I, N)`` of the cameras (``dynaeval.io.frames.select_shard``); the
    shards' results combine with ``dynaeval merge`` into exactly the unsharded numbers."""
    protocol: str = "dynaeval"
    """Whose whole-frame PSNR/SSIM and 8-bit step to reproduce: ``dynaeval``, ``nerfbaselines``
    or ``nerfstudio`` (``dynaeval.metrics.protocols``; ``quantize`` then defaults to the
    protocol's)."""


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


def _load_gt(pair: FramePair, config: ScoreConfig, cache: FrameCache) -> np.ndarray:
    """The ground truth of ``pair`` as the metrics see it (quantised when asked)."""
    from dynaeval.metrics import quantize

    gt = cache.read(pair.gt, config.background)
    return gt if config.quantize == "none" else quantize(gt, config.quantize)


def _load_pair(pair: FramePair, config: ScoreConfig,
               cache: FrameCache) -> tuple[np.ndarray, np.ndarray]:
    from dynaeval.metrics import quantize

    pred = cache.read(pair.pred, config.background)
    gt = cache.read(pair.gt, config.background)
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


MetricFn = Callable[[np.ndarray, np.ndarray, dict[str, Any]], float]


def _build_metric_fns(
    config: ScoreConfig, warnings: list[dict]
) -> tuple[dict[str, tuple[str, MetricFn]], dict[str, Any]]:
    """The per-frame metrics to run, ``name -> (region kind, fn(pred, gt, region kwargs))``, and
    the settings that describe them. Region kind is ``""`` (whole frame), ``"boxes"`` or ``"mask"``."""
    from dynaeval import metrics as M
    from dynaeval.metrics import structural
    from dynaeval.metrics.protocols import get_protocol

    dr = config.data_range
    proto = get_protocol(config.protocol)
    base: dict[str, MetricFn] = {  # whole frame (kw empty): the protocol's; regions: dynaeval's
        "psnr": lambda p, g, kw: M.psnr(p, g, data_range=dr, **kw) if kw
        else proto.whole_psnr(p, g, data_range=dr),
        "ssim": lambda p, g, kw: M.ssim(p, g, data_range=dr, **kw) if kw
        else proto.whole_ssim(p, g, data_range=dr),
    }
    lpips_setting: dict[str, Any] = {"enabled": False, "net": config.lpips_net}
    if config.lpips:
        device = resolve_device(config.device)
        try:
            if config.lpips_backend == "onnxruntime":
                M.load_lpips_onnx(config.lpips_net, device=device)
            else:
                M.load_lpips(config.lpips_net, device=device)
        except (WeightsUnavailableError, ImportError) as err:
            hint = " (pip install 'dynaeval[lpips]')" if isinstance(err, ImportError) else ""
            lpips_setting["unavailable"] = f"{err}{hint}"
            warnings.append({"metric": "lpips", "reason": f"LPIPS not computed: {err}{hint}"})
        else:
            backend = config.lpips_backend
            lpips_setting.update(enabled=True, device=device, backend=backend)
            net = config.lpips_net
            base["lpips"] = lambda p, g, kw: M.lpips(p, g, net=net, device=device,
                                                     backend=backend, **kw)
    fns: dict[str, tuple[str, MetricFn]] = {name: ("", fn) for name, fn in base.items()}
    if config.focus.source != "none":
        fns.update({f"focused_{n}": ("boxes", fn) for n, fn in base.items()})
    if config.focus.masked:
        fns.update({f"masked_{n}": ("mask", fn) for n, fn in base.items()})
    settings = {
        "data_range": dr,
        "quantize": config.quantize,
        "background": config.background,
        "allow_missing": config.allow_missing,
        "ssim": {
            "window": "gaussian",
            "win_size": structural.WIN_SIZE,
            "sigma": structural.SIGMA,
            "truncate": structural.TRUNCATE,
            "k1": structural.K1,
            "k2": structural.K2,
            "covariance": "population",
            "border": "valid windows only (the 5-px border is skipped, as scikit-image crops it)",
        },
        "lpips": lpips_setting,
        "regions": {
            "focused": "SSIM/LPIPS: box-area-weighted mean over crops of the merged boxes; "
            "PSNR: over the union of the boxes",
            "masked": "PSNR: over the mask's pixels; SSIM/LPIPS: mean of the full-frame map over them",
        },
        "summary": "mean of per-frame values (frames weighted equally, not pooled error)",
        "protocol": proto.describe(),
    }
    return fns, settings


def _warning(pair: FramePair, metric: str, reason: str) -> dict:
    return {"camera": pair.camera, "frame": pair.frame, "metric": metric, "reason": reason}


PresenceStep = Callable[[FramePair, np.ndarray, np.ndarray, FrameRegions],
                        tuple[dict[str, float | None], dict[str, str], list[dict]]]


def _presence_step(config: ScoreConfig, sources: Any, settings: dict) -> PresenceStep | None:
    """The per-frame presence step, ``(pair, pred, gt, regions) -> (values, reasons, objects)``
    (the ground-truth objects are ``regions.records``), or None
    when it does not run (``settings["presence"]`` says why)."""
    src = config.focus.source
    if not config.presence or src not in ("detector", "boxes"):
        why = ("disabled (presence=False)" if not config.presence else
               f"needs boxes with classes (focus detector or boxes:FILE), focus is {src!r}")
        settings["presence"] = {"enabled": False, "reason": why}
        return None
    from dynaeval.metrics.presence import PRESENCE_METRICS, PresenceConfig, frame_presence
    from dynaeval.regions.boxes_file import frame_key

    pcfg = PresenceConfig(data_range=config.data_range)
    settings["presence"] = {
        "enabled": True, **pcfg.describe(), "detector_test": src == "detector",
        "objects": "the boxes file's records" if src == "boxes" else "the detector on the ground truth",
    }

    def step(pair: FramePair, pred: np.ndarray, gt: np.ndarray, regions: FrameRegions):
        records = regions.records
        if records is None:
            why = f"frame {frame_key(pair.camera, pair.frame)!r} is not in the boxes file"
            return dict.fromkeys(PRESENCE_METRICS), dict.fromkeys(PRESENCE_METRICS, why), []
        detections = sources.detector(pred) if src == "detector" else None
        fp = frame_presence(pred, gt, records, detections=detections, config=pcfg)
        return fp.values, fp.reasons, fp.objects

    return step


def _score_frame(
    pair: FramePair,
    regions: FrameRegions,
    config: ScoreConfig,
    metric_fns: dict[str, tuple[str, MetricFn]],
    timing: dict[str, float],
    lock: threading.Lock,
    presence: PresenceStep | None,
    cache: FrameCache,
) -> tuple[dict[str, Any], list[dict]]:
    t0 = time.perf_counter()
    pred, gt = _load_pair(pair, config, cache)
    elapsed = {"read": time.perf_counter() - t0}
    row: dict[str, Any] = {
        "camera": pair.camera,
        "frame": pair.frame,
        "index": pair.index,
        "pred": str(pair.pred),
        "gt": str(pair.gt),
    }
    warnings: list[dict] = []
    values: list[tuple[str, float | None, str | None]] = []
    for name, (kind, fn) in metric_fns.items():
        value: float | None
        if kind == "boxes" and regions.boxes is None:
            value, reason = None, regions.boxes_reason
        elif kind == "mask" and regions.mask is None:
            value, reason = None, regions.mask_reason
        else:
            kw = {"boxes": regions.boxes} if kind == "boxes" else (
                {"mask": regions.mask} if kind == "mask" else {})
            t0 = time.perf_counter()
            try:
                value, reason = float(fn(pred, gt, kw)), None
            except InputError as err:  # e.g. a frame smaller than the SSIM window
                raise InputError(f"{name}: {err}", path=str(pair.pred)) from err
            except EmptyRegionError as err:
                value, reason = None, str(err)
            elapsed[name] = time.perf_counter() - t0
        values.append((name, value, reason))
    if presence is not None:
        t0 = time.perf_counter()
        found, reasons, row["objects"] = presence(pair, pred, gt, regions)
        values.extend((name, v, reasons.get(name)) for name, v in found.items())
        elapsed["presence"] = time.perf_counter() - t0
    for name, value, reason in values:
        if value is None:
            warnings.append(_warning(pair, name, reason or "undefined"))
        elif math.isnan(value):  # inputs are checked finite before this point
            raise RuntimeError(f"{name} is NaN for {pair.pred}")
        elif math.isinf(value):
            warnings.append(_warning(pair, name, "prediction equals ground truth in the scored "
                                     "region: value is +infinity, written as null"))
        row[name] = value
    with lock:
        for k, v in elapsed.items():
            timing[k] += v
    return row, warnings


def _temporal_for_camera(
    pairs: list[FramePair],
    regions: list[FrameRegions],
    config: ScoreConfig,
    temporal_config: Any,
    lpips_ok: bool,
    cache: FrameCache,
    pool: ThreadPoolExecutor | None = None,
) -> dict[str, dict]:
    from dynaeval.metrics.temporal import temporal_metrics

    indices = [p.index for p in pairs]
    if indices != list(range(indices[0], indices[0] + len(indices))):
        reason = "frames are not consecutive (some were skipped): temporal terms need a sequence"
        from dynaeval.metrics.temporal import TEMPORAL_METRICS

        return {n: {"value": None, "reason": reason}
                for base in TEMPORAL_METRICS for n in (base, f"focused_{base}")}
    static = None
    masks = [r.mask for r in regions if r.mask is not None]
    if config.focus.masked and masks:
        static = ~np.logical_or.reduce(masks)  # static: never moving in any frame
    region_masks = None
    if config.focus.source != "none" and all(r.boxes is not None for r in regions):
        region_masks = [r.boxes for r in regions]
    tcfg = temporal_config if lpips_ok else replace(temporal_config, tlp=False)
    return temporal_metrics(
        (_load_pair(p, config, cache)[0] for p in pairs),
        (_load_gt(p, config, cache) for p in pairs),
        static_mask=static,
        region_masks=region_masks,
        config=tcfg,
        executor=pool,
        window=2 * config.workers,
    )


def _timed_temporal(pairs, regions, config, temporal_config, lpips_ok, timing, lock, cache, pool) -> dict[str, dict]:  # noqa: ANN001
    """``_temporal_for_camera`` adding its wall time to ``timing["temporal"]`` (thread-safe)."""
    t0 = time.perf_counter()
    out = _temporal_for_camera(pairs, regions, config, temporal_config, lpips_ok, cache, pool)
    with lock:
        timing["temporal"] += time.perf_counter() - t0
    return out


RegionsCallback = Callable[[str, list[FramePair], list[FrameRegions]], None]


def score(
    pred_dir: str | Path,
    gt_dir: str | Path,
    config: ScoreConfig | None = None,
    *,
    on_regions: RegionsCallback | None = None,
    **overrides,
) -> Results:
    """Score a folder of predicted frames against a folder of ground-truth frames.

    Args:
        pred_dir: predictions: images (flat, or one sub-folder per camera) or videos.
        gt_dir: ground truth in the same layout; frames are paired by relative path with the
            extension ignored (``dynaeval.io.frames`` gives the rules).
        config: settings; keyword ``overrides`` replace its fields (``score(p, g, workers=2)``).
        on_regions: called once per camera, before its frames are scored, with the camera name,
            its pairs and their regions (``FrameRegions``, same order): how a report keeps the
            boxes and masks it draws without ``score`` holding every camera's masks.

    Returns:
        Results: per-frame values, per-camera and overall means, settings and timing (the layout
        of the results JSON, see docs/results-format.md).

    Raises:
        InputError: bad input (missing frames, size mismatch, unreadable file, NaN pixels, ...).
    """
    from tqdm.auto import tqdm

    from dynaeval import __version__
    from dynaeval.metrics.presence import PRESENCE_METRICS
    from dynaeval.metrics.protocols import check_lpips_net, get_protocol, resolve_quantize
    from dynaeval.regions.focus import camera_regions, open_sources
    from dynaeval.report.results import build_results

    config = replace(config or ScoreConfig(), **overrides)
    protocol = get_protocol(config.protocol)
    check_lpips_net(protocol, config.lpips_net)
    config = replace(config, quantize=resolve_quantize(protocol, config.quantize))
    if config.quantize not in ("none", "round", "truncate"):
        raise InputError(f"quantize must be none, round or truncate, got {config.quantize!r}")
    if config.lpips_backend not in ("torch", "onnxruntime"):
        raise InputError(f"lpips_backend must be torch or onnxruntime, got {config.lpips_backend!r}")
    if config.workers < 1:
        raise InputError(f"workers must be >= 1, got {config.workers}")
    if config.cache_mb < 0:
        raise InputError(f"cache_mb must be >= 0 (0: no frame cache), got {config.cache_mb}")
    t_start = time.perf_counter()
    pairing = pair_frames(pred_dir, gt_dir, allow_missing=config.allow_missing)
    if config.shard is not None:
        pairing = select_shard(pairing, *config.shard)
    warnings: list[dict] = []
    metric_fns, settings = _build_metric_fns(config, warnings)
    sources = open_sources(config.focus)
    settings["focus"] = sources.settings
    presence = _presence_step(config, sources, settings)
    temporal_config = None
    if config.temporal:
        from dynaeval.metrics.flow import FlowConfig
        from dynaeval.metrics.temporal import TemporalConfig

        temporal_config = TemporalConfig(flow=FlowConfig(method=config.flow),
                                         lpips_net=config.lpips_net,
                                         lpips_device=resolve_device(config.device),
                                         lpips_backend=config.lpips_backend)
        settings["temporal"] = temporal_config.describe()
    timing: dict[str, float] = defaultdict(float)
    lock = threading.Lock()
    by_camera: dict[str, list[FramePair]] = {}
    for pair in pairing.pairs:
        by_camera.setdefault(pair.camera, []).append(pair)

    bar = tqdm(total=len(pairing.pairs), desc="scoring", unit="frame",
               disable=not config.progress, leave=False)
    rows: list[dict] = []
    temporal: dict[str, dict[str, dict]] = {}
    pool = ThreadPoolExecutor(max_workers=config.workers) if config.workers > 1 else None
    try:
        for cam, pairs in by_camera.items():
            t0 = time.perf_counter()
            # one cache per camera, dropped after the camera's temporal pass
            cache = FrameCache(config.cache_mb * 2**20)
            first_gt = _load_gt(pairs[0], config, cache)
            regions = camera_regions(
                cam, [p.frame for p in pairs],
                lambda i, ps=pairs, c=cache: _load_gt(ps[i], config, c),
                first_gt.shape[:2], sources, pool,
            )
            timing["regions"] += time.perf_counter() - t0
            if on_regions is not None:
                on_regions(cam, pairs, regions)

            def work(item: tuple[FramePair, FrameRegions], cache: FrameCache = cache):
                out = _score_frame(item[0], item[1], config, metric_fns, timing, lock, presence,
                                   cache)
                bar.update(1)
                return out

            items = list(zip(pairs, regions, strict=True))
            outputs = list(pool.map(work, items)) if pool else [work(it) for it in items]
            for row, w in outputs:
                rows.append(row)
                warnings.extend(w)
            if temporal_config is not None:
                # the camera's pairs run on the pool (flows dominate: 3 per pair); the frames
                # are decoded here meanwhile, and the next camera starts when they are done
                temporal[cam] = _timed_temporal(pairs, regions, config, temporal_config,
                                                "lpips" in metric_fns, timing, lock, cache, pool)
    finally:
        bar.close()
        if pool:
            pool.shutdown()
        from dynaeval.io.video import close_videos

        close_videos()
    return Results(
        build_results(
            rows=rows,
            metric_names=[*metric_fns, *(PRESENCE_METRICS if presence else ())],
            method=config.method or Path(pred_dir).resolve().name,
            scene=config.scene or Path(gt_dir).resolve().name,
            pred_dir=str(pred_dir),
            gt_dir=str(gt_dir),
            settings=settings,
            unscored_cameras=pairing.unscored_cameras,
            shard=config.shard,
            skipped=pairing.skipped,
            warnings=warnings,
            timing={"total_s": time.perf_counter() - t_start, **dict(timing)},
            version=__version__,
            temporal=temporal,
        )
    )


"""Temporal consistency metrics over consecutive frames of one camera: warping error, tOF, tLP, flicker.

All four compare the prediction's temporal behaviour with the ground truth's, so that what the
ground truth itself does (motion, sensor noise, flow-estimation error) cancels: the ground truth
scored against itself gives exactly 0 for every metric, every value is >= 0, lower is better.
Exact definitions, with the direction of every flow, are in docs/temporal-metrics.md; in short,
for a pair of frames ``(t-1, t)``:

* ``warp_error`` (the reported number): ``|E(pred) - E(gt)|`` with ``E(x)`` the warping error of
  one sequence, :func:`~dynaeval.metrics.temporal_pairs.warping_error`:
  ``E(x) = mean_{p in V, c} (x_t(p) - x_{t-1}(p + b(p)))^2``, ``b`` the ground-truth flow
  ``t -> t-1`` (backward warping of ``t-1`` onto ``t``'s grid) and ``V`` the pixels of ``t``
  visible in ``t-1`` (forward-backward check, in frame). Lai et al. 2018.
* ``tof``: ``mean_p |F(pred_{t-1}, pred_t)(p) - F(gt_{t-1}, gt_t)(p)|_2`` in pixels (TecoGAN).
* ``tlp``: ``|LPIPS(pred_{t-1}, pred_t) - LPIPS(gt_{t-1}, gt_t)|`` (TecoGAN).
* ``flicker`` (static cameras, whole sequence): ``|S(pred) - S(gt)|``,
  ``S(x) = mean_{p static, c} std_t x(p, c)``.

The absolute value is taken per pair (like tLP), not after averaging, and the signed means are
kept in the sequence results (``"signed"``): a signed warping-error difference goes negative when
the prediction *loses* content the flow cannot follow (a ball that vanishes, see the study).

This module is the streaming engine (:func:`temporal_metrics`, its :class:`TemporalConfig` and the
assembly of its results); the pure per-pair functions live in ``dynaeval.metrics.temporal_pairs``
and the flicker in ``dynaeval.metrics.static_flicker`` (both re-exported here). Result keys come
from the registry (``dynaeval.metrics.registry``).

Frames are ``(H, W, 3)`` RGB, float32 in ``[0, 1]`` (uint8 is divided by 255). The sequence API
:func:`temporal_metrics` streams over pairs and keeps two frames and their flows in memory.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from functools import partial
from itertools import repeat

import numpy as np

from dynaeval.core.boxes import as_boxes, boxes_to_mask
from dynaeval.core.errors import InputError
from dynaeval.core.outcome import CameraTerm, Outcome, Status
from dynaeval.metrics.flow import FlowCache, FlowConfig
from dynaeval.metrics.pair_kernels import frame_prep
from dynaeval.metrics.registry import METRICS, SPECS, keys_of, temporal_keys
from dynaeval.metrics.static_flicker import SequenceFlicker, TemporalStd, check_static, flicker
from dynaeval.metrics.temporal_pairs import (
    WARP_ERROR_KEYS,
    FeatureMemo,
    Frames,
    GroundTruthPair,
    LpipsFn,
    default_lpips,
    pair_terms,
    paired_frames,
    tlp,
    tof,
    warping_error,
)

__all__ = [
    "TEMPORAL_METRICS",
    "LpipsFn",
    "TemporalConfig",
    "TemporalRun",
    "TemporalStd",
    "default_lpips",
    "flicker",
    "temporal_metrics",
    "tlp",
    "tof",
    "warping_error",
]

TEMPORAL_METRICS = tuple(SPECS[k].name for k in temporal_keys(region="whole"))
"""Base names of the temporal metrics, from the registry: ``warp_error, tof, tlp, flicker``
(each also reported ``focused_``; result keys: ``temporal_keys()``). Lower is better."""


@dataclass(frozen=True)
class TemporalConfig:
    """Settings of the temporal metrics (every one of them goes into the results JSON)."""

    flow: FlowConfig = field(default_factory=FlowConfig)
    """Optical-flow estimator for the warping error (ground-truth flows) and tOF (both)."""

    tlp: bool = True
    """Compute tLP (needs LPIPS: torch + weights). False records ``tlp`` as null."""

    lpips_net: str = "alex"
    """Backbone of the default LPIPS (``dynaeval.metrics.lpips``): ``"alex"`` or ``"vgg"``.
    Ignored when a ``lpips_fn`` is passed to :func:`temporal_metrics`."""

    lpips_device: str | None = None
    """Torch device of the default LPIPS (``cpu``, ``cuda``; None: cpu). Never changes a number
    beyond the device's rounding (1e-4 tested by the LPIPS tests)."""

    lpips_backend: str = "torch"
    """Runtime of the default LPIPS: ``torch`` or ``onnxruntime`` (the same network)."""

    tlp_min_crop: int = 32
    """focused_tlp: the tight box of the region is grown to at least this many pixels per side
    (centred, kept inside the frame) so that LPIPS's five pooling stages have something left."""

    def describe(self) -> dict:
        """The settings for the results JSON."""
        return {
            "flow": self.flow.describe(),
            "warp_error": "per pair |E(pred) - E(gt)|, E = mean squared error over channels and "
            "visible pixels on the [0, 1] scale; occlusion: Sundaram et al. 2010 "
            "forward-backward check; mean over pairs",
            "tof": "mean endpoint difference of the (t-1 -> t) flows, pixels",
            "tlp": self.tlp,
            "lpips_net": self.lpips_net,
            "tlp_min_crop": self.tlp_min_crop,
            "flicker": "|S(pred) - S(gt)|, S = mean temporal std (ddof=0) over static pixels "
            "and channels",
        }


@dataclass(frozen=True)
class TemporalRun:
    """How ``temporal_metrics`` goes about one camera: none of it changes a number (the
    numbers are those of the default, sequential run on the frames alone), so it is apart from
    ``TemporalConfig``, whose every field does."""

    executor: Executor | None = None
    """A ``concurrent.futures`` executor (threads) to compute the pairs on, or None: in the
    caller's thread. ``lpips_fn`` must then be thread-safe (``default_lpips`` is)."""
    window: int = 4
    """Pairs in flight on ``executor`` (each holds its four frames)."""
    on_pair: Callable[[], None] | None = None
    """Called as each pair's terms are folded, in order (progress)."""
    flow_cache: FlowCache | None = None
    """Flows kept for reuse: share one across the methods scored on one ground truth so its
    flows are computed once (None: a private 64 MiB cache)."""
    gt_flicker: tuple[float | None, float | None] | None = None
    """``S(gt)`` of these very frames on the static pixels and on the static pixels inside the
    union of the regions (``static_flicker.static_mean`` of the ground truth's temporal std;
    None where no pixel is kept), computed beforehand (``dynaeval prepare``); flicker then
    accumulates the prediction only."""
    gt_pairs: Callable[[int], GroundTruthPair] | None = None
    """``gt_pairs(k)``: the ground-truth half of pair ``k`` (frames ``k, k + 1``), a
    ``GroundTruthPair`` computed beforehand for these very frames and region masks (``dynaeval
    prepare``: flows, visibility mask, ``E(gt)``); the ground truth's gray images and flows are
    then not made here. None: computed from the frames."""


# --------------------------------------------------------------------------------------------
# The streaming engine

_NO_REGIONS = "no region masks given (focus: none)"


def region_item_mask(item, shape: tuple[int, int], i: int) -> np.ndarray:
    """Frame ``i``'s region item (an ``(H, W) = shape`` bool mask or ``(N, 4)`` boxes) as a
    bool mask; InputError for a mask of another shape."""
    arr = np.asarray(item)
    if arr.dtype == bool:
        if arr.shape != shape:
            raise InputError(f"region mask of frame {i} must have shape {shape}, got {arr.shape}")
        return arr
    return boxes_to_mask(as_boxes(arr), *shape)


def _time_steps(
    pred_frames: Iterable[np.ndarray],
    gt_frames: Iterable[np.ndarray],
    region_masks: Iterable[np.ndarray] | None,
    gt_gray: bool = True,
) -> Iterator[Frames]:
    """The checked frames of each time step with its region as a bool mask (None: no regions);
    ``gt_gray`` False: the ground truth's gray image is not made (its flows are prepared)."""
    regions = iter(region_masks) if region_masks is not None else repeat(None)
    shape = None
    for i, (p, g) in enumerate(paired_frames(pred_frames, gt_frames)):
        if shape is not None and p.shape != shape:
            raise InputError(f"frame {i} has shape {p.shape}, frame {i - 1} had {shape}")
        shape = p.shape
        try:
            item = next(regions)
        except StopIteration:
            raise InputError(
                f"region_masks has fewer items than the {i + 1} frames seen so far"
            ) from None
        region = None if item is None else region_item_mask(item, p.shape[:2], i)
        yield Frames(p, g, region, frame_prep(p, g, gt_gray=gt_gray))


def _lpips_for_run(
    config: TemporalConfig, lpips_fn: LpipsFn | None
) -> tuple[LpipsFn | None, Outcome | None]:
    """The LPIPS of the run and, when tLP cannot run, why (its null ``Outcome``)."""
    if not config.tlp:
        return lpips_fn, Outcome(None, Status.DISABLED,
                                 "tLP disabled in the configuration (no LPIPS)")
    if lpips_fn is not None:
        return lpips_fn, None
    try:
        return default_lpips(config.lpips_net, config.lpips_device, config.lpips_backend), None
    except (ImportError, AttributeError) as exc:  # no LPIPS in this install: recorded
        return None, Outcome(None, Status.UNAVAILABLE,
                             f"LPIPS unavailable: {type(exc).__name__}: {exc}")


class _PairFold:
    """The pairs of a sequence: computed in order (on an executor, up to ``window`` in flight) and
    folded in frame order into per-pair lists, so the numbers are the sequential run's."""

    def __init__(self, executor: Executor | None, window: int, memo: FeatureMemo | None,
                 lpips_off: Outcome | None, on_pair: Callable[[], None] | None = None) -> None:
        self.executor, self.window, self.memo, self.on_pair = executor, window, memo, on_pair
        self.lpips_off = lpips_off  # why tLP is null (None: it runs)
        self.per_pair: dict[str, list] = {k: [] for k in keys_of("pair")}
        self.parts = {k: {"pred": [], "gt": [], "signed": []} for k in WARP_ERROR_KEYS}
        self._pending: deque = deque()  # pair terms in frame order: futures (executor) or dicts
        self._folded = 0

    def submit(self, fn: Callable[..., dict], *args) -> None:
        if self.executor is None:
            self._pending.append(fn(*args))
            self.drain(0)
        else:
            self._pending.append(self.executor.submit(fn, *args))
            self.drain(max(1, self.window))

    def drain(self, keep: int) -> None:
        """Fold the oldest pairs until at most ``keep`` are in flight."""
        while len(self._pending) > keep:
            item = self._pending.popleft()
            self._fold(item.result() if self.executor is not None else item)

    def _fold(self, terms: dict) -> None:
        if self.memo is not None:
            self.memo.drop(self._folded)  # pair k = frames (k, k+1): later pairs never need frame k
        self._folded += 1
        for key, value in terms["per_pair"].items():
            self.per_pair[key].append(value)
        for key, got in terms["parts"].items():
            for part, value in got.items():
                self.parts[key][part].append(value)
        if terms["lpips_error"] is not None and self.lpips_off is None:
            self.lpips_off = Outcome(None, Status.UNAVAILABLE, terms["lpips_error"])
        if self.on_pair is not None:
            self.on_pair()


class _CameraTerms:
    """The per-camera terms of a sequence (``flicker``): the temporal std of its static pixels,
    and the union of every frame's region for ``focused_flicker``."""

    def __init__(self, static_mask: np.ndarray | None,
                 gt_flicker: tuple[float | None, float | None] | None) -> None:
        self.static_mask = static_mask
        self.gt_flicker = gt_flicker
        self.flicker: SequenceFlicker | None = None  # None: no static mask (or no frame yet)
        self.region_union: np.ndarray | None = None

    def update(self, cur: Frames) -> None:
        if cur.region is not None:
            union = self.region_union
            self.region_union = cur.region.copy() if union is None else union | cur.region
        if self.static_mask is not None:
            if self.flicker is None:
                self.flicker = SequenceFlicker(check_static(self.static_mask, cur.pred.shape[:2]),
                                               self.gt_flicker)
            self.flicker.update(cur.pred, cur.gt)

    def entry(self, focused: bool, n_frames: int, has_regions: bool) -> CameraTerm:
        """The entry of ``flicker`` or (``focused``) ``focused_flicker`` (over the union of the
        regions of the frames that have one)."""
        if n_frames < 2:
            return _null(Status.UNDEFINED, f"needs at least 2 frames, got {n_frames}")
        if self.flicker is None:
            return _null(Status.UNDEFINED,  # no static region known (not a missing box)
                         "no static mask given (moving camera, or motion masks unavailable)")
        if focused and not has_regions:
            return _null(Status.DISABLED, _NO_REGIONS)
        if focused and self.region_union is None:
            return _null(Status.NO_REGION, "no frame has a region")
        region = self.region_union if focused else None
        terms = self.flicker.terms(region, focused)
        if terms is None:
            return _null(Status.EMPTY_REGION, "no static pixel: the static mask is empty"
                         if region is None else "no static pixel inside the regions")
        return CameraTerm(Outcome(terms["value"], Status.OK), parts=_parts(terms))


def temporal_metrics(
    pred_frames: Iterable[np.ndarray],
    gt_frames: Iterable[np.ndarray],
    *,
    static_mask: np.ndarray | None = None,
    region_masks: Iterable[np.ndarray] | None = None,
    config: TemporalConfig | None = None,
    lpips_fn: LpipsFn | None = None,
    frame_indices: Sequence[int] | None = None,
    run: TemporalRun | None = None,
) -> dict[str, CameraTerm]:
    """All temporal metrics of one camera's sequence, streaming over consecutive pairs.

    ``pred_frames``, ``gt_frames``: iterables of T paired frames ``(H, W, 3)``, float32 in
    ``[0, 1]`` or uint8; only two of each are held at a time. ``static_mask``: ``(H, W)`` bool,
    True = static pixel (static camera only; None: flicker is null). ``region_masks``: one item per
    frame, an ``(H, W)`` bool mask or ``(N, 4)`` boxes (``boxes_to_mask``), or None for a frame
    without a region (the focused values of the pairs that include it are None, the other pairs
    are scored); None: focused metrics are null. ``lpips_fn``: ``(a, b) -> float`` (default :func:`default_lpips`; if LPIPS cannot be
    loaded ``tlp`` is null with the reason). An ``lpips_fn`` with ``features`` / ``distance``
    (``LpipsFeatures``, the torch default) gets each frame's whole-frame features computed once
    for tLP and kept while a pair in flight needs them (86 MB per frame and side at 1080p with
    AlexNet).
    ``frame_indices``: each frame's position in its sequence (increasing integers, one per
    frame; None: ``0, 1, 2, ...``). Two neighbours whose positions are not consecutive (frames
    left out between them, ``--allow-missing``) are no pair: their per-pair values are None and
    no flow is computed for them; flicker uses every frame given (a std over time needs no
    neighbours).
    ``run``: how the camera is gone about (``TemporalRun``: worker threads, pairs in flight,
    progress, a shared flow cache, the ground truth's terms computed beforehand); the numbers do
    not depend on it. Default: sequential, from the frames alone.

    Returns ``{key: CameraTerm}`` (``dynaeval.core.outcome``) for the keys
    ``temporal_keys()``: ``warp_error, tof, tlp, flicker`` and their ``focused_`` variants.
    ``term.outcome.value`` is the mean of the defined per-pair values ``term.per_pair`` (pair i =
    frames ``(i, i+1)``, None where undefined); None exactly when the outcome's ``status`` and
    ``detail`` say why (fewer than 2 frames, no static pixels, empty regions, LPIPS missing).
    ``warp_error`` (per pair ``|E(pred) - E(gt)|``, ``E`` = :func:`warping_error`) and
    ``flicker`` terms (and their focused variants) also carry ``term.parts``: ``"pred"`` and
    ``"gt"`` (the two terms, means over pairs) and ``"signed"`` (the mean of ``pred - gt``
    without the absolute value; > 0: the prediction is less stable than the ground truth).
    Flicker has no per-pair values (``per_pair == ()``).
    Convention: undefined -> null with a reason, never an exception; bad input (shapes, NaN)
    raises InputError.
    """
    config = config or TemporalConfig()
    run = run or TemporalRun()
    gt_pairs = run.gt_pairs
    cache = run.flow_cache if run.flow_cache is not None else FlowCache(max_bytes=1 << 26)
    lpips_fn, lpips_off = _lpips_for_run(config, lpips_fn)
    memo = FeatureMemo(lpips_fn) if hasattr(lpips_fn, "features") else None
    pairs = _PairFold(run.executor, run.window, memo, lpips_off, run.on_pair)
    camera = _CameraTerms(static_mask, run.gt_flicker)
    prev: Frames | None = None
    n_frames = 0
    regionless: list[int] = []  # frames whose region item was None
    positions = _Positions(frame_indices)
    steps = _time_steps(pred_frames, gt_frames, region_masks, gt_gray=gt_pairs is None)
    for i, cur in enumerate(steps):
        n_frames = i + 1
        if cur.region is None:
            regionless.append(i)
        camera.update(cur)
        if prev is not None and positions.next_follows(i):
            pairs.submit(pair_terms, prev, cur, cache, config.flow,
                         lpips_fn if pairs.lpips_off is None else None,
                         config.tlp_min_crop, memo, i,
                         None if gt_pairs is None else partial(gt_pairs, i - 1))
        elif prev is not None:  # a gap: no pair, its slot stays None
            pairs.submit(_no_pair_terms)
        prev = cur
    pairs.drain(0)
    return _results(pairs, camera, n_frames, region_masks is not None,
                    regionless if region_masks is not None else [], positions.gaps)


class _Positions:
    """Walks ``frame_indices`` alongside the frames: ``next_follows(i)`` is True when frame ``i``
    comes right after frame ``i - 1`` in its sequence; ``gaps`` counts the neighbours that do not.
    """

    def __init__(self, frame_indices: Sequence[int] | None) -> None:
        self.indices = None if frame_indices is None else [int(t) for t in frame_indices]
        self.gaps = 0

    def next_follows(self, i: int) -> bool:
        if self.indices is None:
            return True
        if i >= len(self.indices):
            raise InputError(f"frame_indices has {len(self.indices)} items, fewer than the frames "
                             f"(at least {i + 1}): give one position per frame")
        prev, cur = self.indices[i - 1], self.indices[i]
        if cur <= prev:
            raise InputError(f"frame_indices must increase: frame {i} is at {cur}, frame {i - 1} "
                             f"at {prev}")
        self.gaps += cur != prev + 1
        return cur == prev + 1


def _no_pair_terms() -> dict:
    """The terms of two neighbours that are not consecutive frames: every value None."""
    return {"per_pair": dict.fromkeys(keys_of("pair")),
            "parts": {k: {"pred": None, "gt": None, "signed": None} for k in WARP_ERROR_KEYS},
            "lpips_error": None}


# --------------------------------------------------------------------------------------------
# Assembly of the results


def _mean_or_reason(values: list, empty_reason: str) -> tuple[float | None, str | None]:
    got = [v for v in values if v is not None]
    if not got:
        return None, empty_reason
    return float(np.mean(got)), None


def _pair_entry(key: str, pairs: _PairFold, n_frames: int, has_regions: bool,
                regionless: list[int], gaps: int = 0) -> CameraTerm:
    """The entry of a per-pair metric (warp_error, tof, tlp and their focused variants);
    ``regionless``: the frames given no region (their pairs' focused values are None);
    ``gaps``: neighbours that are not consecutive frames (no pair)."""
    info = METRICS[key]
    focused = info.variant == "focused"
    if n_frames < 2:
        return _null(Status.UNDEFINED, f"needs at least 2 frames, got {n_frames}")
    if gaps == n_frames - 1:
        return _null(Status.NOT_CONSECUTIVE, (  # one camera-level null
            f"no two of the {n_frames} frames are consecutive (frames are missing between every "
            "pair of neighbours): no pair to score"))
    if focused and not has_regions:
        return _null(Status.DISABLED, _NO_REGIONS, pairs.per_pair[key])
    if info.metric == "tlp" and pairs.lpips_off is not None:
        return _null(pairs.lpips_off.status, pairs.lpips_off.detail)
    empty, status = (
        ("no pixel of any frame was visible in its previous frame (all occluded)",
         Status.EMPTY_REGION) if not focused
        else ("every pair's region was empty", Status.EMPTY_REGION) if not regionless
        else (f"no pair of consecutive frames has a region in both (frames without one: "
              f"{', '.join(map(str, regionless))})", Status.NO_REGION)
    )
    value, reason = _mean_or_reason(pairs.per_pair[key], empty)
    parts = ({} if key not in pairs.parts else
             _parts({k: _mean_or_reason(v, empty)[0] for k, v in pairs.parts[key].items()}))
    return CameraTerm(Outcome(value, Status.OK if reason is None else status, reason),
                      tuple(pairs.per_pair[key]), parts=parts)


def _parts(means: dict[str, float | None]) -> dict[str, float | None]:
    """A term's ``CameraTerm.parts`` from the means of its sides (``signed``, ``pred``, ``gt``;
    other keys of ``means`` left out), in that order."""
    return {k: means[k] for k in ("signed", "pred", "gt")}


def _null(status: Status, reason: str, per_pair: list | None = None) -> CameraTerm:
    """A term null for the whole camera (``per_pair``: its per-pair values, all None, when it
    has them)."""
    return CameraTerm(Outcome(None, status, reason), tuple(per_pair or ()))


def _results(
    pairs: _PairFold, camera: _CameraTerms, n_frames: int, has_regions: bool,
    regionless: list[int], gaps: int = 0,
) -> dict[str, CameraTerm]:
    """Every temporal result key -> its term, in the registry's report order."""
    out: dict[str, CameraTerm] = {}
    for key in temporal_keys():
        info = METRICS[key]
        if info.kind == "camera":
            out[key] = camera.entry(info.variant == "focused", n_frames, has_regions)
        else:
            out[key] = _pair_entry(key, pairs, n_frames, has_regions, regionless, gaps)
    return out

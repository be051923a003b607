"""Temporal consistency metrics over consecutive frames of one camera: warping error, tOF, tLP, flicker.

All four compare the prediction's temporal behaviour with the ground truth's, so that what the
ground truth itself does (motion, sensor noise, flow-estimation error) cancels: the ground truth
scored against itself gives exactly 0 for every metric, every value is >= 0, lower is better.
Exact definitions, with the direction of every flow, are in docs/temporal-metrics.md; in short,
for a pair of frames ``(t-1, t)``:

* ``warp_error``: ``|E(pred) - E(gt)|`` with ``E(x) = mean_{p in V, c} (x_t(p) - x_{t-1}(p + b(p)))^2``,
  ``b`` the ground-truth flow ``t -> t-1`` (backward warping of ``t-1`` onto ``t``'s grid) and
  ``V`` the pixels of ``t`` visible in ``t-1`` (forward-backward check, in frame). Lai et al. 2018.
* ``tof``: ``mean_p |F(pred_{t-1}, pred_t)(p) - F(gt_{t-1}, gt_t)(p)|_2`` in pixels (TecoGAN).
* ``tlp``: ``|LPIPS(pred_{t-1}, pred_t) - LPIPS(gt_{t-1}, gt_t)|`` (TecoGAN).
* ``flicker`` (static cameras, whole sequence): ``|S(pred) - S(gt)|``,
  ``S(x) = mean_{p static, c} std_t x(p, c)``.

The absolute value is taken per pair (like tLP), not after averaging, and the signed means are
kept in the sequence results (``"signed"``): a signed warping-error difference goes negative when
the prediction *loses* content the flow cannot follow (a ball that vanishes, see the study).

Frames are ``(H, W, 3)`` RGB, float32 in ``[0, 1]`` (uint8 is divided by 255). The sequence API
:func:`temporal_metrics` streams over pairs and keeps two frames and their flows in memory.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future
from dataclasses import dataclass, field
from itertools import repeat
from typing import Any

import numpy as np

from dynaeval.errors import EmptyRegionError, InputError, WeightsUnavailableError
from dynaeval.metrics.flow import (
    FlowCache,
    FlowConfig,
    check_flow,
    check_image,
    valid_warp_mask,
    warp,
)
from dynaeval.regions.boxes import as_boxes, boxes_to_mask, clip_boxes, mask_to_box

TEMPORAL_METRICS = ("warp_error", "tof", "tlp", "flicker")
"""Names in the results; each also exists prefixed ``focused_``. Lower is better for all."""

LpipsFn = Callable[[np.ndarray, np.ndarray], float]


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


# --------------------------------------------------------------------------------------------
# Pure per-pair functions


def _region(
    region: np.ndarray | None, shape: tuple[int, int], name: str = "region"
) -> np.ndarray | None:
    if region is None:
        return None
    r = np.asarray(region)
    if r.dtype != bool or r.shape != shape:
        raise InputError(f"{name} must be a bool mask of shape {shape}, got {r.dtype} {r.shape}")
    return r


def _pair(a: np.ndarray, b: np.ndarray, names: tuple[str, str]) -> tuple[np.ndarray, np.ndarray]:
    a, b = check_image(a, names[0]), check_image(b, names[1])
    if a.shape != b.shape:
        raise InputError(
            f"{names[0]} and {names[1]} must have one shape, got {a.shape} and {b.shape}"
        )
    return a, b


def warp_error(
    prev: np.ndarray,
    cur: np.ndarray,
    flow_back: np.ndarray,
    valid: np.ndarray | None = None,
    region: np.ndarray | None = None,
) -> float:
    """Warping error of one pair: ``mean (cur - warp(prev, flow_back))^2`` over pixels and channels.

    ``prev``, ``cur``: frames ``t-1`` and ``t``, ``(H, W, C)`` or ``(H, W)`` float in ``[0, 1]``
    (uint8 divided by 255). ``flow_back``: ``(H, W, 2)`` float32 flow ``t -> t-1`` in pixels (on
    ``t``'s grid; it brings ``prev`` onto ``cur``'s grid). ``valid``: ``(H, W)`` bool, the pixels
    of ``t`` visible in ``t-1`` (:func:`~dynaeval.metrics.flow.valid_warp_mask`); None = all.
    ``region``: ``(H, W)`` bool focus mask on ``t``'s grid; None = whole frame.

    Returns the mean squared error on the ``[0, 1]`` scale (a float >= 0), averaged over the kept
    pixels *and channels* (Lai et al. 2018 sum the channels: theirs = 3 x ours for RGB).
    Raises EmptyRegionError when no pixel is kept.
    """
    prev, cur = _pair(prev, cur, ("prev", "cur"))
    hw = cur.shape[:2]
    keep = np.ones(hw, dtype=bool)
    for m, name in ((valid, "valid"), (region, "region")):
        m = _region(m, hw, name)
        if m is not None:
            keep &= m
    if not keep.any():
        raise EmptyRegionError(
            "warping error: no pixel is both visible in the previous frame and in the region"
        )
    diff = cur - warp(prev, flow_back)
    sq = diff[keep].astype(np.float64) ** 2
    return float(sq.mean())


def tof(flow_pred: np.ndarray, flow_gt: np.ndarray, region: np.ndarray | None = None) -> float:
    """tOF of one pair: mean Euclidean distance between two ``(H, W, 2)`` flows, in pixels.

    ``flow_pred``: flow ``pred_{t-1} -> pred_t``; ``flow_gt``: flow ``gt_{t-1} -> gt_t`` (both on
    ``t-1``'s grid, float32 ``(dx, dy)``). ``region``: ``(H, W)`` bool; None = whole frame.
    As TecoGAN (Chu et al. 2020) without its 8-pixel border crop. Raises EmptyRegionError for an
    empty region.
    """
    fp, fg = check_flow(flow_pred, "flow_pred"), check_flow(flow_gt, "flow_gt")
    if fp.shape != fg.shape:
        raise InputError(
            f"flow_pred and flow_gt must have one shape, got {fp.shape} and {fg.shape}"
        )
    epe = np.sqrt(np.sum((fp.astype(np.float64) - fg) ** 2, axis=-1))
    r = _region(region, fp.shape[:2])
    if r is None:
        return float(epe.mean())
    if not r.any():
        raise EmptyRegionError("tOF: the region holds no pixel")
    return float(epe[r].mean())


def default_lpips(net: str = "alex", device: str | None = None, backend: str = "torch") -> LpipsFn:
    """``(a, b) -> float``: ``dynaeval.metrics.lpips(a, b, net=net, device=device, backend=backend)``.

    With the torch backend it is a ``LpipsFeatures`` (same numbers bit for bit), which also has
    ``features`` / ``distance``: :func:`temporal_metrics` then computes each frame's features once
    for tLP instead of once per pair it belongs to. Frames must be in ``[0, 1]`` (InputError
    outside); WeightsUnavailableError on the first call when the pretrained backbone is missing.
    """
    import dynaeval.metrics as _metrics  # lazy: pulls in torch

    if backend == "torch":
        return _metrics.perceptual.LpipsFeatures(net, device=device)
    _lpips = _metrics.lpips
    if not callable(_lpips):  # the submodule, not the function
        _lpips = _lpips.lpips

    def fn(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.asarray(_lpips(a, b, net=net, device=device, backend=backend)))

    return fn


class _FeatureMemo:
    """Whole-frame LPIPS features of the frames in flight, keyed by (frame index, side), computed
    once even when two threads ask at the same time (the second waits for the first)."""

    def __init__(self, fn: Any) -> None:
        import threading

        self.fn = fn
        self._items: dict[tuple[int, str], Future] = {}
        self._lock = threading.Lock()

    def get(self, index: int, side: str, frame: np.ndarray) -> Any:
        with self._lock:
            fut = self._items.get((index, side))
            owner = fut is None
            if owner:
                fut = self._items[(index, side)] = Future()
        if owner:
            try:
                fut.set_result(self.fn.features(frame))
            except BaseException as exc:
                fut.set_exception(exc)
        return fut.result()

    def drop(self, index: int) -> None:
        with self._lock:
            for side in ("pred", "gt"):
                self._items.pop((index, side), None)


def _crop_box(region: np.ndarray, min_side: int) -> np.ndarray:
    h, w = region.shape
    box = mask_to_box(region)
    if box is None:
        raise EmptyRegionError("tLP: the region holds no pixel")
    x0, y0, x1, y1 = (int(v) for v in box)
    for lo, hi, size, idx in ((x0, x1, w, 0), (y0, y1, h, 1)):
        side = min(max(hi - lo, min_side), size)
        start = min(max((lo + hi - side) // 2, 0), size - side)
        box[idx], box[idx + 2] = start, start + side
    return clip_boxes(box, h, w)[0]


def tlp(
    pred_prev: np.ndarray,
    pred_cur: np.ndarray,
    gt_prev: np.ndarray,
    gt_cur: np.ndarray,
    lpips_fn: LpipsFn | None = None,
    region: np.ndarray | None = None,
    min_crop: int = 32,
) -> float:
    """tLP of one pair: ``|LPIPS(pred_prev, pred_cur) - LPIPS(gt_prev, gt_cur)|`` (TecoGAN).

    Frames: ``(H, W, 3)`` float32 in ``[0, 1]`` (uint8 divided by 255), all of one shape.
    ``lpips_fn``: ``(a, b) -> float`` taking two such frames (default :func:`default_lpips`).
    ``region``: ``(H, W)`` bool; the four frames are cropped to the region's tight box, grown to
    at least ``min_crop`` px per side, before LPIPS. Returns a float >= 0 (LPIPS units).
    """
    pred_prev, pred_cur = _pair(pred_prev, pred_cur, ("pred_prev", "pred_cur"))
    gt_prev, gt_cur = _pair(gt_prev, gt_cur, ("gt_prev", "gt_cur"))
    if pred_cur.shape != gt_cur.shape:
        raise InputError(
            f"prediction and ground truth must have one shape, got {pred_cur.shape} and {gt_cur.shape}"
        )
    r = _region(region, pred_cur.shape[:2])
    if r is not None:
        x0, y0, x1, y1 = _crop_box(r, min_crop)
        pred_prev, pred_cur, gt_prev, gt_cur = (
            x[y0:y1, x0:x1] for x in (pred_prev, pred_cur, gt_prev, gt_cur)
        )
    fn = lpips_fn or default_lpips()
    return abs(float(fn(pred_prev, pred_cur)) - float(fn(gt_prev, gt_cur)))


# --------------------------------------------------------------------------------------------
# Flicker: temporal standard deviation on static pixels


class TemporalStd:
    """Streaming per-pixel temporal standard deviation (Welford, float64) on a fixed pixel set.

    ``pixels``: ``(H, W)`` bool, the pixels to follow. ``update(frame)`` with ``(H, W, C)`` or
    ``(H, W)`` float frames; ``std()`` gives ``(N, C)`` population std (ddof=0) of the N pixels.
    """

    def __init__(self, pixels: np.ndarray) -> None:
        self.pixels = np.asarray(pixels, dtype=bool)
        self.count = 0
        self._mean: np.ndarray | None = None
        self._m2: np.ndarray | None = None

    def update(self, frame: np.ndarray) -> None:
        x = np.asarray(frame)[self.pixels].astype(np.float64)
        if self._mean is None:
            self._mean = np.zeros_like(x)
            self._m2 = np.zeros_like(x)
        self.count += 1
        delta = x - self._mean
        self._mean += delta / self.count
        self._m2 += delta * (x - self._mean)

    def std(self) -> np.ndarray:
        if self.count == 0 or self._m2 is None:
            raise InputError("temporal std needs at least one frame")
        return np.sqrt(self._m2 / self.count)


def _check_static(static_mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    m = np.asarray(static_mask)
    if m.dtype != bool or m.shape != shape:
        raise InputError(
            f"static_mask must be a bool (H, W) = {shape} mask (True = static pixel), got {m.dtype} {m.shape}"
        )
    return m


def flicker(
    pred_frames: Iterable[np.ndarray],
    gt_frames: Iterable[np.ndarray],
    static_mask: np.ndarray,
    region: np.ndarray | None = None,
) -> float:
    """Static-region flicker of one static camera: ``|mean std_t(pred) - mean std_t(gt)|``.

    ``pred_frames``, ``gt_frames``: T frames each, ``(H, W, 3)`` float in ``[0, 1]`` (uint8
    divided by 255). ``static_mask``: ``(H, W)`` bool, True where the scene does not move (from the
    motion masks). ``region``: optional ``(H, W)`` bool restricting the pixels further.
    The std is per pixel and channel over time (ddof=0); the mean is over the kept pixels and
    channels. Raises InputError for fewer than 2 frames and EmptyRegionError when no pixel is kept.
    Returns a float >= 0; :func:`temporal_metrics` also reports the signed difference.
    """
    result = _flicker_stream(pred_frames, gt_frames, static_mask, region)
    if result["value"] is None:
        raise result["error"]
    return result["value"]


def _flicker_stream(pred_frames, gt_frames, static_mask, region) -> dict:
    sp = sg = None
    keep = None
    n = 0
    for n, (p, g) in enumerate(_zip_frames(pred_frames, gt_frames), start=1):
        if sp is None:
            shape = p.shape
            keep = _check_static(static_mask, p.shape[:2])
            if region is not None:
                keep = keep & _region(region, p.shape[:2])
            sp, sg = TemporalStd(keep), TemporalStd(keep)
        if p.shape != shape:
            raise InputError(f"frame {n - 1} has shape {p.shape}, frame 0 had {shape}")
        sp.update(p)
        sg.update(g)
    if n < 2:
        return {"value": None, "error": InputError(f"flicker needs at least 2 frames, got {n}")}
    if not keep.any():
        return {
            "value": None,
            "error": EmptyRegionError("flicker: no static pixel (in the region)"),
        }
    vp, vg = float(sp.std().mean()), float(sg.std().mean())
    return {"value": abs(vp - vg), "signed": vp - vg, "pred": vp, "gt": vg}


def _zip_frames(pred_frames, gt_frames):
    try:
        for i, (p, g) in enumerate(zip(pred_frames, gt_frames, strict=True)):
            p, g = (
                check_image(p, f"prediction frame {i}"),
                check_image(g, f"ground-truth frame {i}"),
            )
            if p.shape != g.shape:
                raise InputError(
                    f"frame {i}: prediction {p.shape} and ground truth {g.shape} differ in shape"
                )
            yield p, g
    except ValueError as exc:
        if isinstance(exc, InputError | EmptyRegionError) or "zip()" not in str(exc):
            raise
        raise InputError(
            "prediction and ground truth have different numbers of frames; pair them first "
            "(dynaeval.io) so that frame i of one is frame i of the other"
        ) from exc


# --------------------------------------------------------------------------------------------
# Sequence API


def _as_region_mask(item, shape: tuple[int, int], i: int) -> np.ndarray:
    arr = np.asarray(item)
    if arr.dtype == bool:
        if arr.shape != shape:
            raise InputError(f"region mask of frame {i} must have shape {shape}, got {arr.shape}")
        return arr
    return boxes_to_mask(as_boxes(arr), *shape)


def _mean_or_reason(values: list, empty_reason: str) -> tuple[float | None, str | None]:
    got = [v for v in values if v is not None]
    if not got:
        return None, empty_reason
    return float(np.mean(got)), None


def _pair_terms(
    pp: np.ndarray,
    gp: np.ndarray,
    rp: np.ndarray | None,
    p: np.ndarray,
    g: np.ndarray,
    reg: np.ndarray | None,
    cache: FlowCache,
    config: TemporalConfig,
    lpips_fn: LpipsFn | None,
    memo: _FeatureMemo | None = None,
    index: int = 0,
) -> dict:
    """Every per-pair term of frames ``(t-1, t)``: prediction ``pp -> p``, ground truth ``gp -> g``,
    regions ``rp`` / ``reg`` (bool masks or None). ``lpips_fn`` None: no tLP. ``memo``: whole-frame
    LPIPS features by frame (``index`` is frame t's). Pure given the caches (which only save
    work), so pairs can be computed on several threads and folded in order.

    Returns ``{"per_pair": {name: float | None}, "parts": {warp name: {pred, gt, signed}},
    "lpips_error": str | None}``.
    """
    fcfg = config.flow
    values: dict[str, float | None] = {}
    parts: dict[str, dict[str, float | None]] = {}
    pair_region = None if reg is None or rp is None else (reg | rp)
    fw = cache.flow(gp, g, fcfg)  # gt t-1 -> t, on t-1's grid
    bw = cache.flow(g, gp, fcfg)  # gt t -> t-1, on t's grid: warps t-1 onto t
    valid = valid_warp_mask(bw, fw)
    for name, region in (("warp_error", None), ("focused_warp_error", pair_region)):
        if name.startswith("focused") and region is None:
            ep = eg = None
        else:
            try:
                ep = warp_error(pp, p, bw, valid, region)
                eg = warp_error(gp, g, bw, valid, region)
            except EmptyRegionError:
                ep = eg = None
        parts[name] = {"pred": ep, "gt": eg, "signed": None if ep is None else ep - eg}
        values[name] = None if ep is None else abs(ep - eg)

    fp = cache.flow(pp, p, fcfg)
    values["tof"] = tof(fp, fw)
    values["focused_tof"] = (
        None if pair_region is None or not pair_region.any() else tof(fp, fw, pair_region)
    )

    lpips_error = None
    if lpips_fn is not None:
        try:
            if memo is not None:  # = tlp(pp, p, gp, g, lpips_fn), each frame's features once
                d_pred = lpips_fn.distance(memo.get(index - 1, "pred", pp), memo.get(index, "pred", p))
                d_gt = lpips_fn.distance(memo.get(index - 1, "gt", gp), memo.get(index, "gt", g))
                values["tlp"] = abs(d_pred - d_gt)
            else:
                values["tlp"] = tlp(pp, p, gp, g, lpips_fn)
            values["focused_tlp"] = (
                None
                if pair_region is None or not pair_region.any()
                else tlp(pp, p, gp, g, lpips_fn, pair_region, config.tlp_min_crop)
            )
        except WeightsUnavailableError as exc:  # raised by the first LPIPS call
            lpips_error = f"LPIPS unavailable: WeightsUnavailableError: {exc}"
            values.pop("tlp", None)
    return {"per_pair": values, "parts": parts, "lpips_error": lpips_error}


def temporal_metrics(
    pred_frames: Iterable[np.ndarray],
    gt_frames: Iterable[np.ndarray],
    *,
    static_mask: np.ndarray | None = None,
    region_masks: Iterable[np.ndarray] | None = None,
    config: TemporalConfig | None = None,
    lpips_fn: LpipsFn | None = None,
    flow_cache: FlowCache | None = None,
    executor: Executor | None = None,
    window: int = 4,
) -> dict[str, dict]:
    """All temporal metrics of one camera's sequence, streaming over consecutive pairs.

    ``pred_frames``, ``gt_frames``: iterables of T paired frames ``(H, W, 3)``, float32 in
    ``[0, 1]`` or uint8; only two of each are held at a time. ``static_mask``: ``(H, W)`` bool,
    True = static pixel (static camera only; None: flicker is null). ``region_masks``: one item per
    frame, an ``(H, W)`` bool mask or ``(N, 4)`` boxes (``boxes_to_mask``); None: focused metrics
    are null. ``lpips_fn``: ``(a, b) -> float`` (default :func:`default_lpips`; if LPIPS cannot be
    loaded ``tlp`` is null with the reason). ``flow_cache``: share one across the methods scored
    on one ground truth so its flows are computed once (default: a private 64 MiB cache).
    ``executor``: a ``concurrent.futures`` executor (threads) to compute the pairs on, up to
    ``window`` pairs in flight (each holds its four frames); the numbers are those of the
    sequential run, which is what happens with None. ``lpips_fn`` must then be thread-safe
    (``default_lpips`` is). An ``lpips_fn`` with ``features`` / ``distance`` (``LpipsFeatures``,
    the torch default) gets each frame's whole-frame features computed once for tLP and kept
    while a pair in flight needs them (86 MB per frame and side at 1080p with AlexNet).

    Returns ``{name: {"value": float | None, "reason": str | None, "per_pair": [float | None]}}``
    for ``warp_error, tof, tlp, flicker`` and their ``focused_`` variants. ``value`` is the mean of
    the defined per-pair values (pair i = frames ``(i, i+1)``); None exactly when ``reason`` says
    why (fewer than 2 frames, no static pixels, empty regions, LPIPS missing). ``warp_error`` and
    ``flicker`` entries (and their focused variants) also carry ``"pred"`` and ``"gt"`` (the two
    terms, means over pairs) and ``"signed"`` (the mean of ``pred - gt`` without the absolute
    value; > 0: the prediction is less stable than the ground truth).
    Flicker has no per-pair values (``per_pair == []``).
    Convention: undefined -> null with a reason, never an exception; bad input (shapes, NaN)
    raises InputError.
    """
    config = config or TemporalConfig()
    cache = flow_cache if flow_cache is not None else FlowCache(max_bytes=1 << 26)
    names = [*TEMPORAL_METRICS, *(f"focused_{n}" for n in TEMPORAL_METRICS)]
    per_pair: dict[str, list] = {n: [] for n in names}
    parts: dict[str, dict[str, list]] = {
        n: {"pred": [], "gt": [], "signed": []} for n in ("warp_error", "focused_warp_error")
    }

    lpips_reason = None
    if not config.tlp:
        lpips_reason = "tLP disabled in the configuration (no LPIPS)"
    elif lpips_fn is None:
        try:
            lpips_fn = default_lpips(config.lpips_net, config.lpips_device, config.lpips_backend)
        except (ImportError, AttributeError) as exc:  # no LPIPS in this install: recorded
            lpips_reason = f"LPIPS unavailable: {type(exc).__name__}: {exc}"

    regions_iter = iter(region_masks) if region_masks is not None else repeat(None)
    static_p = static_g = None
    static_keep = None
    region_union = None
    prev = None  # (pred, gt, region)
    n_frames = 0
    pending: deque = deque()  # pair terms in frame order: futures (executor) or dicts
    memo = _FeatureMemo(lpips_fn) if hasattr(lpips_fn, "features") else None
    folded = 0

    def fold(terms: dict) -> None:
        nonlocal lpips_reason, folded
        if memo is not None:
            memo.drop(folded)  # pair k = frames (k, k+1): later pairs never need frame k
        folded += 1
        for name, value in terms["per_pair"].items():
            per_pair[name].append(value)
        for name, got in terms["parts"].items():
            for part, value in got.items():
                parts[name][part].append(value)
        if terms["lpips_error"] is not None and lpips_reason is None:
            lpips_reason = terms["lpips_error"]

    def drain(keep: int) -> None:
        while len(pending) > keep:
            item = pending.popleft()
            fold(item.result() if executor is not None else item)

    for i, (p, g) in enumerate(_zip_frames(pred_frames, gt_frames)):
        n_frames = i + 1
        hw = p.shape[:2]
        try:
            item = next(regions_iter)
        except StopIteration:
            raise InputError(
                f"region_masks has fewer items than the {i + 1} frames seen so far"
            ) from None
        reg = None if item is None else _as_region_mask(item, hw, i)
        if reg is not None:
            region_union = reg.copy() if region_union is None else region_union | reg

        if static_mask is not None:
            if static_p is None:
                static_keep = _check_static(static_mask, hw)
                static_p, static_g = TemporalStd(static_keep), TemporalStd(static_keep)
            static_p.update(p)
            static_g.update(g)

        if prev is not None:
            pp, gp, rp = prev
            if pp.shape != p.shape:
                raise InputError(f"frame {i} has shape {p.shape}, frame {i - 1} had {pp.shape}")
            args = (pp, gp, rp, p, g, reg, cache, config,
                    lpips_fn if lpips_reason is None else None, memo, i)
            if executor is None:
                pending.append(_pair_terms(*args))
            else:
                pending.append(executor.submit(_pair_terms, *args))
            drain(max(1, window) if executor is not None else 0)
        prev = (p, g, reg)
    drain(0)

    out: dict[str, dict] = {}
    short = f"needs at least 2 frames, got {n_frames}"
    no_regions = "no region masks given (focus: none)"
    for name in names:
        focused = name.startswith("focused_")
        base = name.removeprefix("focused_")
        if base == "flicker":
            continue
        if n_frames < 2:
            out[name] = {"value": None, "reason": short, "per_pair": []}
            continue
        if focused and region_masks is None:
            out[name] = {"value": None, "reason": no_regions, "per_pair": per_pair[name]}
            continue
        if base == "tlp" and lpips_reason is not None:
            out[name] = {"value": None, "reason": lpips_reason, "per_pair": []}
            continue
        empty = (
            "every pair's region was empty"
            if focused
            else "no pixel of any frame was visible in its previous frame (all occluded)"
        )
        value, reason = _mean_or_reason(per_pair[name], empty)
        out[name] = {"value": value, "reason": reason, "per_pair": per_pair[name]}
        if base == "warp_error":
            out[name]["signed"] = _mean_or_reason(parts[name]["signed"], empty)[0]
            out[name]["pred"] = _mean_or_reason(parts[name]["pred"], empty)[0]
            out[name]["gt"] = _mean_or_reason(parts[name]["gt"], empty)[0]

    for name, region in (("flicker", None), ("focused_flicker", region_union)):
        entry: dict = {"value": None, "reason": None, "per_pair": []}
        if n_frames < 2:
            entry["reason"] = short
        elif static_mask is None:
            entry["reason"] = "no static mask given (moving camera, or motion masks unavailable)"
        elif name == "focused_flicker" and region_masks is None:
            entry["reason"] = no_regions
        else:
            keep = static_keep if region is None else static_keep & region
            if not keep.any():
                entry["reason"] = (
                    "no static pixel: the static mask is empty"
                    if region is None
                    else "no static pixel inside the regions"
                )
            else:
                sel = keep[static_keep]  # static_keep's pixels, in the accumulators' order
                vp = float(static_p.std()[sel].mean())
                vg = float(static_g.std()[sel].mean())
                entry.update(value=abs(vp - vg), signed=vp - vg, pred=vp, gt=vg)
        out[name] = entry
    return {name: out[name] for name in names}

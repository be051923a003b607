"""Temporal terms of one pair of consecutive frames ``(t-1, t)``: pure functions, no state.

* :func:`warping_error`: ``E(x)``, the warping error of *one* sequence's pair (Lai et al. 2018):
  ``mean_{p in V, c} (x_t(p) - x_{t-1}(p + b(p)))^2`` with ``b`` the flow ``t -> t-1``. The
  reported ``warp_error`` is ``|E(pred) - E(gt)|`` per pair (:func:`pair_terms`), averaged over
  the pairs by :func:`dynaeval.metrics.temporal.temporal_metrics`.
* :func:`tof`: the endpoint difference of two flows (TecoGAN's tOF of one pair).
* :func:`tlp`: ``|LPIPS(pred_{t-1}, pred_t) - LPIPS(gt_{t-1}, gt_t)|`` (TecoGAN's tLP of one pair).
* :func:`pair_terms`: every per-pair value of frames ``(t-1, t)`` of prediction and ground truth
  (what the streaming engine computes for each pair, possibly on several threads).

Frames are ``(H, W, 3)`` RGB (or ``(H, W)``), float in ``[0, 1]``; uint8 is divided by 255.
Definitions and flow directions: docs/temporal-metrics.md.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future
from itertools import zip_longest
from typing import Any, NamedTuple

import numpy as np

from dynaeval.core.boxes import grow_box, mask_to_box
from dynaeval.core.errors import EmptyRegionError, InputError, WeightsUnavailableError
from dynaeval.core.validation import as_image
from dynaeval.metrics.flow import (
    FlowCache,
    FlowConfig,
    check_flow,
    sample_grid_of,
    visibility,
    warp,
)
from dynaeval.metrics.pair_kernels import (
    FramePrep,
    frame_prep,
    ground_truth_flows,
    prediction_flow,
    tof_terms,
    warp_errors,
)
from dynaeval.metrics.perceptual import LpipsFeatures, lpips
from dynaeval.metrics.registry import result_key

LpipsFn = Callable[[np.ndarray, np.ndarray], float]
"""``(a, b) -> float``: LPIPS of two ``(H, W, 3)`` float32 frames in ``[0, 1]``."""

WARP_ERROR_KEYS = (result_key("warp_error"), result_key("warp_error", "focused"))
"""Result keys of the reported warping-error difference, whole frame and focused."""


# --------------------------------------------------------------------------------------------
# Input checks shared by the temporal modules


def check_region(
    region: np.ndarray | None, shape: tuple[int, int], name: str = "region"
) -> np.ndarray | None:
    """``region`` as an ``(H, W) = shape`` bool mask (None stays None); InputError otherwise."""
    if region is None:
        return None
    r = np.asarray(region)
    if r.dtype != bool or r.shape != shape:
        raise InputError(f"{name} must be a bool mask of shape {shape}, got {r.dtype} {r.shape}")
    return r


def check_frames(a: np.ndarray, b: np.ndarray,
                 names: tuple[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """Two frames validated by ``as_image`` (float32, uint8 / 255) that must have one shape."""
    a, b = as_image(a, names[0]), as_image(b, names[1])
    if a.shape != b.shape:
        raise InputError(
            f"{names[0]} and {names[1]} must have one shape, got {a.shape} and {b.shape}"
        )
    return a, b


def paired_frames(
    pred_frames: Iterable[np.ndarray], gt_frames: Iterable[np.ndarray]
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """``(pred_i, gt_i)`` of two sequences, each validated (``as_image``) and of one shape.

    Raises InputError when the sequences differ in length or a pair in shape.
    """
    for i, (p, g) in enumerate(zip_longest(pred_frames, gt_frames, fillvalue=_ENDED)):
        if p is _ENDED or g is _ENDED:  # one sequence ended first
            raise InputError(
                "prediction and ground truth have different numbers of frames; pair them first "
                "(dynaeval.io) so that frame i of one is frame i of the other"
            )
        p, g = (
            as_image(p, f"prediction frame {i}"),
            as_image(g, f"ground-truth frame {i}"),
        )
        if p.shape != g.shape:
            raise InputError(
                f"frame {i}: prediction {p.shape} and ground truth {g.shape} differ in shape"
            )
        yield p, g


_ENDED = object()
"""``paired_frames``' stand-in for the frame of a sequence that has ended."""


# --------------------------------------------------------------------------------------------
# The three per-pair metrics


def warping_error(
    prev: np.ndarray,
    cur: np.ndarray,
    flow_back: np.ndarray,
    valid: np.ndarray | None = None,
    region: np.ndarray | None = None,
) -> float:
    """``E(x)`` of one sequence's pair: ``mean (cur - warp(prev, flow_back))^2`` over pixels and
    channels (Lai et al. 2018). Not the reported ``warp_error``, which is ``|E(pred) - E(gt)|``.

    ``prev``, ``cur``: frames ``t-1`` and ``t``, ``(H, W, C)`` or ``(H, W)`` float in ``[0, 1]``
    (uint8 divided by 255). ``flow_back``: ``(H, W, 2)`` float32 flow ``t -> t-1`` in pixels (on
    ``t``'s grid; it brings ``prev`` onto ``cur``'s grid). ``valid``: ``(H, W)`` bool, the pixels
    of ``t`` visible in ``t-1`` (:func:`~dynaeval.metrics.flow.valid_warp_mask`); None = all.
    ``region``: ``(H, W)`` bool focus mask on ``t``'s grid; None = whole frame.

    Returns the mean squared error on the ``[0, 1]`` scale (a float >= 0), averaged over the kept
    pixels *and channels* (Lai et al. 2018 sum the channels: theirs = 3 x ours for RGB).
    Raises EmptyRegionError when no pixel is kept.
    """
    prev, cur = check_frames(prev, cur, ("prev", "cur"))
    hw = cur.shape[:2]
    keep = np.ones(hw, dtype=bool)
    for m, name in ((valid, "valid"), (region, "region")):
        m = check_region(m, hw, name)
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
    r = check_region(region, fp.shape[:2])
    if r is None:
        return float(epe.mean())
    if not r.any():
        raise EmptyRegionError("tOF: the region holds no pixel")
    return float(epe[r].mean())


def default_lpips(net: str = "alex", device: str | None = None, backend: str = "torch") -> LpipsFn:
    """``(a, b) -> float``: ``dynaeval.metrics.lpips(a, b, net=net, device=device, backend=backend)``.

    With the torch backend it is a ``LpipsFeatures`` (same numbers bit for bit), which also has
    ``features`` / ``distance``: :func:`~dynaeval.metrics.temporal.temporal_metrics` then computes
    each frame's features once for tLP instead of once per pair it belongs to. Frames must be in
    ``[0, 1]`` (InputError outside); WeightsUnavailableError on the first call when the
    pretrained backbone is missing.
    """
    if backend == "torch":
        return LpipsFeatures(net, device=device)

    def fn(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.asarray(lpips(a, b, net=net, device=device, backend=backend)))

    return fn


def _crop_box(region: np.ndarray, min_side: int) -> np.ndarray:
    """Tight box of ``region`` grown, centred, to ``min_side`` px per side inside the frame (an
    odd extra pixel goes before the box: the crop focused_tlp has always used)."""
    h, w = region.shape
    box = mask_to_box(region)
    if box is None:
        raise EmptyRegionError("tLP: the region holds no pixel")
    return grow_box(box, min_side, min_side, h, w, odd_pixel="before")


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
    pred_prev, pred_cur = check_frames(pred_prev, pred_cur, ("pred_prev", "pred_cur"))
    gt_prev, gt_cur = check_frames(gt_prev, gt_cur, ("gt_prev", "gt_cur"))
    if pred_cur.shape != gt_cur.shape:
        raise InputError(
            f"prediction and ground truth must have one shape, got {pred_cur.shape} and {gt_cur.shape}"
        )
    r = check_region(region, pred_cur.shape[:2])
    if r is not None:
        x0, y0, x1, y1 = _crop_box(r, min_crop)
        pred_prev, pred_cur, gt_prev, gt_cur = (
            x[y0:y1, x0:x1] for x in (pred_prev, pred_cur, gt_prev, gt_cur)
        )
    fn = lpips_fn or default_lpips()
    return abs(float(fn(pred_prev, pred_cur)) - float(fn(gt_prev, gt_cur)))


# --------------------------------------------------------------------------------------------
# Every term of one pair, for the streaming engine


class Frames(NamedTuple):
    """One time step of a camera: prediction, ground truth and the focus region."""

    pred: np.ndarray
    """``(H, W, 3)`` float32 in ``[0, 1]`` (checked)."""
    gt: np.ndarray
    """``(H, W, 3)`` float32 in ``[0, 1]``, the prediction's shape."""
    region: np.ndarray | None
    """``(H, W)`` bool focus mask, or None (no regions given for this frame)."""
    prep: FramePrep | None = None
    """Gray images and hashes for the flows (``pair_kernels.frame_prep``); None: made when
    needed."""


class FeatureMemo:
    """Whole-frame LPIPS features of the frames in flight, keyed by (frame index, side), computed
    once even when two threads ask at the same time (the second waits for the first).

    ``fn``: an ``LpipsFn`` with ``features(frame)`` / ``distance(fa, fb)`` (``LpipsFeatures``).
    """

    def __init__(self, fn: Any) -> None:
        self.fn = fn
        self._items: dict[tuple[int, str], Future] = {}
        self._lock = threading.Lock()

    def get(self, index: int, side: str, frame: np.ndarray) -> Any:
        """The features of frame ``index`` of ``side`` (``pred`` / ``gt``), computed on first ask."""
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
        """Forget frame ``index``'s features (no pair still to compute needs them)."""
        with self._lock:
            for side in ("pred", "gt"):
                self._items.pop((index, side), None)


class GroundTruthPair(NamedTuple):
    """What the terms of a pair ``(t-1, t)`` need of the ground truth alone
    (:func:`ground_truth_pair`): the same for every method scored on it, so ``dynaeval
    prepare`` computes it once."""

    fw: np.ndarray
    """``(H, W, 2)`` float32 ground-truth flow ``t-1 -> t`` (tOF's reference)."""
    bw: np.ndarray
    """``(H, W, 2)`` float32 ground-truth flow ``t -> t-1`` (warps ``t-1`` onto ``t``)."""
    valid: np.ndarray
    """``(H, W)`` bool, the pixels of ``t`` visible in ``t-1`` (``flow.visibility(bw, fw)``)."""
    warp_error: tuple[float | None, float | None]
    """``E(gt)`` of the pair (:func:`warping_error`) over ``valid`` and over ``valid`` inside
    the pair's focus region (:func:`pair_region`); None: no pixel kept, or no region."""


def pair_region(prev: np.ndarray | None, cur: np.ndarray | None) -> np.ndarray | None:
    """The focus region of a pair: the union of its two frames' ``(H, W)`` bool regions (None
    when either frame has none)."""
    return None if cur is None or prev is None else (cur | prev)


def _kept_pixels(valid: np.ndarray, region: np.ndarray | None) -> list[np.ndarray | None]:
    """The flat indices of the pixels the warping errors average: visible ones; visible ones
    in ``region`` (None without a region)."""
    return [np.flatnonzero(valid), None if region is None else np.flatnonzero(valid & region)]


def _errors_of(prev: np.ndarray, cur: np.ndarray, xs: np.ndarray, ys: np.ndarray,
               keeps: list[np.ndarray | None]) -> list[float | None]:
    """``E`` of one sequence's pair for each kept pixel set of ``keeps`` (None: not computed),
    ``prev`` warped once on the backward flow's grid ``(xs, ys)``."""
    got = iter(warp_errors(prev, cur, xs, ys, [k for k in keeps if k is not None]))
    return [None if k is None else next(got) for k in keeps]


def ground_truth_pair(prev_gt: np.ndarray, cur_gt: np.ndarray, fw: np.ndarray, bw: np.ndarray,
                      region: np.ndarray | None) -> GroundTruthPair:
    """The :class:`GroundTruthPair` of ground-truth frames ``(t-1, t)`` (checked float32
    ``(H, W, C)``), their flows and the pair's region (``(H, W)`` bool or None): what
    ``dynaeval prepare`` stores, the very computation of a scoring run."""
    return _ground_truth_on_grid(prev_gt, cur_gt, fw, bw, region)[0]


def _ground_truth_on_grid(
    prev_gt: np.ndarray, cur_gt: np.ndarray, fw: np.ndarray, bw: np.ndarray,
    region: np.ndarray | None,
) -> tuple[GroundTruthPair, np.ndarray, np.ndarray, list[np.ndarray | None]]:
    """:func:`ground_truth_pair` with the sample grid ``(xs, ys)`` of ``bw`` it was found on
    (``(H, W)`` float32 each) and the kept pixels (``_kept_pixels``), for the prediction's
    warping errors."""
    valid, xs, ys = visibility(bw, fw)  # the pixels of t visible in t-1, bw's grid
    keeps = _kept_pixels(valid, region)
    errors = _errors_of(prev_gt, cur_gt, xs, ys, keeps)
    return GroundTruthPair(fw, bw, valid, (errors[0], errors[1])), xs, ys, keeps


def _warp_error_parts(e_pred: list[float | None],
                      e_gt: tuple[float | None, ...]) -> list[dict[str, float | None]]:
    """``{"pred": E(pred), "gt": E(gt), "signed": E(pred) - E(gt)}`` of each kept pixel set;
    all None where either is None (no pixel kept, or no region)."""
    return [dict(_NO_PARTS) if ep is None or eg is None
            else {"pred": ep, "gt": eg, "signed": ep - eg} for ep, eg in zip(e_pred, e_gt, strict=True)]


_NO_PARTS: dict[str, float | None] = {"pred": None, "gt": None, "signed": None}


def _tlp_values(
    prev: Frames, cur: Frames, region: np.ndarray | None, lpips_fn: LpipsFn, min_crop: int,
    memo: FeatureMemo | None, index: int,
) -> dict[str, float | None]:
    """``{"tlp": ..., "focused_tlp": ...}`` of the pair; the whole-frame LPIPS from ``memo``'s
    features when given (= ``tlp(...)`` bit for bit, each frame's features once)."""
    if memo is not None:
        d_pred = lpips_fn.distance(memo.get(index - 1, "pred", prev.pred),
                                   memo.get(index, "pred", cur.pred))
        d_gt = lpips_fn.distance(memo.get(index - 1, "gt", prev.gt), memo.get(index, "gt", cur.gt))
        whole = abs(d_pred - d_gt)
    else:
        whole = tlp(prev.pred, cur.pred, prev.gt, cur.gt, lpips_fn)
    focused = (
        None
        if region is None or not region.any()
        else tlp(prev.pred, cur.pred, prev.gt, cur.gt, lpips_fn, region, min_crop)
    )
    return {result_key("tlp"): whole, result_key("tlp", "focused"): focused}


def _prep(frames: Frames) -> FramePrep:
    return frame_prep(frames.pred, frames.gt) if frames.prep is None else frames.prep


def pair_terms(
    prev: Frames,
    cur: Frames,
    cache: FlowCache,
    flow: FlowConfig,
    lpips_fn: LpipsFn | None = None,
    min_crop: int = 32,
    memo: FeatureMemo | None = None,
    index: int = 0,
    ground_truth: Callable[[], GroundTruthPair] | None = None,
) -> dict:
    """Every per-pair term of frames ``(t-1, t)`` = ``(prev, cur)``, ``index`` = t.

    The focused terms use the union of the two frames' regions (None when either has none).
    ``flow``: the estimator; ``lpips_fn`` None: no tLP; ``min_crop``: focused tLP's crop side;
    ``memo``: whole-frame LPIPS features by frame; ``ground_truth()``: the pair's
    :class:`GroundTruthPair` computed beforehand for these very frames and regions (``dynaeval
    prepare``; None: computed here from the frames' gray images). Pure given the caches (which
    only save work), so pairs can be computed on several threads and folded in order.

    Returns ``{"per_pair": {result key: float | None}, "parts": {warp-error key: {pred, gt,
    signed}}, "lpips_error": str | None}``; ``per_pair["warp_error"]`` is ``|E(pred) - E(gt)|``.
    """
    region = pair_region(prev.region, cur.region)
    p_prev, p_cur = _prep(prev), _prep(cur)
    if ground_truth is None:
        fw, bw = ground_truth_flows(p_prev, p_cur, cache, flow)
        gt, xs, ys, keeps = _ground_truth_on_grid(prev.gt, cur.gt, fw, bw, region)
    else:
        gt = ground_truth()
        xs, ys = sample_grid_of(gt.bw)  # the grid visibility found the mask on
        keeps = _kept_pixels(gt.valid, region)
    e_pred = _errors_of(prev.pred, cur.pred, xs, ys, keeps)
    parts = dict(zip(WARP_ERROR_KEYS, _warp_error_parts(e_pred, gt.warp_error), strict=True))
    values: dict[str, float | None] = {
        key: None if got["signed"] is None else abs(got["signed"]) for key, got in parts.items()
    }
    fp = prediction_flow(p_prev, p_cur, cache, flow)
    values[result_key("tof")], values[result_key("tof", "focused")] = tof_terms(fp, gt.fw, region)

    lpips_error = None
    if lpips_fn is not None:
        try:
            values.update(_tlp_values(prev, cur, region, lpips_fn, min_crop, memo, index))
        except WeightsUnavailableError as exc:  # raised by the first LPIPS call
            lpips_error = f"LPIPS unavailable: WeightsUnavailableError: {exc}"
    return {"per_pair": values, "parts": parts, "lpips_error": lpips_error}

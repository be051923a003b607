"""The per-pair work of the temporal engine at its floor: :func:`pair_terms`' numbers, bit for bit
those of the pure functions (``warping_error``, ``tof``, ``valid_warp_mask``; a test holds them
together), with the work each of them repeats done once.

* per frame, once (:func:`frame_prep`): the gray image the flows run on and its hash for the flow
  cache's key (the frame itself was checked once by the engine);
* per pair, once: the sample grid of the backward flow (visibility, warping the prediction and
  warping the ground truth share it), the visibility mask and the flat indices of the kept
  pixels (whole frame; focus region), each frame's warp ``warp(prev)``;
* per term: one compiled gather of the kept differences' (``cur - warp(prev)``) float64
  squares by index into a per-thread buffer (instead of a boolean mask re-evaluated per call)
  and their float64 mean, taken on an array of the very shape and order ``warping_error``
  reduces, so numpy's pairwise sum gives the same bits.

Frames: ``(H, W, C)`` or ``(H, W)`` float32 in ``[0, 1]``, already checked (``as_image``).
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np

from dynaeval.metrics.flow import FlowCache, FlowConfig, gray_digest, gray_of_checked, warp_on_grid


class FramePrep(NamedTuple):
    """What the flows need of one time step, computed once: gray images and their hashes."""

    gray_pred: np.ndarray
    """``(H, W)`` uint8, ``to_gray_u8(pred)``."""
    gray_gt: np.ndarray | None
    """``(H, W)`` uint8, ``to_gray_u8(gt)``; None when the ground truth's flows are not looked
    up by content (prepared: ``temporal_pairs.GroundTruthPair``)."""
    digests: tuple[bytes, bytes | None]
    """``gray_digest`` of the prediction's and of the ground truth's gray image (None with it)."""


def frame_prep(pred: np.ndarray, gt: np.ndarray, *, gt_gray: bool = True) -> FramePrep:
    """The :class:`FramePrep` of one time step (checked float32 frames); ``gt_gray`` False:
    the prediction's only."""
    gp = gray_of_checked(pred)
    gg = gray_of_checked(gt) if gt_gray else None
    return FramePrep(gp, gg, (gray_digest(gp), None if gg is None else gray_digest(gg)))


def ground_truth_flows(prev: FramePrep, cur: FramePrep, cache: FlowCache,
                       flow: FlowConfig) -> tuple[np.ndarray, np.ndarray]:
    """``(fw, bw)``: ground-truth flows ``t-1 -> t`` and ``t -> t-1``."""
    fw = cache.flow_gray(prev.gray_gt, cur.gray_gt, flow, (prev.digests[1], cur.digests[1]))
    bw = cache.flow_gray(cur.gray_gt, prev.gray_gt, flow, (cur.digests[1], prev.digests[1]))
    return fw, bw


def prediction_flow(prev: FramePrep, cur: FramePrep, cache: FlowCache,
                    flow: FlowConfig) -> np.ndarray:
    """The prediction's flow ``t-1 -> t`` (from ``cache``: a prediction equal to its ground
    truth gets the ground truth's very flow)."""
    return cache.flow_gray(prev.gray_pred, cur.gray_pred, flow, (prev.digests[0], cur.digests[0]))


_BUFFERS = threading.local()


def _buffer(n: int) -> np.ndarray:
    """This thread's float64 buffer of at least ``n`` values (kept between pairs: a fresh
    50 MB array per term is page-faulted in again every time)."""
    got = getattr(_BUFFERS, "pair", None)
    if got is None or got.size < n:
        got = _BUFFERS.pair = np.empty(n, np.float64)
    return got


def kept_mse(cur: np.ndarray, warped: np.ndarray, keep: np.ndarray) -> float | None:
    """Mean of ``(cur - warped) ** 2`` (difference in float32, square and mean in float64) over
    the pixels ``keep`` and every channel; None when ``keep`` is empty. ``cur``, ``warped``:
    ``(H, W, C)`` or ``(H, W)`` float32 of one shape; ``keep``: flat pixel indices
    (``np.flatnonzero`` of the mask), in increasing order.

    Equals ``((cur - warped)[mask].astype(np.float64) ** 2).mean()`` bit for bit: the same
    squares (one compiled gather, ``gather_kernels.squared_differences_at``), in the same order,
    reduced as an array of the same shape.
    """
    from dynaeval.metrics.gather_kernels import squared_differences_at

    if keep.size == 0:
        return None
    c = 1 if cur.ndim == 2 else cur.shape[2]
    sq = _buffer(keep.size * c)[: keep.size * c]
    squared_differences_at(cur.reshape(-1, c), warped.reshape(-1, c), keep, sq.reshape(keep.size, c))
    return float((sq.reshape(keep.size, c) if cur.ndim == 3 else sq).mean())


def warp_errors(prev: np.ndarray, cur: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                keeps: list[np.ndarray]) -> list[float | None]:
    """``warping_error(prev, cur, bw, valid, region)`` for each kept set of ``keeps`` (flat
    indices), the warp of ``prev`` done once on ``bw``'s sample grid ``(xs, ys)``, the difference
    ``cur - warp(prev, bw)`` taken at the kept pixels only."""
    warped = warp_on_grid(prev, xs, ys)
    return [kept_mse(cur, warped, k) for k in keeps]


def tof_terms(fp: np.ndarray, fw: np.ndarray, region: np.ndarray | None) -> tuple[float, float | None]:
    """``(tof(fp, fw), tof(fp, fw, region))`` bit for bit, the endpoint map computed once (one
    compiled loop, ``flow_kernels.endpoint_error``: ``np.sqrt(np.sum((fp.astype(np.float64) -
    fw) ** 2, axis=-1))``'s operations); the focused value None when ``region`` is None or
    empty."""
    from dynaeval.metrics.flow_kernels import endpoint_error

    epe = np.empty(fp.shape[:2], np.float64)
    endpoint_error(fp, fw, epe)
    whole = float(epe.mean())
    if region is None:
        return whole, None
    # np.compress: the values of epe[region] in their order, without their indices
    kept = np.compress(region.reshape(-1), epe.reshape(-1))
    return whole, (float(kept.mean()) if kept.size else None)

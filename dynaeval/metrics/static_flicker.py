"""Static-region flicker of one static camera: the temporal standard deviation of static pixels.

``flicker = |S(pred) - S(gt)|`` with ``S(x) = mean_{p static, c} std_t x_t(p, c)`` (ddof=0), in
one streaming pass (Welford, float64). :class:`SequenceFlicker` is the one computation: the
function :func:`flicker` and the streaming engine
(:func:`dynaeval.metrics.temporal.temporal_metrics`) both use it.

The module is not called ``flicker``: ``dynaeval.metrics.flicker`` is the function.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from dynaeval.core.errors import EmptyRegionError, InputError
from dynaeval.metrics.temporal_pairs import check_region, paired_frames


class TemporalStd:
    """Streaming per-pixel temporal standard deviation (Welford, float64) on a fixed pixel set.

    ``pixels``: ``(H, W)`` bool, the pixels to follow. ``update(frame)`` with ``(H, W, C)`` or
    ``(H, W)`` float frames; ``std()`` gives ``(N, C)`` population std (ddof=0) of the N pixels.

    The boolean mask is resolved to indices once; each update is one compiled loop over them
    (``flicker_kernels.welford_update``: the float64 Welford step per value, the bits of the
    numpy steps it replaced, tested).
    """

    def __init__(self, pixels: np.ndarray) -> None:
        self.pixels = np.asarray(pixels, dtype=bool)
        self._index = np.flatnonzero(self.pixels)
        self.count = 0
        self._mean: np.ndarray | None = None
        self._m2: np.ndarray | None = None
        self._tail: tuple[int, ...] = ()  # the frames' channel axis, () for (H, W) frames
        self._std: np.ndarray | None = None  # std() of the frames so far, until the next update

    def update(self, frame: np.ndarray) -> None:
        from dynaeval.metrics.flicker_kernels import welford_update

        arr = np.ascontiguousarray(frame)
        if arr.shape[:2] != self.pixels.shape or (self._mean is not None
                                                  and arr.shape[2:] != self._tail):
            raise InputError(f"frame of shape {arr.shape}: the followed pixels are "
                             f"{self.pixels.shape} and the frames so far {self.pixels.shape + self._tail}")
        rows = arr.reshape(arr.shape[0] * arr.shape[1], -1)
        if self._mean is None:
            self._tail = arr.shape[2:]
            self._mean = np.zeros((self._index.size, rows.shape[1]), np.float64)
            self._m2 = np.zeros_like(self._mean)
        self.count += 1
        self._std = None
        welford_update(rows, self._index, self._mean, self._m2, np.float64(self.count))

    def std(self) -> np.ndarray:
        """The ``(N, C)`` (``(N,)`` for ``(H, W)`` frames) float64 population std of the frames
        so far; read-only, computed once per frame count (the whole-frame and the focused
        flicker read the same)."""
        from dynaeval.metrics.flicker_kernels import population_std

        if self.count == 0 or self._m2 is None:
            raise InputError("temporal std needs at least one frame")
        if self._std is None:
            out = np.empty_like(self._m2)
            population_std(self._m2, np.float64(self.count), out)
            out.setflags(write=False)
            self._std = out.reshape(self._index.size, *self._tail)
        return self._std


def check_static(static_mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``static_mask`` as an ``(H, W) = shape`` bool mask (True = static pixel); InputError else."""
    m = np.asarray(static_mask)
    if m.dtype != bool or m.shape != shape:
        raise InputError(
            f"static_mask must be a bool (H, W) = {shape} mask (True = static pixel), got {m.dtype} {m.shape}"
        )
    return m


def static_mean(std: np.ndarray, pixels: np.ndarray, region: np.ndarray | None) -> float | None:
    """``S``: the mean of a temporal std ``std`` (``(N, C)`` float64 of the N followed
    ``pixels``, ``TemporalStd.std``) over the followed pixels inside ``region`` (``(H, W)``
    bool; None: all of them), or None when none is kept. One function for a scoring run and
    ``dynaeval prepare``: the same bits."""
    if region is None:
        return float(std.mean()) if pixels.any() else None
    sel = region[pixels]  # the followed pixels, in the accumulators' order
    if not sel.any():
        return None
    # np.compress: the values of std[sel], in their order, ~4x faster than the mask index
    return float(np.compress(sel, std, axis=0).mean())


class SequenceFlicker:
    """Flicker of one sequence, streamed: the temporal std of prediction and ground truth on the
    pixels ``pixels`` (``(H, W)`` bool, checked), one frame pair at a time.

    ``gt_means``: ``S(gt)`` over the pixels and over the pixels inside the focused region
    (``static_mean`` of the ground truth's std of the same frames, computed beforehand:
    ``dynaeval prepare``; None where no pixel is kept); the ground truth is then neither
    accumulated nor read.
    """

    def __init__(self, pixels: np.ndarray,
                 gt_means: tuple[float | None, float | None] | None = None) -> None:
        self.pixels = pixels
        self.pred = TemporalStd(pixels)
        self.gt = TemporalStd(pixels) if gt_means is None else None
        self._gt_means = gt_means

    def update(self, pred: np.ndarray, gt: np.ndarray | None) -> None:
        """Add frame t of the prediction and of the ground truth (``(H, W, C)`` float; the
        ground truth unused with ``gt_means``)."""
        self.pred.update(pred)
        if self.gt is not None:
            self.gt.update(gt)

    def terms(self, region: np.ndarray | None = None,
              focused: bool = False) -> dict[str, float] | None:
        """``{"value": |S(pred) - S(gt)|, "signed": S(pred) - S(gt), "pred": S(pred), "gt": S(gt)}``
        over the followed pixels (inside ``region``, ``(H, W)`` bool, when given: the focused
        region, ``focused`` True, when the sequence has ``gt_means``); None when no pixel is
        kept. Needs at least one frame."""
        vp = static_mean(self.pred.std(), self.pixels, region)
        if vp is None:
            return None
        vg = (static_mean(self.gt.std(), self.pixels, region) if self._gt_means is None
              else self._gt_means[1 if focused else 0])
        return {"value": abs(vp - vg), "signed": vp - vg, "pred": vp, "gt": vg}


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
    Returns a float >= 0; :func:`~dynaeval.metrics.temporal.temporal_metrics` also reports the
    signed difference.
    """
    acc = None
    n = 0
    for n, (p, g) in enumerate(paired_frames(pred_frames, gt_frames), start=1):
        if acc is None:
            shape = p.shape
            keep = check_static(static_mask, p.shape[:2])
            if region is not None:
                keep = keep & check_region(region, p.shape[:2])
            acc = SequenceFlicker(keep)
        if p.shape != shape:
            raise InputError(f"frame {n - 1} has shape {p.shape}, frame 0 had {shape}")
        acc.update(p, g)
    if n < 2:
        raise InputError(f"flicker needs at least 2 frames, got {n}")
    terms = acc.terms()
    if terms is None:
        raise EmptyRegionError("flicker: no static pixel (in the region)")
    return terms["value"]

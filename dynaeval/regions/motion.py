"""Motion weights and masks for one *static* camera: which pixels move (DyNeRF-style).

Weights per frame ``t`` and pixel, from the camera's frames ``C_t`` (RGB, [0, 1]):

* **ISG** (global, "image-space gradient" in DyNeRF's sampling terms): Geman-McClure of the
  difference to the per-pixel temporal median ``M``, averaged over channels::

      w_t = mean_c  d^2 / (d^2 + gamma^2),   d = C_t[c] - M[c]          (in [0, 1))

  ``gamma`` sets the difference that counts as half-moved (w = 0.5 where |d| = gamma in every
  channel). K-Planes (``plenoxels/datasets/video_datasets.py``, ``dynerf_isg_weight``) uses
  ``gamma = 2e-2`` on full sequences and ``1e-3`` on keyframes, on [0, 1] values; we default to
  2e-2. ``M`` is ``np.median`` over at most ``median_frames`` evenly spaced frames (all frames when
  the sequence is shorter, i.e. the exact median).

* **IST** (temporal): the largest absolute difference to any frame within ``+-window`` frames,
  per channel, averaged over channels, floored at ``alpha``::

      w_t = max(alpha, mean_c max_{0<|k|<=window} |C_t[c] - C_{t+k}[c]|)   (in [alpha, 1])

  DyNeRF / K-Planes use ``window = 25`` and ``alpha = 0.1`` (K-Planes' ``dynerf_ist_weight``
  applies the floor to 0-255 values, where it has almost no effect, and pads the sequence ends
  with black frames; here values are in [0, 1] and only frames that exist are compared).

Weights are **not normalised**: for ray importance sampling use ``w / w.sum()`` over the pixels you
sample from. Masks threshold the weights (``w > threshold``) then clean them with morphology
(opening removes speckle, closing fills holes, small components go, dilation adds a margin).

Memory stays bounded: frames are read one at a time (IST keeps ``2 * window + 1`` frames), and the
ISG median stacks the rows of ``min(T, median_frames)`` frames as float32, at most
``MEDIAN_MAX_BYTES`` (256 MiB) at a time: 64 frames of 1080p (1.6 GB) are taken in 7 bands of rows,
each reading the frames again. ``frames`` can be an array
``(T, H, W, C)`` or any sequence with ``len`` and indexing that loads a frame on access (e.g.
``LazyFrames(paths, load)``). ISG reads each frame twice (median pass, then weights), so it needs
such a sequence; IST reads once and accepts any iterable, including a generator.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import as_image

MOTION_KINDS = ("isg", "ist")
_DEFAULT_THRESHOLD = {"isg": 0.5, "ist": 0.15}


@dataclass(frozen=True)
class MotionConfig:
    """How motion weights are computed and turned into a binary mask."""

    kind: str = "isg"
    """``"isg"`` (difference to the temporal median) or ``"ist"`` (difference within a window)."""
    gamma: float = 2e-2
    """ISG: Geman-McClure scale, in [0, 1] intensity units (DyNeRF / K-Planes: 2e-2)."""
    window: int = 25
    """IST: compare with frames up to this many frames before and after (DyNeRF: 25)."""
    alpha: float = 0.1
    """IST: floor of the weights (DyNeRF: 0.1), so static pixels keep some sampling weight."""
    threshold: float | None = None
    """A pixel moves where its weight is > threshold; None: 0.5 for ISG, 0.15 for IST (must be
    above ``alpha`` for IST, or every pixel moves)."""
    median_frames: int = 64
    """ISG: the median uses at most this many evenly spaced frames (bounded memory)."""
    open_radius: int = 1
    """Morphological opening radius in px (removes isolated noisy pixels); 0 disables."""
    close_radius: int = 2
    """Morphological closing radius in px (fills small holes inside a mover); 0 disables."""
    min_area: int = 16
    """Connected components smaller than this many pixels are removed; 0 disables."""
    dilate_radius: int = 2
    """Final dilation radius in px (a margin for edges and motion blur); 0 disables."""

    def __post_init__(self) -> None:
        if self.kind not in MOTION_KINDS:
            raise InputError(f"motion kind must be 'isg' or 'ist', got {self.kind!r}")
        if not self.gamma > 0:
            raise InputError(f"gamma must be > 0, got {self.gamma!r}")
        if self.window < 1:
            raise InputError(f"window must be >= 1 frame, got {self.window!r}")
        if not 0 <= self.alpha < 1:
            raise InputError(f"alpha must be in [0, 1), got {self.alpha!r}")
        if self.median_frames < 1:
            raise InputError(f"median_frames must be >= 1, got {self.median_frames!r}")
        for name in ("open_radius", "close_radius", "min_area", "dilate_radius"):
            if getattr(self, name) < 0:
                raise InputError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.threshold is not None and not 0.0 <= self.threshold < 1.0:
            raise InputError(f"threshold must be in [0, 1) (weights never reach 1), got {self.threshold!r}")
        if self.kind == "ist" and self.effective_threshold <= self.alpha:
            raise InputError(
                f"IST threshold {self.effective_threshold} must be above alpha {self.alpha} "
                "(weights are floored at alpha, so every pixel would count as moving)"
            )

    @property
    def effective_threshold(self) -> float:
        """The threshold in use (the per-kind default when ``threshold`` is None)."""
        return _DEFAULT_THRESHOLD[self.kind] if self.threshold is None else float(self.threshold)


class LazyFrames(Sequence):
    """A sequence that loads frame ``i`` as ``load(items[i])`` on access (nothing kept in memory).

    ``items``: e.g. file paths; ``load``: returns an ``(H, W, C)`` uint8 or float [0, 1] array.
    """

    def __init__(self, items: Sequence[Any], load: Callable[[Any], np.ndarray]) -> None:
        self.items = list(items)
        self.load = load

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return LazyFrames(self.items[i], self.load)
        return self.load(self.items[i])


def _frame(frame: object, index: int, shape: tuple[int, ...] | None) -> np.ndarray:
    """One frame as ``(H, W, C)`` float32 in [0, 1]; InputError on a bad shape, dtype or range."""
    arr = as_image(frame, f"frame {index}", check_range=True)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if shape is not None and arr.shape != shape:
        raise InputError(f"frame {index}: shape {arr.shape} differs from frame 0's {shape} (one static camera)")
    return arr


def _as_sequence(frames: object) -> Sequence:
    if isinstance(frames, np.ndarray):
        if frames.ndim not in (3, 4):
            raise InputError(f"frames must be (T, H, W, C) or (T, H, W), got shape {frames.shape}")
        return frames  # type: ignore[return-value]
    if hasattr(frames, "__len__") and hasattr(frames, "__getitem__"):
        return frames  # type: ignore[return-value]
    raise InputError(
        "ISG reads the frames twice (median, then weights) and needs a sequence with len() and "
        "indexing, not a one-shot iterator; wrap file paths as LazyFrames(paths, load)"
    )


def subsample_indices(n: int, max_frames: int) -> np.ndarray:
    """At most ``max_frames`` evenly spaced indices in ``[0, n)``, first and last included."""
    if n <= max_frames:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(np.int64))


MEDIAN_MAX_BYTES = 256 * 2**20
"""The ISG median's stack of frames (float32) is at most this big: a longer or larger stack is
taken band by band of rows, each band reading its frames again (through the caller's frame
cache), so the memory of the median does not grow with the frames it uses."""


MEDIAN_BAND_BYTES = 8 * 2**20
"""When the frames fit ``MEDIAN_MAX_BYTES``, they are read once and their rows copied into stacks
of at most this many bytes (in the CPU's cache) for the median kernel."""


def temporal_median(frames: Sequence, max_frames: int = 64, executor: Executor | None = None,
                    max_bytes: int = MEDIAN_MAX_BYTES) -> np.ndarray:
    """Per-pixel median ``(H, W, C)`` float32 over at most ``max_frames`` evenly spaced frames.

    Exact (``np.median`` over all frames, mean of the two middle values for even counts, bit for
    bit: ``dynaeval.regions.motion_kernels``) when ``len(frames) <= max_frames``. Each pixel's
    median is its own, so it is taken band by band of rows (the same values): when the frames
    fit ``max_bytes`` they are read once and their rows stacked a small band at a time; else in
    bands of at most ``max_bytes`` of stacked rows, each reading the frames again (a lazy
    sequence loads them once per band). With ``executor`` (threads) the frames are read and the
    bands' medians taken on it.
    """
    seq = _as_sequence(frames)
    n = len(seq)
    if n == 0:
        raise InputError("no frames: the temporal median needs at least one frame")
    idx = subsample_indices(n, max_frames)
    first = _frame(seq[int(idx[0])], int(idx[0]), None)
    height = first.shape[0]
    row_bytes = len(idx) * first[0].nbytes
    rows = int(min(height, max(1, max_bytes // row_bytes)))
    out = np.empty(first.shape, np.float32)
    run = executor.map if executor is not None else map

    def load(k: int) -> np.ndarray:
        return first if k == 0 else _frame(seq[int(idx[k])], int(idx[k]), first.shape)

    if rows == height:  # every frame in memory at once: read once, no frame-sized stack
        loaded = list(run(load, range(len(idx))))
        step = int(max(1, MEDIAN_BAND_BYTES // row_bytes))

        def small(r0: int) -> None:
            part = np.empty((len(idx), min(step, height - r0), *first.shape[1:]), np.float32)
            for k, frame in enumerate(loaded):
                part[k] = frame[r0 : r0 + part.shape[1]]
            _median_rows(part, out[r0 : r0 + part.shape[1]])

        list(run(small, range(0, height, step)))
        return out
    stack = np.empty((len(idx), rows, *first.shape[1:]), dtype=np.float32)
    for r0 in range(0, height, rows):
        part = stack[:, : min(rows, height - r0)]

        def put(k: int, r0: int = r0, part: np.ndarray = part) -> None:
            part[k] = load(k)[r0 : r0 + part.shape[1]]

        list(run(put, range(len(idx))))
        step = part.shape[1] if executor is None else max(1, -(-part.shape[1] // 16))

        def band(b0: int, r0: int = r0, part: np.ndarray = part, step: int = step) -> None:
            _median_rows(part[:, b0 : b0 + step], out[r0 + b0 : r0 + b0 + step])

        list(run(band, range(0, part.shape[1], step)))
    return out


def _median_rows(part: np.ndarray, dest: np.ndarray) -> None:
    """``dest[...] = np.median(part, axis=0)`` (bit for bit) of a float32 stack ``(n, rows, W,
    C)``, each of its ``n`` rows contiguous, into ``dest``: rows of the C-contiguous median."""
    from dynaeval.regions.motion_kernels import median_network, median_of_stack

    median_of_stack(part.reshape(part.shape[0], -1), dest.reshape(-1),
                    median_network(part.shape[0]))


def isg_weight(frame: np.ndarray, median: np.ndarray, gamma: float = 2e-2) -> np.ndarray:
    """ISG weight ``(H, W)`` float32 in [0, 1) of one ``(H, W, C)`` float frame vs the median."""
    d2 = np.subtract(frame, median, dtype=np.float32)
    np.square(d2, out=d2)
    np.divide(d2, d2 + np.float32(gamma) ** 2, out=d2)
    return _channel_mean(d2)


def _channel_mean(x: np.ndarray) -> np.ndarray:
    """Mean over the last axis of ``(H, W, C)`` float32, as C contiguous adds (faster than
    ``mean(axis=-1)`` over a short strided axis)."""
    out = x[..., 0].copy()
    for c in range(1, x.shape[-1]):
        out += x[..., c]
    out /= np.float32(x.shape[-1])
    return out


def _iter_isg(frames: object, gamma: float, median_frames: int) -> Iterator[np.ndarray]:
    seq = _as_sequence(frames)
    median = temporal_median(seq, median_frames)
    for t in range(len(seq)):
        yield isg_weight(_frame(seq[t], t, median.shape), median, gamma)


def _iter_ist(frames: Iterable, window: int, alpha: float) -> Iterator[np.ndarray]:
    it = enumerate(iter(frames))
    buf: deque[tuple[int, np.ndarray]] = deque()
    shape: tuple[int, ...] | None = None
    exhausted = False
    t = 0
    while True:
        while not exhausted and (not buf or buf[-1][0] < t + window):
            try:
                i, f = next(it)
            except StopIteration:
                exhausted = True
                break
            arr = _frame(f, i, shape)
            shape = arr.shape
            buf.append((i, arr))
        while buf and buf[0][0] < t - window:
            buf.popleft()
        if not buf or buf[-1][0] < t:
            if t == 0:
                raise InputError("no frames: IST weights need at least one frame")
            return
        cur = buf[t - buf[0][0]][1]
        diff = np.zeros_like(cur)
        tmp = np.empty_like(cur)
        for j, other in buf:
            if j != t:
                np.subtract(other, cur, out=tmp)
                np.abs(tmp, out=tmp)
                np.maximum(diff, tmp, out=diff)
        yield np.maximum(_channel_mean(diff), np.float32(alpha))
        t += 1


def iter_importance_weights(
    frames: object,
    kind: str = "isg",
    *,
    gamma: float = 2e-2,
    window: int = 25,
    alpha: float = 0.1,
    median_frames: int = 64,
) -> Iterator[np.ndarray]:
    """Yield one ``(H, W)`` float32 weight map per frame (ISG in [0, 1), IST in [alpha, 1]).

    ``frames``: ``(T, H, W, C)`` array or lazy sequence of ``(H, W, C)`` frames (uint8 or float in
    [0, 1]) from one static camera; IST also takes any iterable. See the module docstring.
    """
    if kind == "isg":
        return _iter_isg(_as_sequence(frames), gamma, median_frames)
    if kind == "ist":
        return _iter_ist(frames, window, alpha)
    raise InputError(f"importance weight kind must be 'isg' or 'ist', got {kind!r}")


def importance_weights(
    frames: object,
    kind: str = "isg",
    *,
    gamma: float = 2e-2,
    window: int = 25,
    alpha: float = 0.1,
    median_frames: int = 64,
) -> np.ndarray:
    """``(T, H, W)`` float32 per-pixel weights (unnormalised) for ray importance sampling.

    Same arguments as ``iter_importance_weights``; the one implementation behind motion masks too.
    """
    maps = list(
        iter_importance_weights(frames, kind, gamma=gamma, window=window, alpha=alpha, median_frames=median_frames)
    )
    return np.stack(maps)


def _disk(radius: int) -> np.ndarray:
    import cv2

    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def _morph(mask: np.ndarray, op: int, radius: int) -> np.ndarray:
    """``cv2.morphologyEx`` on a uint8 mask padded by edge replication, then cropped back.

    Without the padding OpenCV treats pixels outside the image as neutral for *each* step, so a
    closing grows any object lying within ``radius`` px of the border out to the border.
    """
    import cv2

    padded = np.pad(mask, radius, mode="edge")
    return cv2.morphologyEx(padded, op, _disk(radius))[radius:-radius, radius:-radius]


def remove_small_components(mask: np.ndarray, min_area: int) -> np.ndarray:
    """``(H, W)`` bool mask without its 8-connected components of fewer than ``min_area`` pixels."""
    import cv2

    m = np.asarray(mask, dtype=bool)
    if min_area <= 1 or not m.any():
        return m.copy()
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area
    keep[0] = False  # background
    return keep[labels]


def clean_mask(mask: np.ndarray, config: MotionConfig | None = None) -> np.ndarray:
    """Opening, closing, small-component removal, dilation of a ``(H, W)`` bool mask (config radii)."""
    import cv2

    cfg = config or MotionConfig()
    m = np.asarray(mask, dtype=bool).astype(np.uint8)
    if cfg.open_radius:
        m = _morph(m, cv2.MORPH_OPEN, cfg.open_radius)
    if cfg.close_radius:
        m = _morph(m, cv2.MORPH_CLOSE, cfg.close_radius)
    out = remove_small_components(m.astype(bool), cfg.min_area)
    if cfg.dilate_radius:
        out = cv2.dilate(out.astype(np.uint8), _disk(cfg.dilate_radius)).astype(bool)
    return out


def iter_motion_masks(
    frames: object, config: MotionConfig | None = None, executor: Executor | None = None
) -> Iterator[np.ndarray]:
    """Yield one cleaned ``(H, W)`` bool motion mask per frame (bounded memory; see module doc).

    ``executor``: a ``concurrent.futures`` executor (threads) for ISG, whose frames are
    independent once the median is known: each frame is loaded, weighted, thresholded and
    cleaned on it, in order; the masks equal the sequential ones. IST ignores it (sliding window).
    """
    cfg = config or MotionConfig()
    thr = np.float32(cfg.effective_threshold)
    if executor is not None and cfg.kind == "isg":
        seq = _as_sequence(frames)
        median = temporal_median(seq, cfg.median_frames, executor)

        def one(t: int) -> np.ndarray:
            w = isg_weight(_frame(seq[t], t, median.shape), median, cfg.gamma)
            return clean_mask(w > thr, cfg)

        yield from executor.map(one, range(len(seq)))
        return
    weights = iter_importance_weights(
        frames, cfg.kind, gamma=cfg.gamma, window=cfg.window, alpha=cfg.alpha, median_frames=cfg.median_frames
    )
    for w in weights:
        yield clean_mask(w > thr, cfg)


def motion_mask(frames: object, config: MotionConfig | None = None) -> np.ndarray:
    """``(T, H, W)`` bool: True where a pixel of a static camera's frame moves.

    ``frames``: ``(T, H, W, C)`` array or lazy sequence of frames (uint8, or float in [0, 1]).
    """
    return np.stack(list(iter_motion_masks(frames, config)))


def mask_boxes(mask: np.ndarray, min_area: int = 1) -> np.ndarray:
    """Boxes ``(N, 4)`` int64 (max exclusive) of the 8-connected components of a ``(H, W)`` mask.

    Components with fewer than ``min_area`` pixels are skipped; order is OpenCV's label order
    (raster order of each component's first pixel).
    """
    import cv2

    m = np.asarray(mask)
    if m.ndim != 2:
        raise InputError(f"mask_boxes takes one (H, W) mask, got shape {m.shape}")
    if not m.any():
        return np.zeros((0, 4), dtype=np.int64)
    _, _, stats, _ = cv2.connectedComponentsWithStats(m.astype(bool).astype(np.uint8), connectivity=8)
    stats = stats[1:]
    stats = stats[stats[:, cv2.CC_STAT_AREA] >= max(min_area, 1)]
    x, y = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    w, h = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    return np.stack([x, y, x + w, y + h], axis=1).astype(np.int64)

"""Optical flow, backward warping and occlusion masks for the temporal metrics.

Conventions used throughout (and by ``dynaeval.metrics.temporal``):

* A **flow** ``a -> b`` is an ``(H, W, 2)`` float32 array in pixels, channel 0 = ``dx`` (to the
  right), channel 1 = ``dy`` (down), on the grid of ``a``, such that ``a(p) ~ b(p + flow(p))``.
  A scene translating by ``(+3, -2)`` px from ``a`` to ``b`` gives ``flow ~ (3, -2)``.
* **Backward warping** brings ``b`` onto ``a``'s grid with the flow ``a -> b``:
  ``warp(b, flow_ab)(p) = b(p + flow_ab(p))`` (bilinear).
* Images are ``(H, W, 3)`` RGB or ``(H, W)`` gray, float in ``[0, 1]`` or uint8 in ``[0, 255]``
  (checked by ``dynaeval.core.validation.as_image``: uint8 / 255, uint16 / 65535, float32 out).

OpenCV (``cv2``, opencv-contrib for TV-L1) is imported lazily inside the functions that use it.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import astuple, dataclass
from pathlib import Path

import numpy as np

from dynaeval.core.errors import InputError, UndefinedMetricError
from dynaeval.core.runtime import check_opencv, has_tvl1
from dynaeval.core.validation import as_image

FLOW_METHODS = ("dis", "farneback", "tvl1")
DIS_PRESETS = ("ultrafast", "fast", "medium")

# ITU-R BT.601 luma weights, the ones cv2.COLOR_RGB2GRAY uses.
_LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)


@dataclass(frozen=True)
class FlowConfig:
    """How optical flow is estimated. Frozen: it is part of every cache key."""

    method: str = "dis"
    """``"dis"`` (OpenCV DIS, Kroeger et al. 2016, default), ``"farneback"`` (Farneback 2003,
    the estimator TecoGAN's tOF uses) or ``"tvl1"`` (Zach et al. 2007 dual TV-L1, opencv-contrib,
    about 100x slower than DIS)."""

    dis_preset: str = "medium"
    """DIS preset: ``"ultrafast"``, ``"fast"`` or ``"medium"`` (``cv2.DISOPTICAL_FLOW_PRESET_*``).
    ``medium`` is the most accurate of the three; see docs/temporal-metrics.md for its endpoint
    error and speed."""

    farneback_pyr_scale: float = 0.5
    """Farneback: image scale between pyramid levels (TecoGAN: 0.5)."""

    farneback_levels: int = 3
    """Farneback: number of pyramid levels (TecoGAN: 3)."""

    farneback_winsize: int = 15
    """Farneback: averaging window in pixels (TecoGAN: 15)."""

    farneback_iterations: int = 3
    """Farneback: iterations per level (TecoGAN: 3)."""

    farneback_poly_n: int = 5
    """Farneback: pixel neighbourhood of the polynomial expansion (TecoGAN: 5)."""

    farneback_poly_sigma: float = 1.2
    """Farneback: Gaussian sigma of the polynomial expansion (TecoGAN: 1.2)."""

    def __post_init__(self) -> None:
        if self.method not in FLOW_METHODS:
            raise InputError(
                f"flow method must be one of {FLOW_METHODS}, got {self.method!r}; "
                "use 'dis' unless you need to reproduce another paper's numbers"
            )
        if self.dis_preset not in DIS_PRESETS:
            raise InputError(f"DIS preset must be one of {DIS_PRESETS}, got {self.dis_preset!r}")

    def describe(self) -> dict:
        """The settings that change a number, for the results JSON."""
        if self.method == "dis":
            return {"method": "dis", "dis_preset": self.dis_preset}
        if self.method == "farneback":
            return {
                "method": "farneback",
                "pyr_scale": self.farneback_pyr_scale,
                "levels": self.farneback_levels,
                "winsize": self.farneback_winsize,
                "iterations": self.farneback_iterations,
                "poly_n": self.farneback_poly_n,
                "poly_sigma": self.farneback_poly_sigma,
            }
        return {
            "method": "tvl1",
            "params": "OpenCV defaults (cv2.optflow.DualTVL1OpticalFlow_create())",
        }


def to_gray_u8(image: np.ndarray) -> np.ndarray:
    """Gray uint8 ``(H, W)`` for the flow estimators, from RGB/gray, float ``[0, 1]`` or uint8.

    Luma ``0.299 R + 0.587 G + 0.114 B`` (BT.601, as ``cv2.COLOR_RGB2GRAY``) computed in float32
    on values in ``[0, 1]`` (uint8 is divided by 255 first, so uint8 and ``uint8 / 255`` floats give
    the same gray image), then ``round(255 * luma)`` clipped to ``[0, 255]``. Values outside
    ``[0, 1]`` are clipped here only (for the flow), never in the metrics themselves. A single
    channel is used as is; a 4th (alpha) channel is ignored.
    """
    return gray_of_checked(as_image(image))


def gray_of_checked(arr: np.ndarray) -> np.ndarray:
    """:func:`to_gray_u8` of a frame already checked by ``as_image`` (float32, ``(H, W[, C])``):
    the conversion without the check, for frames validated once upstream."""
    from dynaeval.metrics.flow_kernels import gray_u8

    if arr.ndim == 3:
        if arr.shape[2] == 1:
            arr = arr[..., 0]
        elif arr.shape[2] in (3, 4):
            arr = arr[..., :3] @ _LUMA
        else:
            raise InputError(f"image must have 1, 3 or 4 channels, got {arr.shape[2]}")
    if arr.dtype != np.float32:  # float64 (the luma of float64 frames): numpy's steps
        return np.clip(np.rint(arr * 255.0), 0, 255).astype(np.uint8)
    out = np.empty(arr.shape, np.uint8)
    gray_u8(arr, out)  # np.clip(np.rint(arr * 255.0), 0, 255).astype(np.uint8) in one loop
    return out


MIN_FLOW_SIZE = 16
"""Smallest frame side (pixels) the optical flow accepts: OpenCV's estimators raise or crash
(a segmentation fault, e.g. DIS on 8x100) on smaller frames."""


def check_flow_size(shape: tuple[int, ...]) -> None:
    """Raise ``UndefinedMetricError`` when a frame of ``shape`` is too small for optical flow."""
    if min(shape[:2]) < MIN_FLOW_SIZE:
        raise UndefinedMetricError(
            f"optical flow needs frames of at least {MIN_FLOW_SIZE}x{MIN_FLOW_SIZE} pixels, got "
            f"{shape[1]}x{shape[0]}")


def flow_from_gray(a: np.ndarray, b: np.ndarray, config: FlowConfig) -> np.ndarray:
    """Forward optical flow ``a -> b`` of two gray frames as the estimators take them: ``a``,
    ``b`` ``(H, W)`` uint8 of one size (``to_gray_u8`` / ``gray_of_checked``); returns ``(H, W,
    2)`` float32 ``(dx, dy)`` in pixels on ``a``'s grid. The one estimator call of every flow
    (``optical_flow``, the flow cache, ``dynaeval prepare``).

    Raises:
        UndefinedMetricError: frames smaller than ``MIN_FLOW_SIZE`` on a side.
    """
    import cv2

    check_flow_size(a.shape)  # every estimator goes through here: never hand OpenCV a tiny frame

    if config.method == "dis":
        preset = {
            "ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
            "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
            "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
        }[config.dis_preset]
        flow = cv2.DISOpticalFlow_create(preset).calc(a, b, None)
    elif config.method == "farneback":
        flow = cv2.calcOpticalFlowFarneback(
            a,
            b,
            None,
            config.farneback_pyr_scale,
            config.farneback_levels,
            config.farneback_winsize,
            config.farneback_iterations,
            config.farneback_poly_n,
            config.farneback_poly_sigma,
            0,
        )
    else:
        if not has_tvl1(cv2):
            check_opencv(needs_tvl1=True)  # raises, naming the installed builds and the repair
        flow = cv2.optflow.DualTVL1OpticalFlow_create().calc(a, b, None)
    return np.ascontiguousarray(flow, dtype=np.float32)


def optical_flow(a: np.ndarray, b: np.ndarray, config: FlowConfig | None = None) -> np.ndarray:
    """Forward optical flow ``a -> b``: ``(H, W, 2)`` float32, pixels, ``(dx, dy)`` on ``a``'s grid.

    ``a(p) ~ b(p + flow(p))``. ``a``, ``b``: ``(H, W, 3)`` RGB or ``(H, W)`` gray, float in
    ``[0, 1]`` or uint8, same height and width; converted with :func:`to_gray_u8` (all three
    OpenCV estimators run on 8-bit gray). Deterministic for a given input and config.
    """
    config = config or FlowConfig()
    ga, gb = to_gray_u8(a), to_gray_u8(b)
    if ga.shape != gb.shape:
        raise InputError(f"flow needs two frames of one size, got {ga.shape} and {gb.shape}")
    return flow_from_gray(ga, gb, config)


def gray_digest(gray: np.ndarray) -> bytes:
    """20-byte blake2b digest of a gray uint8 frame's pixels (its part of a flow-cache key)."""
    return hashlib.blake2b(np.ascontiguousarray(gray).data, digest_size=20).digest()


class FlowCache:
    """Flows keyed on the *content* of both frames and the flow settings, computed once.

    The key is ``(blake2b(gray a), blake2b(gray b), FlowConfig)``, so a ground-truth pair's flows
    are reused when several methods are scored against the same ground truth, and a prediction
    identical to its ground truth gets the very same flow array (which is what makes the ground
    truth score exactly 0 against itself). Camera and frame names are not needed for correctness;
    pass ``tag`` only if you want it in the ``stats``.

    Memory: a flow is ``8 * H * W`` bytes (16.6 MB at 1920x1080, 4.1 MB at 960x540). The
    in-memory part is an LRU bounded by ``max_bytes``; with ``directory`` set, every flow is also
    written there as ``<key>.npy`` and read back on a later miss (unbounded: you choose the disk).
    ``known`` maps keys to ``.npy`` files of flows computed beforehand (a prepared ground truth,
    ``dynaeval prepare``): read on a miss with ``load_known`` (default: memory-mapped
    ``numpy.load``; a prepared ground truth checks the file's digest first), never written.
    Thread-safe: flows are computed outside the lock, so threads computing different pairs run
    in parallel (two threads asking for one new pair may both compute it; the numbers agree).
    """

    def __init__(self, max_bytes: int = 1 << 30, directory: str | Path | None = None,
                 known: dict[str, Path] | None = None,
                 load_known: Callable[[Path], np.ndarray] | None = None) -> None:
        if max_bytes < 0:
            raise InputError(f"FlowCache max_bytes must be >= 0, got {max_bytes}")
        self.max_bytes = int(max_bytes)
        self.directory = None if directory is None else Path(directory)
        if self.directory is not None:
            self.directory.mkdir(parents=True, exist_ok=True)
        self.known = dict(known or {})
        self._load_known = load_known or (lambda p: np.load(p, mmap_mode="r"))
        self._items: OrderedDict[str, np.ndarray] = OrderedDict()
        self._lock = threading.Lock()
        self._bytes = 0
        self.hits = 0
        self.misses = 0

    @staticmethod
    def key(gray_a: np.ndarray, gray_b: np.ndarray, config: FlowConfig,
            digests: tuple[bytes, bytes] | None = None) -> str:
        """Content key of a gray uint8 pair and a flow config (hex string): a hash of the shape,
        of each frame's :func:`gray_digest` (``digests``, when the caller has them already: a
        frame is hashed once, not once per flow it is in) and of the config."""
        da, db = digests if digests is not None else (gray_digest(gray_a), gray_digest(gray_b))
        h = hashlib.blake2b(digest_size=20)
        h.update(repr(gray_a.shape).encode())
        h.update(da)
        h.update(db)
        h.update(repr(astuple(config)).encode())
        return h.hexdigest()

    def flow(self, a: np.ndarray, b: np.ndarray, config: FlowConfig | None = None) -> np.ndarray:
        """:func:`optical_flow` ``a -> b``, from the cache when the same pair was seen before.

        The returned array is read-only (it may be shared with later callers).
        """
        return self.flow_gray(to_gray_u8(a), to_gray_u8(b), config or FlowConfig())

    def flow_gray(self, ga: np.ndarray, gb: np.ndarray, config: FlowConfig,
                  digests: tuple[bytes, bytes] | None = None) -> np.ndarray:
        """:meth:`flow` of two frames already converted by :func:`to_gray_u8` (``(H, W)`` uint8),
        with their :func:`gray_digest` when known (read-only result)."""
        if ga.shape != gb.shape:
            raise InputError(f"flow needs two frames of one size, got {ga.shape} and {gb.shape}")
        k = self.key(ga, gb, config, digests)
        with self._lock:
            if k in self._items:
                self._items.move_to_end(k)
                self.hits += 1
                return self._items[k]
        path = None if self.directory is None else self.directory / f"{k}.npy"
        if k in self.known:  # a prepared flow: read (a missing or changed file is refused)
            flow = self._load_known(self.known[k])  # mapped from the page cache, not copied
            hit = True
        elif path is not None and path.exists():
            flow = np.load(path, mmap_mode="r")
            hit = True
        else:
            flow = flow_from_gray(ga, gb, config)
            hit = False
            if path is not None:
                tmp = path.with_name(f"{k}.{threading.get_ident()}.tmp.npy")
                np.save(tmp, flow)
                tmp.replace(path)
        flow.setflags(write=False)
        with self._lock:
            if hit:
                self.hits += 1
            else:
                self.misses += 1
            if k in self._items:  # another thread computed it meanwhile: share one array
                return self._items[k]
            self._put(k, flow)
        return flow

    def _put(self, k: str, flow: np.ndarray) -> None:
        if flow.nbytes > self.max_bytes:
            return
        self._items[k] = flow
        self._bytes += flow.nbytes
        while self._bytes > self.max_bytes:
            _, old = self._items.popitem(last=False)
            self._bytes -= old.nbytes

    def __len__(self) -> int:
        return len(self._items)


def check_flow(flow: np.ndarray, name: str = "flow") -> np.ndarray:
    """Return ``flow`` as float32 ``(H, W, 2)``; InputError for another shape or NaN/Inf."""
    arr = np.asarray(flow)
    if arr.ndim != 3 or arr.shape[2] != 2:
        raise InputError(f"{name} must have shape (H, W, 2) as (dx, dy) in pixels, got {arr.shape}")
    arr = arr.astype(np.float32, copy=False)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains NaN or Inf values")
    return arr


def _sample_grid(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(xs, ys)``: ``p + flow(p)``, two ``(H, W)`` float32 arrays (x, then y), for ``cv2.remap``."""
    h, w = flow.shape[:2]
    xs = np.arange(w, dtype=np.float32)[None, :] + flow[..., 0]
    ys = np.arange(h, dtype=np.float32)[:, None] + flow[..., 1]
    return xs, ys


def warp(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Backward warp: ``out(p) = image(p + flow(p))``, bilinear (``cv2.remap``, ``INTER_LINEAR``).

    ``image``: ``(H, W)`` or ``(H, W, C)`` float (any range; uint8 is divided by 255), ``C <= 4``.
    ``flow``: ``(H, W, 2)`` float32 ``(dx, dy)`` px, on the grid of the output. To bring frame
    ``s`` onto frame ``t``'s grid, pass the flow ``t -> s``. Samples that fall outside the image
    take the nearest border pixel (``BORDER_REPLICATE``); :func:`valid_warp_mask` marks them
    invalid, so they never enter a metric. Returns float32 with the shape of ``image``.
    """
    img = as_image(image)
    flow = check_flow(flow)
    if img.shape[:2] != flow.shape[:2]:
        raise InputError(
            f"warp needs image and flow of one size, got {img.shape[:2]} and {flow.shape[:2]}"
        )
    if img.ndim == 3 and img.shape[2] > 4:
        raise InputError(f"warp handles at most 4 channels, got {img.shape[2]}")
    return warp_on_grid(img, *_sample_grid(flow))


def warp_on_grid(img: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """:func:`warp` of a checked float32 ``img`` on the sample grid ``(xs, ys)`` of its flow
    (``(H, W)`` float32 each, from :func:`visibility`), unchecked: one grid serves several images."""
    import cv2

    out = cv2.remap(img, xs, ys, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(img.shape)


def warp_reference(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Slow, readable numpy version of :func:`warp` (the test holds them together)."""
    img = as_image(image)
    flow = check_flow(flow)
    h, w = flow.shape[:2]
    xs, ys = _sample_grid(flow)
    xs = np.clip(xs.astype(np.float64), 0, w - 1)
    ys = np.clip(ys.astype(np.float64), 0, h - 1)
    x0 = np.clip(np.floor(xs).astype(np.int64), 0, max(w - 2, 0))
    y0 = np.clip(np.floor(ys).astype(np.int64), 0, max(h - 2, 0))
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = xs - x0, ys - y0
    if img.ndim == 3:
        fx, fy = fx[..., None], fy[..., None]
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


def in_frame_mask(flow: np.ndarray) -> np.ndarray:
    """``(H, W)`` bool: ``p + flow(p)`` lies inside ``[0, W-1] x [0, H-1]`` (no border sample)."""
    flow = check_flow(flow)
    h, w = flow.shape[:2]
    return _in_frame(*_sample_grid(flow))


def _in_frame(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    h, w = xs.shape
    return (xs >= 0) & (xs <= w - 1) & (ys >= 0) & (ys <= h - 1)


def valid_warp_mask(flow_ts: np.ndarray, flow_st: np.ndarray) -> np.ndarray:
    """Pixels of frame ``t`` that are visible in frame ``s``: ``(H, W)`` bool on ``t``'s grid.

    ``flow_ts``: flow ``t -> s`` (the one that backward-warps ``s`` onto ``t``); ``flow_st``: flow
    ``s -> t``. Forward-backward consistency (Sundaram, Brox & Keutzer, ECCV 2010, eq. 5; the
    rule Lai et al. 2018 and Ruder et al. 2016 use): with ``f = flow_ts(p)`` and
    ``g = flow_st(p + f)`` (bilinear), ``p`` is kept when

        ``|f + g|^2 < 0.01 (|f|^2 + |g|^2) + 0.5``

    and ``p + f`` lies inside the frame (:func:`in_frame_mask`). Sundaram et al.'s second test
    (motion boundaries) is not applied.
    """
    flow_ts = check_flow(flow_ts, "flow_ts")
    flow_st = check_flow(flow_st, "flow_st")
    if flow_ts.shape != flow_st.shape:
        raise InputError(
            f"the two flows must have one shape, got {flow_ts.shape} and {flow_st.shape}"
        )
    return visibility(flow_ts, flow_st)[0]


def visibility(flow_ts: np.ndarray, flow_st: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(valid, xs, ys)``: :func:`valid_warp_mask` of two checked flows and the sample grid of
    ``flow_ts`` it was found with (:func:`warp_on_grid` reuses it to warp frame ``s`` onto ``t``).

    The grid, the in-frame test and the forward-backward test are single compiled loops
    (``flow_kernels``) with the float32 operations of ``_sample_grid``, ``_in_frame`` and
    ``np.sum(v ** 2, axis=-1)`` in their order: the same bits (tested against
    :func:`visibility_reference`).
    """
    from dynaeval.metrics.flow_kernels import consistent

    xs, ys, valid = _grid_and_inside(flow_ts)
    consistent(flow_ts, warp_on_grid(flow_st, xs, ys), valid)
    return valid, xs, ys


def sample_grid_of(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(xs, ys)`` of a checked ``(H, W, 2)`` float32 flow: the sample grid :func:`visibility`
    returns with its mask (the same compiled loop, the same bits), for a mask computed
    beforehand (``dynaeval prepare``)."""
    xs, ys, _ = _grid_and_inside(flow)
    return xs, ys


def _grid_and_inside(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(xs, ys, inside)`` of a checked ``(H, W, 2)`` float32 flow, one compiled loop
    (``flow_kernels.sample_grid``): the grid ``p + flow(p)``, ``(H, W)`` float32 each, and
    ``(H, W)`` bool, the sample lies in the frame."""
    from dynaeval.metrics.flow_kernels import sample_grid

    h, w = flow.shape[:2]
    xs, ys = np.empty((h, w), np.float32), np.empty((h, w), np.float32)
    inside = np.empty((h, w), bool)
    sample_grid(flow, xs, ys, inside)
    return xs, ys, inside


def visibility_reference(flow_ts: np.ndarray,
                         flow_st: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`visibility` in numpy steps, band by band of rows (what it was before its compiled
    loops; the test holds them together)."""
    xs, ys = _sample_grid(flow_ts)
    g = warp_on_grid(flow_st, xs, ys)
    valid = _in_frame(xs, ys)
    for r0 in range(0, valid.shape[0], BAND_ROWS):
        b = slice(r0, r0 + BAND_ROWS)
        f, gb = flow_ts[b], g[b]
        s = f + gb
        lhs = sq_sum(s[..., 0], s[..., 1])
        rhs = sq_sum(f[..., 0], f[..., 1])
        rhs += sq_sum(gb[..., 0], gb[..., 1])
        rhs *= np.float32(0.01)
        rhs += np.float32(0.5)
        valid[b] &= lhs < rhs
    return valid, xs, ys


BAND_ROWS = 64
"""Rows per band of the plane-wise flow arithmetic (:func:`visibility_reference`)."""


def sq_sum(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``x^2 + y^2`` (a new array; ``x`` and ``y`` untouched)."""
    out = np.square(x)
    out += np.square(y)
    return out

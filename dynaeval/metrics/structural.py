"""SSIM exactly as Wang et al. 2004 (the scikit-image Gaussian variant), whole image, masked, focused.

Definition (per channel, data scaled to L = data_range):

* window: separable Gaussian, sigma 1.5, truncated at 3.5 sigma -> 11 taps (radius r = 5),
  weights normalised to sum 1;
* ``mu_x = w * x``, ``sigma_x^2 = w * x^2 - mu_x^2`` (population covariance), same for y,
  ``sigma_xy = w * (x y) - mu_x mu_y``;
* ``S = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 + C2))``
  with ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2``;
* the score is the mean of S over the *valid* windows (those entirely inside the image: the
  r-pixel border is skipped, as scikit-image crops it) and then over channels.

The fast path (``ssim``/``ssim_map``) filters float32 data centred at 0.5 (``x / L - 0.5``; the
variances are shift invariant and the centring halves the magnitude of ``w * x^2``, cutting the
cancellation in ``w * x^2 - mu^2``) with OpenCV's separable filter, band by band of rows in
reused buffers, combines the moments in one compiled loop (``structural_kernels``), and reduces
in float64 (optionally over ``threads`` threads; same numbers).
``ssim_reference`` is the slow, readable float64 version the tests hold it to.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, NamedTuple

import numpy as np

from dynaeval.core.boxes import grow_box
from dynaeval.core.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.core.validation import check_data_range, check_pair
from dynaeval.metrics._common import WholeOrRegion, clipped_boxes, region_mask

SIGMA = 1.5
"""Standard deviation of the Gaussian window in pixels."""
TRUNCATE = 3.5
"""The window is cut at TRUNCATE * SIGMA (scikit-image/scipy convention) -> 11 taps."""
RADIUS = int(TRUNCATE * SIGMA + 0.5)
"""Window radius r = 5 pixels; the window is 2r + 1 = 11 taps."""
WIN_SIZE = 2 * RADIUS + 1
K1 = 0.01
K2 = 0.03
REGION_MODES = ("crop", "map")
_C1 = np.float32(K1 * K1)
_C2 = np.float32(K2 * K2)


def gaussian_window(sigma: float = SIGMA, truncate: float = TRUNCATE) -> np.ndarray:
    """1-D Gaussian weights, (2r+1,) float64 summing to 1, r = int(truncate * sigma + 0.5)."""
    r = int(truncate * sigma + 0.5)
    x = np.arange(-r, r + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return k / k.sum()


def _check_size(h: int, w: int) -> None:
    if h < WIN_SIZE or w < WIN_SIZE:
        raise UndefinedMetricError(
            f"SSIM needs images of at least {WIN_SIZE}x{WIN_SIZE} pixels (its Gaussian window, "
            f"sigma {SIGMA}, has {WIN_SIZE} taps); got {h}x{w} (HxW): SSIM is undefined for this "
            "image (dynaeval.score records null; PSNR has no minimum size)"
        )


BAND_ROWS = 96
"""Output rows per band (a multiple of ``SUM_ROWS``); each band is computed tile after tile."""
SUM_ROWS = 32
"""Output rows per float64 partial sum of the whole-image SSIM: fixed, so the sum does not depend
on the band or tile sizes (the partition the results have always been summed in)."""
TILE_VALUES = 600
"""Values per row of a tile (pixels x channels, the 2r halo columns included): a band's tile of
``BAND_ROWS + 2r`` rows then keeps its six float32 buffers (~1.5 MB) in the core's L2 cache from
the first elementwise step to the last (measured: the band-wide buffers of before streamed from
L3 at every step)."""


def _kernel() -> np.ndarray:
    """The 11-tap window as float32 for OpenCV (a test holds it to ``gaussian_window()``)."""
    return gaussian_window().astype(np.float32)


class _Workspace:
    """Float32 buffers for one band, reused band after band.

    ``x, y, d, xy`` hold a tile's centred data and products and are filtered in place into its
    moments; ``q`` collects the band's SSIM, all columns.
    Fresh temporaries on every band are page-faulted in again and again (measured: ~15 % of the
    SSIM time at 1080p); one workspace per thread keeps them warm.
    """

    def __init__(self, rows_in: int, width: int, channels: int) -> None:
        self.channels = channels
        self.kernel = _kernel()
        self.tiles = _tiles(width, channels)
        tile_shape = (rows_in, max(t1 - t0 for t0, t1 in self.tiles) * channels)
        self.x, self.y, self.d, self.xy = (np.empty(tile_shape, np.float32) for _ in range(4))
        self.q = np.empty((rows_in - 2 * RADIUS, width * channels), np.float32)


SIMD_SPAN = 64
"""Values that any SIMD width OpenCV uses divides (4 to 16 float32 lanes, unrolled)."""


def _tiles(width: int, channels: int) -> list[tuple[int, int]]:
    """Input pixel columns [t0, t1) of the tiles of a band ``width`` pixels wide; tile k's output
    columns are [t0 + r, t1 - r) and the tiles together cover the W - 2r valid ones.

    OpenCV runs an elementwise step on a row with SIMD and the row's last values (its length
    modulo the SIMD width) with scalar code, which rounds differently (``addWeighted`` fuses a
    multiply-add only in SIMD). So every tile is a multiple of ``SIMD_SPAN`` values wide: no
    value is rounded the scalar way, whatever the tiling (for 3-channel images none was in the
    previous code either, which ran 8 whole rows at a time; docs/performance.md has the one
    case that changed, grey images of some widths). The last tile ends at the image's edge and
    may overlap the one before it (it is written after it; overlapping columns are the same
    values). A row narrower than ``SIMD_SPAN`` values is one tile.
    """
    span = _simd_span(channels)
    if width < span:
        return [(0, width)]
    size = min(max(1, TILE_VALUES // channels // span) * span, width // span * span)
    tiles, start = [], 0
    while start + size < width:
        tiles.append((start, start + size))
        start += size - 2 * RADIUS
    last = min(size, -(-(width - start) // span) * span)  # covers [start, width)
    return tiles + [(width - last, width)]


def _simd_span(channels: int) -> int:
    """Pixels of the narrowest SIMD-clean tile: a whole number of ``SIMD_SPAN`` values that holds
    at least one window."""
    span = SIMD_SPAN // math.gcd(SIMD_SPAN, channels)  # pixels per SIMD-clean step
    return span * -(-WIN_SIZE // span)


_WORKSPACES = threading.local()


def _workspace(rows_in: int, width: int, channels: int) -> _Workspace:
    """A workspace for bands of this size: this thread's, kept from one image to the next when it
    is large (the frames of a run share one size: their buffers are not paged in again per
    image); small ones (crops) are cheap to make afresh."""
    key = (rows_in, width, channels)
    if width * channels < 2048:
        return _Workspace(*key)
    kept: dict = _WORKSPACES.__dict__.setdefault("kept", {})
    if key not in kept:
        if len(kept) >= 2:
            kept.pop(next(iter(kept)))
        kept[key] = _Workspace(*key)
    return kept[key]


def _band(xb: np.ndarray, yb: np.ndarray, inv: float, ws: _Workspace) -> np.ndarray:
    """Per-channel SSIM of the windows centred in one band of rows, all columns.

    Args:
        xb, yb: (rows + 2r, W * C) float32/float64 rows of pred and gt (channels interleaved).
        inv: 1 / data_range.
        ws: buffers at least as large as the band.

    Returns:
        (rows, W * C) float32 view into ``ws.q``; the r border columns of each side (r * C
        values) are not valid windows and must be dropped by the caller.

    The band is done in the tiles of ``_tiles`` (their input: r more columns each side than they
    output); every value depends only on its own window, so the tiling changes no bit (tested).
    Fused moments: 4 filtered images instead of 5, data centred at 0.5 (``x = p / L - 0.5``), and
    with ``d = x - y``: ``mu_x^2 + mu_y^2 = 2 mu_x mu_y + (mu_x - mu_y)^2`` and
    ``sigma_x^2 + sigma_y^2 = 2 sigma_xy + var(d)``, ``var(d) = w * d^2 - (w * d)^2``. The
    products and the SSIM of the windows are single compiled loops
    (``dynaeval.metrics.structural_kernels``), the centring one OpenCV ``addWeighted`` per input,
    all writing into the workspace.
    """
    import cv2

    from dynaeval.metrics.structural_kernels import products, ssim_windows

    n = xb.shape[0]
    rows = n - 2 * RADIUS
    c = ws.channels
    for t0, t1 in ws.tiles:  # input pixel columns [t0, t1), output [t0 + r, t1 - r)
        cols = slice(t0 * c, t1 * c)
        m = cols.stop - cols.start
        x, y, d, xy = (b[:n, :m] for b in (ws.x, ws.y, ws.d, ws.xy))
        cv2.addWeighted(xb[:, cols], inv, xb[:, cols], 0.0, -0.5, dst=x, dtype=cv2.CV_32F)
        cv2.addWeighted(yb[:, cols], inv, yb[:, cols], 0.0, -0.5, dst=y, dtype=cv2.CV_32F)
        products(ws.x, ws.y, ws.d, ws.xy, n, m)
        for buf in (x, y, xy, d):  # in place: separable, 11 taps; the reflected border only
            cv2.sepFilter2D(  # reaches rows and columns dropped below
                buf.reshape(n, -1, c), cv2.CV_32F, ws.kernel, ws.kernel,
                dst=buf.reshape(n, -1, c), borderType=cv2.BORDER_REFLECT,
            )
        ssim_windows(ws.x, ws.y, ws.xy, ws.d, ws.q, rows, m, RADIUS, c, (t0 + RADIUS) * c, _C1, _C2)
    return ws.q[:rows]


def _bands(h: int) -> list[tuple[int, int]]:
    """Output-row ranges [r0, r1) of the bands covering the H - 2r valid rows."""
    valid = h - 2 * RADIUS
    return [(r0, min(valid, r0 + BAND_ROWS)) for r0 in range(0, valid, BAND_ROWS)]


def _run_bands(p: np.ndarray, g: np.ndarray, data_range: float, threads: int, per_band) -> list:  # noqa: ANN001
    """``per_band(r0, r1, quotient)`` for every band, in band order; ``threads`` split the bands.

    Each thread owns a workspace and a contiguous run of bands; the results come back in band
    order, so any thread count gives bit-identical numbers.
    """
    h, w = p.shape[:2]
    c = 1 if p.ndim == 2 else p.shape[2]
    pp, gg = p.reshape(h, w * c), g.reshape(h, w * c)
    inv = 1.0 / data_range
    bands = _bands(h)

    def run(chunk: list[tuple[int, int]]) -> list:
        ws = _workspace(min(BAND_ROWS, h - 2 * RADIUS) + 2 * RADIUS, w, c)
        out = []
        for r0, r1 in chunk:
            q = _band(pp[r0 : r1 + 2 * RADIUS], gg[r0 : r1 + 2 * RADIUS], inv, ws)
            out.append(per_band(r0, r1, q))
        return out

    threads = max(1, min(int(threads), len(bands)))
    if threads == 1:
        return run(bands)
    from concurrent.futures import ThreadPoolExecutor

    size = -(-len(bands) // threads)
    chunks = [bands[i : i + size] for i in range(0, len(bands), size)]
    with ThreadPoolExecutor(len(chunks)) as pool:
        return [v for part in pool.map(run, chunks) for v in part]


def _channel_sum(p: np.ndarray, g: np.ndarray, data_range: float, threads: int = 1,
                 keep: np.ndarray | None = None) -> tuple[float, int]:
    """(float64 sum of the per-channel SSIM of every valid window, number of terms); ``keep``:
    an (H - 2r, W * C) float32 array that receives the bands' window values (``_Workspace.q``
    rows, border columns included)."""
    h, w = p.shape[:2]
    c = 1 if p.ndim == 2 else p.shape[2]
    lo, hi = RADIUS * c, (w - RADIUS) * c

    def band_sums(r0: int, r1: int, q: np.ndarray) -> list[float]:
        if keep is not None:
            keep[r0:r1] = q
        return _block_sums(q, r1 - r0, lo, hi)

    sums = [v for part in _run_bands(p, g, data_range, threads, band_sums) for v in part]
    return float(np.sum(sums, dtype=np.float64)), (h - 2 * RADIUS) * (w - 2 * RADIUS) * c


def _block_sums(q: np.ndarray, rows: int, lo: int, hi: int) -> list[float]:
    """The float64 partial sums of ``q[:rows, lo:hi]`` (window values, float32), one per
    ``SUM_ROWS`` rows (OpenCV accumulates float32 sums in float64, a row at a time)."""
    import cv2

    return [cv2.sumElems(q[s : min(s + SUM_ROWS, rows), lo:hi])[0] for s in range(0, rows, SUM_ROWS)]


def _channel_mean(p: np.ndarray, g: np.ndarray, data_range: float, threads: int = 1) -> float:
    """Mean per-channel SSIM over the valid windows (the SSIM of the image pair)."""
    total, count = _channel_sum(p, g, data_range, threads)
    return total / count


def _channel_maps(p: np.ndarray, g: np.ndarray, data_range: float, threads: int = 1) -> np.ndarray:
    """Per-channel SSIM of every valid window: (H - 2r, W - 2r) or (H - 2r, W - 2r, C) float32."""
    r = RADIUS
    h, w = p.shape[:2]
    c = 1 if p.ndim == 2 else p.shape[2]
    out = np.empty((h - 2 * r, w - 2 * r) + p.shape[2:], dtype=np.float32)
    flat = out.reshape(h - 2 * r, (w - 2 * r) * c)

    def store(r0: int, r1: int, q: np.ndarray) -> None:
        flat[r0:r1] = q[:, r * c : (w - r) * c]

    _run_bands(p, g, data_range, threads, store)
    return out


def _valid_map(p: np.ndarray, g: np.ndarray, data_range: float, threads: int = 1) -> np.ndarray:
    """Channel-mean SSIM of every valid window: (H - 2r, W - 2r) float32 (fast path)."""
    maps = _channel_maps(p, g, data_range, threads)
    return maps if maps.ndim == 2 else maps.mean(axis=2, dtype=np.float32)


def ssim_map(pred: object, gt: object, *, data_range: float = 1.0, threads: int = 1) -> np.ndarray:
    """SSIM of every window that fits in the image, averaged over channels.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors of equal shape, H, W >= 11, float in
            [0, data_range] (float16/integers are upcast).
        data_range: L, explicit.
        threads: bands of rows computed by this many threads (same numbers for any count).

    Returns:
        (H - 10, W - 10) float32 map, values in [-1, 1]; element ``[i, j]`` is the SSIM of the
        11x11 window centred at pixel ``(i + 5, j + 5)``. Its float64 mean is ``ssim(pred, gt)``.
    """
    p, g = check_pair(pred, gt, data_range=data_range)
    _check_size(*p.shape[:2])
    return _valid_map(p, g, check_data_range(data_range), threads)


class _WholeMap(NamedTuple):
    """The window values of one whole-image SSIM (``reusing_whole_map``)."""

    pred: np.ndarray
    gt: np.ndarray
    data_range: float
    q: np.ndarray
    """(H - 2r, W * C) float32: row i, value j is the SSIM of channel ``j % C`` of the window
    centred at pixel ``(i + r, j // C)`` (valid for r <= j // C < W - r)."""


_WHOLE = threading.local()


@contextmanager
def reusing_whole_map() -> Iterator[None]:
    """Within this block (this thread), the whole-image ``ssim`` of a pair keeps its window
    values, and ``ssim`` of the very same two arrays (the same objects, values unchanged) over
    boxes (crop mode) or a mask reads a region's windows from them instead of filtering its
    crop again. Same bits: a window's value depends on its own 11x11 pixels alone, whatever
    tile or crop it is computed in (``_tiles``: SIMD-clean widths; a crop narrower than one
    SIMD-clean tile is still computed on its own), and the sums are taken over the same rows in
    the same blocks. For the frame metrics of one frame (``stages.frame_metrics``)."""
    before = getattr(_WHOLE, "on", False), getattr(_WHOLE, "last", None)
    _WHOLE.on, _WHOLE.last = True, None
    try:
        yield
    finally:
        _WHOLE.on, _WHOLE.last = before


def _whole_mean(p: np.ndarray, g: np.ndarray, data_range: float, threads: int) -> float:
    """``_channel_mean`` of the whole image, its window values kept inside ``reusing_whole_map``."""
    if not getattr(_WHOLE, "on", False):
        return _channel_mean(p, g, data_range, threads)
    h, w = p.shape[:2]
    c = 1 if p.ndim == 2 else p.shape[2]
    q = np.empty((h - 2 * RADIUS, w * c), np.float32)
    total, count = _channel_sum(p, g, data_range, threads, keep=q)
    _WHOLE.last = _WholeMap(p, g, data_range, q)
    return total / count


def _kept_map(p: np.ndarray, g: np.ndarray, data_range: float, width: int) -> np.ndarray | None:
    """The kept window values of the whole-image SSIM of ``p`` and ``g`` (these very arrays, at
    this ``data_range``) for a crop ``width`` pixels wide; None when there are none or the crop
    is narrower than one SIMD-clean tile."""
    last = getattr(_WHOLE, "last", None)
    c = 1 if p.ndim == 2 else p.shape[2]
    if (last is None or last.pred is not p or last.gt is not g or last.data_range != data_range
            or width < _simd_span(c)):
        return None
    return last.q


def _crop_mean_from(q: np.ndarray, x0: int, y0: int, x1: int, y1: int, c: int) -> float:
    """``_channel_mean`` of the crop ``[y0:y1, x0:x1]`` from the whole image's window values."""
    r = RADIUS
    rows = y1 - y0 - 2 * r
    total = float(np.sum(_block_sums(q[y0:], rows, (x0 + r) * c, (x1 - r) * c), dtype=np.float64))
    return total / (rows * (x1 - x0 - 2 * r) * c)


def _map_mean_over(p: np.ndarray, g: np.ndarray, m: np.ndarray, data_range: float) -> float:
    """Mean of the SSIM map over the region pixels whose window fits in the image."""
    h, w = m.shape
    r = RADIUS
    ys, xs = np.nonzero(m)
    # Only the bounding box of the region plus r pixels is filtered: the map at the region's
    # pixels is then exactly the whole-image map.
    y0, y1 = max(0, int(ys.min()) - r), min(h, int(ys.max()) + 1 + r)
    x0, x1 = max(0, int(xs.min()) - r), min(w, int(xs.max()) + 1 + r)
    sub = m[y0 + r : y1 - r, x0 + r : x1 - r]
    if y1 - y0 < WIN_SIZE or x1 - x0 < WIN_SIZE or not sub.any():
        raise EmptyRegionError(
            f"the region lies entirely within {r} px of the image border, where no SSIM window "
            "fits: masked SSIM is undefined for this frame"
        )
    q = _kept_map(p, g, data_range, x1 - x0)
    if q is None:
        maps = _channel_maps(p[y0:y1, x0:x1], g[y0:y1, x0:x1], data_range)
    else:  # the same windows of the whole image, in the same layout
        maps = q.reshape(q.shape[0], w, -1)[y0 : y1 - 2 * r, x0 + r : x1 - r].reshape(
            y1 - y0 - 2 * r, x1 - x0 - 2 * r, *p.shape[2:])
    return float(maps[sub].mean(dtype=np.float64))


def _crop_mean(p: np.ndarray, g: np.ndarray, boxes: object, data_range: float) -> float:
    """Box-area-weighted mean of the SSIM of each box's crop (boxes grown to >= 11x11)."""
    h, w = p.shape[:2]
    c = 1 if p.ndim == 2 else p.shape[2]
    total = 0.0
    weight = 0
    for box in clipped_boxes(boxes, h, w):
        area = int((box[2] - box[0]) * (box[3] - box[1]))
        x0, y0, x1, y1 = grow_box(box, WIN_SIZE, WIN_SIZE, h, w)
        q = _kept_map(p, g, data_range, x1 - x0)
        total += area * (_channel_mean(p[y0:y1, x0:x1], g[y0:y1, x0:x1], data_range) if q is None
                         else _crop_mean_from(q, x0, y0, x1, y1, c))
        weight += area
    return total / weight


def ssim(
    pred: object,
    gt: object,
    *,
    data_range: float = 1.0,
    mask: object = None,
    boxes: object = None,
    region_mode: str | None = None,
    threads: int = 1,
) -> float:
    """Structural similarity (Wang et al. 2004, Gaussian window 11, sigma 1.5), whole image or region.

    Args:
        pred, gt: (H, W) or (H, W, C) numpy arrays or torch tensors of equal shape, channel
            last, H, W >= 11; float in [0, data_range] (float16 upcast) or integers with
            ``data_range`` set (255 for uint8): values outside [0, data_range] (beyond a 1e-3 *
            data_range rounding tolerance) and integers with ``data_range <= 1`` are refused.
        data_range: L (1.0 for float images in [0, 1], 255 for uint8), explicit.
        mask: optional bool (H, W): mean of the whole-image SSIM map over the masked pixels whose
            11x11 window fits in the image (windows centred in the mask; their pixels outside
            the mask are real pixels, never counted as a perfect 1).
        boxes: optional (N, 4) ``[x_min, y_min, x_max, y_max]`` max exclusive.
        region_mode: how a region restricts SSIM. ``"map"``: mean of the SSIM map over the
            region's pixels (as for ``mask``; boxes as their union). ``"crop"``: each box is
            cropped and scored as an image of its own (mean over the crop's valid windows); the
            frame value is the box-area-weighted mean; a box smaller than 11 px in a dimension
            is grown symmetrically to 11 px with its real neighbours (shifted to stay inside
            the image). Default None: ``"crop"`` for boxes (differences outside the boxes
            cannot change the score), ``"map"`` for a mask (``"crop"`` needs boxes).
        threads: whole-image SSIM is computed by this many threads over bands of rows (1: the
            caller parallelises, e.g. over frames; the number does not depend on it).

    Returns:
        SSIM as a float in [-1, 1]; 1.0 for identical images.

    Raises:
        InputError: shapes differ, channel-first layout, values outside [0, data_range],
            NaN/Inf, bad mask/boxes/mode.
        UndefinedMetricError: (an InputError) the image is smaller than 11x11.
        EmptyRegionError: the region holds no pixel (or none whose window fits, in map mode).
    """
    if region_mode is not None and region_mode not in REGION_MODES:
        raise InputError(f"region_mode must be one of {REGION_MODES} or None, got {region_mode!r}")
    p, g = check_pair(pred, gt, data_range=data_range)
    h, w = p.shape[:2]
    _check_size(h, w)
    data_range = check_data_range(data_range)
    if mask is not None and region_mode == "crop":
        raise InputError("region_mode='crop' needs boxes; a mask is scored with region_mode='map'")
    m = region_mask(mask, boxes, h, w)
    if m is None:
        return _whole_mean(p, g, data_range, threads)
    if boxes is not None and region_mode in (None, "crop"):
        return _crop_mean(p, g, boxes, data_range)
    return _map_mean_over(p, g, m, data_range)


def ssim_reference(pred: object, gt: object, *, data_range: float = 1.0) -> np.ndarray:
    """Slow, readable float64 SSIM map of the valid windows (the reference for the fast path).

    Every 11x11 window is taken explicitly (no border handling needed: only windows inside the
    image). Returns the (H - 10, W - 10) float64 channel-mean map; ``.mean()`` is the SSIM.
    """
    p, g = check_pair(pred, gt, data_range=data_range)
    _check_size(*p.shape[:2])
    data_range = check_data_range(data_range)
    x = p.astype(np.float64) if p.ndim == 3 else p.astype(np.float64)[..., None]
    y = g.astype(np.float64) if g.ndim == 3 else g.astype(np.float64)[..., None]
    k = gaussian_window()
    weights = np.outer(k, k)  # (11, 11), sums to 1
    c1 = (K1 * data_range) ** 2
    c2 = (K2 * data_range) ** 2
    # windows: (H-10, W-10, C, 11, 11)
    wx = np.lib.stride_tricks.sliding_window_view(x, (WIN_SIZE, WIN_SIZE), axis=(0, 1))
    wy = np.lib.stride_tricks.sliding_window_view(y, (WIN_SIZE, WIN_SIZE), axis=(0, 1))

    def wmean(a: np.ndarray) -> np.ndarray:
        return np.einsum("hwcij,ij->hwc", a, weights)

    mu_x, mu_y = wmean(wx), wmean(wy)
    var_x = wmean(wx * wx) - mu_x**2
    var_y = wmean(wy * wy) - mu_y**2
    cov = wmean(wx * wy) - mu_x * mu_y
    s = ((2 * mu_x * mu_y + c1) * (2 * cov + c2)) / ((mu_x**2 + mu_y**2 + c1) * (var_x + var_y + c2))
    return s.mean(axis=2)


def build_ssim(ctx: Any) -> Any:
    """The registry's SSIM for a run (``dynaeval.metrics.registry.FrameContext``): the protocol's
    whole-frame SSIM, dynaeval's ``ssim`` over a region (``{"boxes": ...}`` / ``{"mask": ...}``)."""
    return WholeOrRegion(ctx.whole().whole_ssim, ssim, ctx.data_range)


def ssim_settings(ctx: Any, enabled: bool, unavailable: str | None) -> dict[str, Any]:
    """What the results record of SSIM (the dynaeval definition used over regions)."""
    return {
        "window": "gaussian",
        "win_size": WIN_SIZE,
        "sigma": SIGMA,
        "truncate": TRUNCATE,
        "k1": K1,
        "k2": K2,
        "covariance": "population",
        "border": "valid windows only (the 5-px border is skipped, as scikit-image crops it)",
    }

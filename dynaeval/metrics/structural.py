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
cancellation in ``w * x^2 - mu^2``) with OpenCV's separable filter, and reduces in float64.
``ssim_reference`` is the slow, readable float64 version the tests hold it to.
"""

from __future__ import annotations

import numpy as np

from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics._common import (
    check_data_range,
    check_pair,
    clipped_boxes,
    grow_box,
    region_mask,
)

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


def gaussian_window(sigma: float = SIGMA, truncate: float = TRUNCATE) -> np.ndarray:
    """1-D Gaussian weights, (2r+1,) float64 summing to 1, r = int(truncate * sigma + 0.5)."""
    r = int(truncate * sigma + 0.5)
    x = np.arange(-r, r + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return k / k.sum()


def _check_size(h: int, w: int) -> None:
    if h < WIN_SIZE or w < WIN_SIZE:
        raise InputError(
            f"SSIM needs images of at least {WIN_SIZE}x{WIN_SIZE} pixels (its Gaussian window, "
            f"sigma {SIGMA}, has {WIN_SIZE} taps); got {h}x{w} (HxW). Score larger images, or "
            "leave SSIM out for this input (PSNR has no minimum size)"
        )


BAND_ROWS = 64
"""Output rows per band: the work is done band by band so the temporaries stay cache-sized."""


def _blur(a: np.ndarray) -> np.ndarray:
    """Gaussian window (11 taps, sigma 1.5) applied separably, float32, same size as ``a``.

    OpenCV's kernel for (11, sigma 1.5) is exactly ``gaussian_window()`` (a test holds them
    together); the reflected border only touches pixels that are cropped afterwards.
    """
    import cv2

    out = cv2.GaussianBlur(a, (WIN_SIZE, WIN_SIZE), SIGMA, borderType=cv2.BORDER_REFLECT)
    return out.reshape(a.shape)  # OpenCV drops a trailing channel axis of size 1


def _band_map(xb: np.ndarray, yb: np.ndarray, inv: float) -> np.ndarray:
    """Per-channel SSIM of the valid windows of one band of rows: (rows - 2r, W - 2r[, C]) float32.

    Uses 4 filtered images instead of 5: with x, y centred at 0.5 and d = x - y,
    ``mu_x^2 + mu_y^2 = 2 mu_x mu_y + (mu_x - mu_y)^2`` and
    ``sigma_x^2 + sigma_y^2 = 2 sigma_xy + var(d)``, ``var(d) = w * d^2 - (w * d)^2``.
    """
    r = RADIUS
    x = xb.astype(np.float32)
    y = yb.astype(np.float32)
    if inv != 1.0:
        x *= np.float32(inv)
        y *= np.float32(inv)
    x -= np.float32(0.5)
    y -= np.float32(0.5)
    d = x - y
    d2 = d * d
    rows, cols = xb.shape[0] - 2 * r, xb.shape[1] - 2 * r
    a = _blur(x)[r : r + rows, r : r + cols]  # mu_x - 0.5
    b = _blur(y)[r : r + rows, r : r + cols]  # mu_y - 0.5
    x *= y
    exy = _blur(x)[r : r + rows, r : r + cols]  # w * (x y), centred data
    ed2 = _blur(d2)[r : r + rows, r : r + cols]  # w * d^2
    del x, y, d, d2
    e = a - b  # mu_x - mu_y
    e *= e
    ab = a * b
    exy -= ab  # sigma_xy
    exy *= np.float32(2)
    exy += np.float32(K2 * K2)  # num2 = 2 sigma_xy + C2
    ed2 -= e
    ed2 += exy  # den2 = sigma_x^2 + sigma_y^2 + C2
    a += np.float32(0.5)
    b += np.float32(0.5)
    np.multiply(a, b, out=ab)
    ab *= np.float32(2)
    ab += np.float32(K1 * K1)  # num1 = 2 mu_x mu_y + C1
    e += ab  # den1 = mu_x^2 + mu_y^2 + C1
    ab *= exy
    e *= ed2
    ab /= e
    return ab


def _channel_maps(p: np.ndarray, g: np.ndarray, data_range: float) -> np.ndarray:
    """Per-channel SSIM of every valid window: (H - 2r, W - 2r) or (H - 2r, W - 2r, C) float32."""
    r = RADIUS
    h, w = p.shape[:2]
    out = np.empty((h - 2 * r, w - 2 * r) + p.shape[2:], dtype=np.float32)
    inv = 1.0 / data_range
    for r0 in range(0, h - 2 * r, BAND_ROWS):
        r1 = min(h - 2 * r, r0 + BAND_ROWS)
        out[r0:r1] = _band_map(p[r0 : r1 + 2 * r], g[r0 : r1 + 2 * r], inv)
    return out


def _valid_map(p: np.ndarray, g: np.ndarray, data_range: float) -> np.ndarray:
    """Channel-mean SSIM of every valid window: (H - 2r, W - 2r) float32 (fast path)."""
    maps = _channel_maps(p, g, data_range)
    return maps if maps.ndim == 2 else maps.mean(axis=2, dtype=np.float32)


def ssim_map(pred: object, gt: object, *, data_range: float = 1.0) -> np.ndarray:
    """SSIM of every window that fits in the image, averaged over channels.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors of equal shape, H, W >= 11, float in
            [0, data_range] (float16/integers are upcast).
        data_range: L, explicit.

    Returns:
        (H - 10, W - 10) float32 map, values in [-1, 1]; element ``[i, j]`` is the SSIM of the
        11x11 window centred at pixel ``(i + 5, j + 5)``. Its float64 mean is ``ssim(pred, gt)``.
    """
    p, g = check_pair(pred, gt)
    _check_size(*p.shape[:2])
    return _valid_map(p, g, check_data_range(data_range))


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
    maps = _channel_maps(p[y0:y1, x0:x1], g[y0:y1, x0:x1], data_range)
    return float(maps[sub].mean(dtype=np.float64))


def _crop_mean(p: np.ndarray, g: np.ndarray, boxes: object, data_range: float) -> float:
    """Box-area-weighted mean of the SSIM of each box's crop (boxes grown to >= 11x11)."""
    h, w = p.shape[:2]
    total = 0.0
    weight = 0
    for box in clipped_boxes(boxes, h, w):
        area = int((box[2] - box[0]) * (box[3] - box[1]))
        x0, y0, x1, y1 = grow_box(box, WIN_SIZE, WIN_SIZE, h, w)
        maps = _channel_maps(p[y0:y1, x0:x1], g[y0:y1, x0:x1], data_range)
        total += area * float(maps.mean(dtype=np.float64))
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
) -> float:
    """Structural similarity (Wang et al. 2004, Gaussian window 11, sigma 1.5), whole image or region.

    Args:
        pred, gt: (H, W) or (H, W, C) numpy arrays or torch tensors of equal shape, H, W >= 11;
            float in [0, data_range] (float16 upcast) or integers with ``data_range`` set.
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

    Returns:
        SSIM as a float in [-1, 1]; 1.0 for identical images.

    Raises:
        InputError: shapes differ, image smaller than 11x11, NaN/Inf, bad mask/boxes/mode.
        EmptyRegionError: the region holds no pixel (or none whose window fits, in map mode).
    """
    if region_mode is not None and region_mode not in REGION_MODES:
        raise InputError(f"region_mode must be one of {REGION_MODES} or None, got {region_mode!r}")
    p, g = check_pair(pred, gt)
    h, w = p.shape[:2]
    _check_size(h, w)
    data_range = check_data_range(data_range)
    if mask is not None and region_mode == "crop":
        raise InputError("region_mode='crop' needs boxes; a mask is scored with region_mode='map'")
    m = region_mask(mask, boxes, h, w)
    if m is None:
        return float(_channel_maps(p, g, data_range).mean(dtype=np.float64))
    if boxes is not None and region_mode in (None, "crop"):
        return _crop_mean(p, g, boxes, data_range)
    return _map_mean_over(p, g, m, data_range)


def ssim_reference(pred: object, gt: object, *, data_range: float = 1.0) -> np.ndarray:
    """Slow, readable float64 SSIM map of the valid windows (the reference for the fast path).

    Every 11x11 window is taken explicitly (no border handling needed: only windows inside the
    image). Returns the (H - 10, W - 10) float64 channel-mean map; ``.mean()`` is the SSIM.
    """
    p, g = check_pair(pred, gt)
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

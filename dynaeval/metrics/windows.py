"""SSIM's local statistics under a separable window and the SSIM variants other evaluators use
(``ssim_variant``: dm_pix / NeRFBaselines, torchmetrics / nerfstudio, pytorch_msssim /
splatfacto, 3DGS), for the protocol classes (``dynaeval.metrics.protocol_*``) and 3DGS /
4DGaussians' MS-SSIM in ``protocol_3dgs``: one module below them all.
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import check_data_range, check_pair
from dynaeval.metrics.structural import K1, K2, RADIUS, _check_size, gaussian_window


def as_hwc(p: np.ndarray) -> np.ndarray:
    """(H, W) -> (H, W, 1); (H, W, C) as it is."""
    return p[..., None] if p.ndim == 2 else p


def window_statistics(
    p: np.ndarray, g: np.ndarray, *, border: str = "valid", clamp: str = "none",
    window: np.ndarray | None = None,
) -> list[tuple[np.ndarray, ...]]:
    """SSIM's local statistics under the 11-tap Gaussian window, per channel.

    Args:
        p, g: (H, W, C) float32 or float64 arrays of one shape, H, W >= 11 (checked by the
            callers); the statistics are computed in their dtype.
        border, clamp, window: as ``ssim_variant`` (checked there).

    Returns:
        One ``(mu_x, mu_y, var_x, var_y, cov_xy)`` of maps per channel, (H - 10, W - 10) for
        ``border="valid"``, else (H, W), in the images' dtype.
    """
    import cv2

    dtype = p.dtype
    k = (gaussian_window() if window is None else np.asarray(window)).astype(dtype)
    r = RADIUS
    depth = cv2.CV_32F if dtype == np.float32 else cv2.CV_64F

    def blur(a: np.ndarray) -> np.ndarray:
        a = np.ascontiguousarray(a)
        if border == "reflect":
            return cv2.sepFilter2D(a, depth, k, k, borderType=cv2.BORDER_REFLECT_101)
        if border == "zero":
            return cv2.sepFilter2D(a, depth, k, k, borderType=cv2.BORDER_CONSTANT)
        return cv2.sepFilter2D(a, depth, k, k, borderType=cv2.BORDER_REFLECT)[r:-r, r:-r]

    out = []
    for c in range(p.shape[2]):
        x, y = p[..., c], g[..., c]
        mx, my = blur(x), blur(y)
        sxx = blur(x * x) - mx * mx
        syy = blur(y * y) - my * my
        sxy = blur(x * y) - mx * my
        if clamp == "zero":
            sxx, syy = np.maximum(sxx, 0), np.maximum(syy, 0)
        elif clamp == "dm_pix":
            eps = dtype.type(np.finfo(np.float32).eps) ** 2
            sxx = np.maximum(eps, sxx)
            syy = np.maximum(eps, syy)
            sxy = np.sign(sxy) * np.minimum(np.sqrt(sxx * syy), np.abs(sxy))
        out.append((mx, my, sxx, syy, sxy))
    return out


SSIM_BORDERS = ("valid", "reflect", "zero")
SSIM_CLAMPS = ("none", "zero", "dm_pix")


def ssim_variant(
    pred: object,
    gt: object,
    *,
    data_range: float = 1.0,
    border: str = "valid",
    clamp: str = "none",
    clip: bool = False,
    precision: str = "float32",
    window: np.ndarray | None = None,
) -> float:
    """SSIM with a Gaussian window (11 taps, sigma 1.5) in the variants other evaluators use.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range], H, W >= 11.
        data_range: L in ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2``.
        border: ``"valid"``: only windows entirely inside the image (scikit-image, dm_pix,
            NeRFBaselines); ``"reflect"``: the image is padded by 5 px by reflection without
            repeating the edge (torch's ``reflect``) and all H x W windows are averaged
            (torchmetrics 1.9, which nerfstudio calls); ``"zero"``: padded by 5 px of zeros and
            all H x W windows averaged (3DGS ``utils/loss_utils.ssim``: ``conv2d(padding=5)``).
        clamp: ``"none"``; ``"zero"``: variances ``max(0, var)`` (torchmetrics); ``"dm_pix"``:
            variances ``max(eps_f32^2, var)`` and covariance ``sign(cov) min(sqrt(var_x var_y),
            |cov|)`` (dm_pix / NeRFBaselines).
        clip: clip both images to [0, 1] first (NeRFBaselines).
        precision: ``"float32"`` (torchmetrics: float32 tensors throughout) or ``"float64"``
            (NeRFBaselines' numpy port of dm_pix: float32 images convolved with a float64
            window, so the statistics are float64).
        window: the 1-D taps, (11,), as the evaluator computes them (float32 weights normalised
            in float32 sum to 1 only within rounding, which moves SSIM by ~1e-5 on flat regions);
            default ``structural.gaussian_window()`` (float64).

    Returns:
        Mean SSIM over the windows and channels, a Python float in [-1, 1].

    Raises:
        InputError: bad shapes, values, size below 11 px, or unknown border/clamp/precision.
    """
    for arg, value, allowed in (("border", border, SSIM_BORDERS), ("clamp", clamp, SSIM_CLAMPS),
                                ("precision", precision, ("float32", "float64"))):
        if value not in allowed:
            raise InputError(f"{arg} must be one of {', '.join(allowed)}, got {value!r}")
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    dtype = np.dtype(precision)
    p, g = as_hwc(p).astype(np.float32), as_hwc(g).astype(np.float32)
    if clip:
        p, g = np.clip(p, 0, 1), np.clip(g, 0, 1)
    p, g = p.astype(dtype), g.astype(dtype)
    _check_size(*p.shape[:2])
    c1 = dtype.type((K1 * data_range) ** 2)
    c2 = dtype.type((K2 * data_range) ** 2)
    maps = []
    for mx, my, sxx, syy, sxy in window_statistics(p, g, border=border, clamp=clamp, window=window):
        num = (2 * mx * my + c1) * (2 * sxy + c2)
        den = (mx * mx + my * my + c1) * (sxx + syy + c2)
        maps.append(num / den)
    return float(np.mean(np.stack(maps), dtype=np.float64))

"""SSIM's local statistics under a separable window, as the protocols' SSIM variants compute
them (``dynaeval.metrics.protocols.ssim_variant``, 3DGS/4DGaussians' MS-SSIM in
``protocol_3dgs``): one module below both, so neither imports the other for them.
"""

from __future__ import annotations

import numpy as np

from dynaeval.metrics.structural import RADIUS, gaussian_window


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

"""NeRFBaselines' use of a render folder's ``mask/``: the images multiplied by the mask, then
scored over the whole frame.

NeRFBaselines 1.2.12 ``evaluation.evaluate`` reads ``mask/<relpath>.png`` for every frame when
the folder exists (``io.read_mask``: ``np.array(PIL.Image.open(f))``, an 8-bit grey mask),
``DefaultEvaluationProtocol.evaluate`` divides it by 255, and ``compute_metrics`` multiplies
both uint8-quantised images (as float32 in [0, 1]) by it, ``pred * mask[..., None]`` and
``gt * mask[..., None]``, before its PSNR, SSIM and LPIPS of the **whole frame**: the pixels
outside the mask are 0 in both images and count as perfect, so the numbers rise with the area
outside the mask (docs/protocols.md). dynaeval's ``masked_*`` over the same masks divide by the
mask instead.

``NerfBaselinesProtocol`` (``--protocol nerfbaselines``) is NeRFBaselines' whole evaluation:
8-bit truncation, values clipped to [0, 1], PSNR from a float32 MSE, the dm_pix SSIM, 16-bit PNGs
read as Pillow reads them, and the mask multiplied in.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import check_pair
from dynaeval.metrics.protocol_base import Float32PsnrProtocol, Pair
from dynaeval.metrics.windows import ssim_variant


def multiply_mask(pred: object, gt: object, weights: object) -> tuple[np.ndarray, np.ndarray]:
    """Both images times the mask, as NeRFBaselines' ``compute_metrics`` does.

    Args:
        pred, gt: (H, W) or (H, W, C) images in [0, 1].
        weights: (H, W) mask weights in [0, 1] (``v / 255`` of an 8-bit mask).

    Returns:
        ``(pred * m, gt * m)`` as float32 (H, W, C) arrays.

    Raises:
        InputError: the mask's size differs from the images'.
    """
    p, g = check_pair(pred, gt)
    p = p[..., None] if p.ndim == 2 else p
    g = g[..., None] if g.ndim == 2 else g
    w = np.asarray(weights, dtype=np.float32)
    if w.shape != p.shape[:2]:
        raise InputError(f"mask must have the image's size {p.shape[:2]}, got {w.shape}")
    w = w[..., None]
    return p.astype(np.float32) * w, g.astype(np.float32) * w


class NerfBaselinesProtocol(Float32PsnrProtocol):
    """NeRFBaselines 1.2.12 ``evaluation.py`` (``DefaultEvaluationProtocol``,
    ``compute_metrics``): both images through 8 bit by truncation, clipped to [0, 1]; PSNR from a
    float32 MSE; the dm_pix SSIM (valid windows, float64 statistics of the float32 images,
    variances clamped to ``eps_f32^2``, the covariance to ``+-sqrt(var_x var_y)``); LPIPS AlexNet;
    given masks multiplied into both images (``multiply_mask``)."""

    name = "nerfbaselines"
    reference = ("NeRFBaselines evaluation.py (DefaultEvaluationProtocol, compute_metrics) and "
                 "metrics.py")
    quantize = "truncate"
    ssim = "dm_pix"
    clip = True
    decode = "pil"
    masks = "multiply"

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return ssim_variant(pred, gt, data_range=data_range, border="valid", clamp="dm_pix",
                            clip=self.clip, precision="float64")

    def weighs_whole_frame(self) -> bool:
        return True

    def apply_masks(self, pred: Any, gt: Any, weights: Any) -> Pair:
        """``(pred * m, gt * m)`` (``multiply_mask``) with a mask; the images without."""
        return (pred, gt) if weights is None else multiply_mask(pred, gt, weights)

"""K-Planes' own evaluation (``--protocol kplanes``): the numbers its trainers log.

Read from the K-Planes repository (sarafridov/K-Planes, ``plenoxels/ops/image/metrics.py`` and
``plenoxels/runners/base_trainer.py``), written here from those facts:

* the prediction is clamped to [0, 1] before every metric (``evaluate_metrics``); an RGBA ground
  truth is blended over white (``gt[..., :3] * a + (1 - a)``); no 8-bit step: the metrics are
  computed on the float render, before the evaluation video is written;
* PSNR: ``10 log10(1 / mse)``, ``mse = torch.mean((rgb - gts) ** 2).item()`` of float32 tensors
  (a float32 mean, the logarithm in double precision) = ``pixel.psnr_float32``;
* SSIM: mip-NeRF's (``metrics.ssim``): 1-D Gaussian of 11 taps, sigma 1.5, normalised; each
  channel blurred along rows then columns with ``scipy.signal.convolve2d(mode="valid")`` (only
  the windows entirely inside the image); the float32 images (and their float32 squares and
  products) convolved with the float64 filter, so the statistics are float64; variances
  clipped at 0 and the covariance to ``sign(cov) min(sqrt(var_x var_y), |cov|)``;
  ``C1 = 0.01^2``, ``C2 = 0.03^2`` (``max_val = 1``); the mean over the map and the channels
  together;
* MS-SSIM: torchmetrics' ``MultiScaleStructuralSimilarityIndexMeasure(data_range=1.0)`` with its
  defaults (``dynaeval.metrics.multiscale``);
* LPIPS (``utils/eval_model_metrics.py``): the ``lpips`` package v0.1, AlexNet, ``normalize=True``;
* every summary is the mean of per-image values (``report_test_metrics``: ``np.mean``).

K-Planes logs ``psnr``, ``ssim`` and ``ms-ssim`` per image; it computes no D-SSIM. dynaeval's
``dssim`` is ``(1 - MS-SSIM) / 2``, as the DyNeRF-benchmark tables that report D-SSIM compute it
(hustvl/4DGaussians ``metrics.py``: ``(1 - ms_ssim) / 2``). docs/protocols.md lists each choice
with its source and the measured agreement; ``KPlanesProtocol`` is the protocol.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dynaeval.core.validation import check_pair
from dynaeval.metrics.protocol_base import Float32PsnrProtocol
from dynaeval.metrics.structural import K1, K2, RADIUS, _check_size, gaussian_window

KPLANES_REFERENCE = (
    "K-Planes plenoxels/ops/image/metrics.py (psnr, ssim, msssim) and "
    "plenoxels/runners/base_trainer.py (calc_metrics, evaluate_metrics)"
)
"""Where ``--protocol kplanes`` comes from."""

KPLANES_CHOICES: tuple[tuple[str, str], ...] = (
    ("prediction", "clamped to [0, 1] before every metric (base_trainer.evaluate_metrics); "
                   "dynaeval clips the ground truth too, a no-op for 8-bit ground truth"),
    ("background", "RGBA ground truth blended over white, gt * a + (1 - a) (calc_metrics)"),
    ("quantize", "none: metrics of the float render, before the evaluation video is written"),
    ("psnr", "10 log10(1 / mse), mse = float32 mean of the squared error, log in float64 "
             "(metrics.psnr: torch.mean(...).item())"),
    ("ssim", "mip-NeRF SSIM (metrics.ssim): separable Gaussian 11 taps sigma 1.5, scipy "
             "convolve2d mode='valid' (valid windows only), float32 images, squares and products, "
             "float64 statistics; variances max(0, v), covariance sign(c) min(sqrt(vx vy), |c|); "
             "C1 = 0.01^2, C2 = 0.03^2; mean over the map and channels together"),
    ("msssim", "torchmetrics MultiScaleStructuralSimilarityIndexMeasure(data_range=1.0) defaults: "
               "Gaussian 11 taps sigma 1.5, reflect padding, 5 scales, betas (0.0448, 0.2856, "
               "0.3001, 0.2363, 0.1333), normalize='relu' (metrics.msssim)"),
    ("dssim", "(1 - msssim) / 2, the DyNeRF-benchmark D-SSIM (4DGaussians metrics.py); "
              "K-Planes itself logs ms-ssim only"),
    ("lpips", "lpips package v0.1, AlexNet, normalize=True (utils/eval_model_metrics.py)"),
    ("summary", "mean of per-image values (report_test_metrics)"),
)
"""Every choice the protocol implies, recorded in the results' ``settings.protocol.choices``."""


def kplanes_ssim(pred: object, gt: object, *, data_range: float = 1.0, clip: bool = True) -> float:
    """SSIM as K-Planes logs it (mip-NeRF's: valid windows, clipped statistics).

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, 1], H, W >= 11; float64 input is
            taken to float32 first (K-Planes' tensors are float32).
        data_range: must be 1 (K-Planes' ``max_val``); ``Protocol.check_range`` checks it.
        clip: clamp both images to [0, 1] first (K-Planes clamps the prediction).

    Returns:
        Mean SSIM over the (H - 10) x (W - 10) valid windows and the channels, a Python float.

    Raises:
        InputError: bad shapes or values. UndefinedMetricError: an image under 11 x 11 pixels.
    """
    import cv2

    p, g = check_pair(pred, gt)
    p = (p[..., None] if p.ndim == 2 else p).astype(np.float32)
    g = (g[..., None] if g.ndim == 2 else g).astype(np.float32)
    if clip:
        p, g = np.clip(p, 0, 1), np.clip(g, 0, 1)
    _check_size(*p.shape[:2])
    k, r = gaussian_window(), RADIUS

    def blur(z: np.ndarray) -> np.ndarray:  # float32 plane -> float64 valid-window means
        out = cv2.sepFilter2D(z.astype(np.float64), cv2.CV_64F, k, k, borderType=cv2.BORDER_REFLECT)
        return out[r:-r, r:-r]

    c1, c2 = (K1 * data_range) ** 2, (K2 * data_range) ** 2
    maps = []
    for c in range(p.shape[2]):
        x, y = p[..., c], g[..., c]
        mx, my = blur(x), blur(y)
        sxx = np.maximum(0.0, blur(x * x) - mx * mx)
        syy = np.maximum(0.0, blur(y * y) - my * my)
        sxy = blur(x * y) - mx * my
        sxy = np.sign(sxy) * np.minimum(np.sqrt(sxx * syy), np.abs(sxy))
        maps.append((2 * mx * my + c1) * (2 * sxy + c2) / ((mx * mx + my * my + c1) * (sxx + syy + c2)))
    return float(np.mean(np.stack(maps, -1)))


class KPlanesProtocol(Float32PsnrProtocol):
    """K-Planes' trainers (module docstring): float renders clipped to [0, 1], PSNR from a
    float32 MSE, mip-NeRF's SSIM (``kplanes_ssim``), MS-SSIM / D-SSIM added to the run's
    metrics, LPIPS AlexNet, RGBA ground truth over white."""

    name = "kplanes"
    reference = KPLANES_REFERENCE
    ssim = "mipnerf"
    clip = True
    metrics = ("msssim", "dssim")
    background = "white"
    choices = KPLANES_CHOICES

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return kplanes_ssim(pred, gt, data_range=data_range, clip=self.clip)

"""What nerfstudio's model families call for SSIM (``--protocol nerfstudio`` / ``nerfstudio-splatfacto``).

nerfstudio has no evaluator of its own: each model's ``get_image_metrics_and_images`` builds its
metrics (read, not copied; docs/protocols.md cites the files), and two families differ:

* nerfacto and its siblings (``models/nerfacto.py``, ``instant_ngp.py``, ``mipnerf.py``,
  ``tensorf.py``, ``vanilla_nerf.py``, ``semantic_nerfw.py``): ``self.ssim =
  structural_similarity_index_measure`` called as ``self.ssim(gt, pred)`` with **no**
  ``data_range``. torchmetrics 1.9 (``functional/image/ssim.py``, ``_ssim_update``) then takes
  ``data_range = max(preds.max() - preds.min(), target.max() - target.min())`` over the batch,
  which ns-eval makes one image: each pair's own range (``image_data_range``). A render whose
  values span 0.6 gets constants ``(0.01 * 0.6)^2``, not ``0.01^2``.
* splatfacto (``models/splatfacto.py``): ``pytorch_msssim.SSIM(data_range=1.0,
  size_average=True, channel=3)``: valid Gaussian windows (11 taps, sigma 1.5, separable
  ``conv2d`` without padding), float32, no clamp, mean over the map.

Both use torchmetrics' ``PeakSignalNoiseRatio(data_range=1.0)`` and
``LearnedPerceptualImagePatchSimilarity(normalize=True)`` (AlexNet): ``NerfstudioProtocol`` and
``SplatfactoProtocol`` differ in their SSIM only.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dynaeval.core.errors import UndefinedMetricError
from dynaeval.core.validation import check_pair
from dynaeval.metrics.protocol_base import Float32PsnrProtocol
from dynaeval.metrics.windows import ssim_variant


def image_data_range(pred: object, gt: object) -> float:
    """torchmetrics' ``data_range=None``: ``max(ptp(pred), ptp(gt))`` of the float32 images.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors (any range).

    Returns:
        The range as a Python float (> 0).

    Raises:
        UndefinedMetricError: both images are constant (torchmetrics then divides 0 by 0: NaN).
    """
    p, g = check_pair(pred, gt)
    p32, g32 = p.astype(np.float32), g.astype(np.float32)
    value = max(float(p32.max() - p32.min()), float(g32.max() - g32.min()))
    if value <= 0:
        raise UndefinedMetricError(
            "nerfstudio's SSIM takes its data range from the images (torchmetrics without "
            "data_range) and both images are constant: the range is 0 and SSIM is 0/0 (NaN "
            "in nerfstudio); use --protocol dynaeval for a defined value"
        )
    return value


def msssim_window() -> np.ndarray:
    """pytorch_msssim's ``_fspecial_gauss_1d(11, 1.5)``: (11,) float32 taps ``exp(-x^2 / 4.5)``,
    ``x = -5..5``, divided by their sum.

    torch rounds its float32 ``exp`` and ``sum`` correctly here, so the taps are computed in
    float64 and rounded to float32 (numpy's own float32 ``exp`` is off by one ulp in two taps,
    which moves SSIM of 8-bit photos by ~1e-5: docs/protocols.md). With these taps dynaeval's
    separable filter is pytorch_msssim's within float32 summation order (~2e-7)."""
    x = np.arange(11, dtype=np.float32) - np.float32(5)
    arg = -(x * x) / np.float32(2 * 1.5**2)  # float32, as torch computes the exponent
    g = np.exp(arg.astype(np.float64)).astype(np.float32)
    return g / np.float32(g.astype(np.float64).sum())


class NerfstudioProtocol(Float32PsnrProtocol):
    """nerfacto and its siblings: float renders, torchmetrics' float32 PSNR
    (``data_range=1``), torchmetrics 1.9's SSIM without ``data_range`` (each pair's own range,
    ``image_data_range``; reflect-padded, every window, variances clamped at 0, float32), LPIPS
    AlexNet with ``normalize=True``."""

    name = "nerfstudio"
    reference = ("nerfstudio models' get_image_metrics_and_images (torchmetrics PSNR, SSIM, LPIPS "
                 "normalize=True) averaged per image by ns-eval; torchmetrics 1.9 "
                 "functional/image/ssim.py (data_range=None: the images' own range)")
    ssim = "torchmetrics"
    ssim_data_range = "image"
    family = "nerfacto, instant-ngp, mipnerf, tensorf, vanilla-nerf, semantic-nerfw"

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        """torchmetrics' SSIM with the pair's own range as L (``data_range`` unused).

        Raises:
            UndefinedMetricError: both images constant (``image_data_range``).
        """
        return ssim_variant(pred, gt, data_range=image_data_range(pred, gt), border="reflect",
                            clamp="zero", clip=self.clip, precision="float32")


class SplatfactoProtocol(Float32PsnrProtocol):
    """splatfacto: as ``NerfstudioProtocol`` but SSIM as ``pytorch_msssim.SSIM(data_range=1)``
    (valid windows, pytorch_msssim's float32 taps ``msssim_window``, no clamp, float32)."""

    name = "nerfstudio-splatfacto"
    reference = ("nerfstudio models/splatfacto.py get_image_metrics_and_images (torchmetrics PSNR, "
                 "pytorch_msssim.SSIM(data_range=1.0, size_average=True), LPIPS normalize=True)")
    ssim = "pytorch_msssim"
    family = "splatfacto"

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return ssim_variant(pred, gt, data_range=data_range, border="valid", clamp="none",
                            clip=self.clip, precision="float32", window=msssim_window())

"""The 3DGS family's own metrics (``--protocol 3dgs``): gaussian-splatting, 4DGaussians, Deformable-3DGS.

All three evaluate with the same ``metrics.py`` (read, not copied; docs/protocols.md cites the
files): each ``renders/NNNNN.png`` and ``gt/NNNNN.png`` is read with PIL, turned into a float32
tensor by ``torchvision.transforms.functional.to_tensor`` (``v / 255``) and cut to RGB
(``[:, :3]``, no compositing), then

* PSNR: ``utils/image_utils.psnr`` = ``20 log10(1 / sqrt(MSE))``, float32, per image
  (``psnr_3dgs``);
* SSIM: ``utils/loss_utils.ssim``: an 11-tap Gaussian (sigma 1.5), ``conv2d(padding=5)`` — zero
  padding, so the map has the image's size and the border windows count — float32,
  ``C1 = 0.01^2``, ``C2 = 0.03^2``, mean over the map (``ssim_variant(border="zero")`` in
  ``dynaeval.metrics.protocols``);
* LPIPS: ``lpipsPyTorch.lpips(..., net_type="vgg")`` (gaussian-splatting, 4DGaussians) or
  ``lpips.LPIPS(net="vgg")`` (Deformable-3DGS), both v0.1 VGG16 with the same linear layers, the
  same shift/scale layer and the same five ReLU outputs — the same network. Both are given the
  [0, 1] tensors *as they are*, where the network expects [-1, 1] (``lpips_unit_input``).

The summary is the mean of the per-image values (``torch.tensor(values).mean()``).

4DGaussians' ``metrics.py`` (``--protocol 4dgaussians``) computes the same three and reports
LPIPS twice, ``LPIPS-vgg`` and ``LPIPS-alex`` (``lpipsPyTorch.lpips(..., net_type='alex')``: the
``lpips`` package's v0.1 AlexNet, again on [0, 1] unscaled), and adds
``ms_ssim(render, gt, data_range=1, size_average=True)`` of ``pytorch_msssim`` 1.0 and
``D-SSIM = (1 - MS-SSIM) / 2`` (``msssim_4dgaussians``, ``dssim_4dgaussians``).

``GaussianSplattingProtocol`` and ``FourDGaussiansProtocol`` (a subclass: the same three, plus its
MS-SSIM and LPIPS-alex) are the two protocols.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dynaeval.core.errors import UndefinedMetricError
from dynaeval.core.validation import check_data_range, check_pair
from dynaeval.metrics.multiscale import BETAS
from dynaeval.metrics.perceptual import lpips_unit_input  # noqa: F401 (3DGS' LPIPS, named here)
from dynaeval.metrics.protocol_base import Protocol, Score
from dynaeval.metrics.protocol_nerfstudio import msssim_window
from dynaeval.metrics.windows import as_hwc, ssim_variant, window_statistics

MSSSIM_MIN_SIZE = 161
"""pytorch_msssim's ``ms_ssim`` asserts ``min(H, W) > (11 - 1) * 2 ** 4``."""


def psnr_3dgs(pred: object, gt: object, *, data_range: float = 1.0) -> float:
    """PSNR in dB as 3DGS' ``utils/image_utils.psnr``: ``20 log10(L / sqrt(MSE))`` in float32.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range].
        data_range: L (3DGS: 1.0).

    Returns:
        The float32 value as a Python float; ``math.inf`` for identical images.
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    d = p.astype(np.float32) - g.astype(np.float32)
    mse = np.mean(d * d, dtype=np.float32)
    if mse == 0:
        return math.inf
    one = np.float32(data_range)
    return float(np.float32(20) * np.log10(one / np.sqrt(mse)))


def _pool_pytorch_msssim(z: np.ndarray) -> np.ndarray:
    """pytorch_msssim's downsampling of (H, W, C): ``F.avg_pool2d(kernel_size=2, padding=[H %
    2, W % 2])``: an odd side gets one zero row/column before it (the one after is never
    reached) and the zeros count in the 2 x 2 means (``count_include_pad``)."""
    z = np.pad(z, ((z.shape[0] % 2, 0), (z.shape[1] % 2, 0), (0, 0)))
    return (z[0::2, 0::2] + z[0::2, 1::2] + z[1::2, 0::2] + z[1::2, 1::2]) * z.dtype.type(0.25)


def msssim_4dgaussians(pred: object, gt: object, *, data_range: float = 1.0,
                       precision: str = "float64") -> float:
    """MS-SSIM as 4DGaussians' ``metrics.py`` calls it: ``pytorch_msssim.ms_ssim(render, gt,
    data_range=1, size_average=True)`` (pytorch_msssim 1.0, every other argument default).

    Per scale and channel: valid Gaussian windows (11 float32 taps, sigma 1.5, separable, no
    padding), no clamp, ``cs`` and ``ssim`` the means of their maps; between the 5 scales both
    images are 2 x 2 average-pooled with an odd side zero-padded (``_pool_pytorch_msssim``);
    ``relu(cs_0..3)`` and ``relu(ssim_4)`` are combined with the betas (0.0448, 0.2856, 0.3001,
    0.2363, 0.1333) *per channel*, then the channels averaged. (torchmetrics, the ``kplanes``
    MS-SSIM, reflect-pads, drops odd rows and averages the channels before the product.)

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range], min(H, W) >= 161.
        data_range: L in ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2`` (4DGaussians: 1).
        precision: ``float64`` (default): the exact value of their formula, from which their
            float32 run departs by its own rounding (< 1e-6 on the photos of the tests); or
            ``float32``, as they run it, whose different rounding lands up to 3e-6 away from
            theirs on smooth images (a variance cancellation, as for SSIM).

    Returns:
        MS-SSIM in [0, 1], a Python float.

    Raises:
        InputError: bad shapes or values. UndefinedMetricError: a side under 161 px
            (pytorch_msssim fails an assert there).
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt, data_range=data_range)  # as ms_ssim: 0..255 input is refused
    dtype = np.dtype(precision)
    x, y = (as_hwc(a).astype(np.float32).astype(dtype) for a in (p, g))
    if min(x.shape[:2]) < MSSSIM_MIN_SIZE:
        raise UndefinedMetricError(
            f"4DGaussians' MS-SSIM (pytorch_msssim) needs images of at least {MSSSIM_MIN_SIZE} px "
            f"on the shorter side (5 scales of an 11-tap window); got {x.shape[0]}x{x.shape[1]} "
            "(HxW): MS-SSIM and D-SSIM are undefined for this image (recorded as null)")
    c1, c2 = dtype.type((0.01 * data_range) ** 2), dtype.type((0.03 * data_range) ** 2)
    betas = np.array([0.0448, 0.2856, 0.3001, 0.2363, 0.1333], dtype)
    terms = []  # (scale, channel)
    for scale in range(len(betas)):
        stats = window_statistics(x, y, window=msssim_window())
        cs = [(2 * sxy + c2) / (sxx + syy + c2) for _, _, sxx, syy, sxy in stats]
        if scale < len(betas) - 1:
            terms.append([np.mean(m, dtype=dtype) for m in cs])
            x, y = _pool_pytorch_msssim(x), _pool_pytorch_msssim(y)
        else:
            terms.append([np.mean((2 * mx * my + c1) / (mx * mx + my * my + c1) * m, dtype=dtype)
                          for (mx, my, *_), m in zip(stats, cs, strict=True)])
    per_channel = np.prod(np.maximum(np.array(terms, dtype), 0) ** betas[:, None], axis=0)
    return float(np.mean(per_channel, dtype=dtype))


def dssim_4dgaussians(pred: object, gt: object, *, data_range: float = 1.0) -> float:
    """4DGaussians' ``D-SSIM = (1 - MS-SSIM) / 2`` (``msssim_4dgaussians``), in [0, 0.5],
    lower is better; same arguments and errors."""
    return (1.0 - msssim_4dgaussians(pred, gt, data_range=data_range)) / 2.0


class GaussianSplattingProtocol(Protocol):
    """gaussian-splatting / 4DGaussians / Deformable-3DGS ``metrics.py``: PSNR ``psnr_3dgs``,
    SSIM zero-padded over every pixel's window in float32 (``ssim_variant(border="zero")``),
    LPIPS VGG fed the [0, 1] images unscaled (``lpips_unit_input``)."""

    name = "3dgs"
    reference = ("gaussian-splatting / 4DGaussians / Deformable-3DGS metrics.py "
                 "(utils/image_utils.psnr, utils/loss_utils.ssim, lpipsPyTorch or "
                 "lpips.LPIPS(net='vgg') on [0, 1] images)")
    psnr = "3dgs"
    ssim = "3dgs"
    lpips_net = "vgg"
    lpips_input = "unit"
    family = "gaussian-splatting, 4DGaussians, Deformable-3DGS"

    def psnr_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return psnr_3dgs(pred, gt, data_range=data_range)

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return ssim_variant(pred, gt, data_range=data_range, border="zero", clamp="none",
                            clip=self.clip, precision="float32")

    def whole_lpips(self, pred: Any, gt: Any, *, score: Score, score_map: Any,
                    score_unit: Score, weights: Any = None) -> float:
        """The network fed the [0, 1] images as they are (``score_unit``)."""
        if weights is None:
            return score_unit(pred, gt)
        return super().whole_lpips(pred, gt, score=score, score_map=score_map,
                                   score_unit=score_unit, weights=weights)


class FourDGaussiansProtocol(GaussianSplattingProtocol):
    """4DGaussians' ``metrics.py``: the 3DGS metrics, plus pytorch_msssim's MS-SSIM / D-SSIM
    (``msssim_4dgaussians``) and its ``LPIPS-alex`` beside ``LPIPS-vgg`` (``--lpips-net alex``,
    again on unscaled [0, 1] input)."""

    name = "4dgaussians"
    reference = ("4DGaussians metrics.py (utils/image_utils.psnr, utils/loss_utils.ssim, "
                 "pytorch_msssim.ms_ssim(data_range=1, size_average=True), D-SSIM = "
                 "(1 - MS-SSIM) / 2, lpipsPyTorch.lpips(net_type='vgg' and 'alex') on [0, 1] "
                 "images)")
    metrics = ("msssim", "dssim")
    family = "4DGaussians"
    msssim = "pytorch_msssim"
    lpips_nets = ("alex",)

    def whole_msssim(self, pred: Any, gt: Any, *, data_range: float = 1.0) -> float:
        return msssim_4dgaussians(pred, gt, data_range=data_range)  # 4DGaussians does not clip

    def whole_dssim(self, pred: Any, gt: Any, *, data_range: float = 1.0) -> float:
        return dssim_4dgaussians(pred, gt, data_range=data_range)

    def msssim_settings(self) -> dict[str, Any]:
        return {
            "variant": "pytorch_msssim 1.0 ms_ssim(data_range=1, size_average=True) defaults, "
                       "as 4DGaussians' metrics.py calls it (its formula in float64)",
            "win_size": 11, "sigma": 1.5, "k1": 0.01, "k2": 0.03, "betas": list(BETAS),
            "padding": "none (valid windows at every scale)", "normalize": "relu",
            "pooling": "2x2 average, odd sides zero-padded", "reduction": "product per channel, "
            "then the mean over channels", "min_size": MSSSIM_MIN_SIZE, "clip": False,
            "dssim": "(1 - msssim) / 2",
        }

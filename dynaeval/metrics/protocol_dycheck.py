"""DyCheck's masked metrics (Gao et al. 2022, "Monocular Dynamic View Synthesis: A Reality Check").

``--protocol dycheck`` reports ``mpsnr``, ``mssim`` and ``mlpips`` over the covisibility mask
(the pixels of a test view that some training view saw) as DyCheck's evaluation computes them
(``dycheck/core/tasks/novel_view.py``, ``dycheck/core/metrics/image.py``,
``dycheck/nn/functional/common.py``; read, not copied):

* both images go through 8 bit by truncation first (``to_quantized_float32``:
  ``(x * 255).clip(0, 255).astype(uint8) / 255``), the mask too (0/255 PNG -> 0/1);
* ``masked_mean(x, m) = sum(x * m) / max(sum(m), 1e-6)`` with ``m`` broadcast to ``x``'s shape
  (so a soft mask weighs pixels, and an empty mask gives 0, not NaN);
* mPSNR: ``-10 log10(masked_mean((a - b)^2, m))``;
* mSSIM: a Gaussian-window SSIM (11 taps, sigma 1.5, valid windows) whose blurs are *partial
  convolutions*: each separable pass blurs ``z * m`` and rescales by ``taps / count``, where
  ``count`` is the number of mask pixels (sum of the weights) under the 1-D window; the second
  pass uses as its mask the support of the first (``count != 0``); windows with no mask pixel
  give 0 statistics, so an SSIM of exactly 1. Variances are clamped at 0 and the covariance to
  ``+-sqrt(var_a var_b)``. The result is the mean of the map over **all** valid windows and
  channels, masked or not (unmasked windows count as 1);
* mLPIPS: the ``lpips`` package's AlexNet with ``spatial=True`` on the *masked images*
  (``a * m``, ``b * m``), then ``masked_mean(map, m)``; the whole-frame LPIPS is the plain mean
  of that spatial map (mask of ones).

DyCheck runs in float32 (jax); these functions compute in float64 from the float32 images
(differences are float32 rounding: docs/protocols.md gives the measured sizes).
``DyCheckProtocol`` is the protocol: these metrics over the whole frame and, as the ``covisible``
variant (``mask_regions``), over the covisibility mask.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.validation import check_pair
from dynaeval.metrics.protocol_base import Pair, Protocol, Score

EPS = 1e-6
"""``masked_mean``'s floor on the mask's sum."""
TAPS = 11
SIGMA = 1.5


def _hwc(a: np.ndarray) -> np.ndarray:
    return a[..., None] if a.ndim == 2 else a


def _weights(weights: object, shape: tuple[int, ...]) -> np.ndarray:
    """The mask as (H, W, 1) float64 in [0, 1] (ones when None)."""
    if weights is None:
        return np.ones((*shape[:2], 1))
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim == 3 and w.shape[2] == 1:
        w = w[..., 0]
    if w.shape != tuple(shape[:2]):
        raise InputError(f"weights must have the image's shape {tuple(shape[:2])}, got {w.shape}")
    if not np.all(np.isfinite(w)) or w.min() < 0 or w.max() > 1:
        raise InputError("weights must be finite values in [0, 1]")
    return w[..., None]


def masked_mean(x: np.ndarray, weights: np.ndarray | None) -> float:
    """DyCheck's ``masked_mean``: ``sum(x * m) / max(sum(m), 1e-6)``, ``m`` broadcast to ``x``.

    Args:
        x: (H, W, C) values.
        weights: (H, W, 1) weights in [0, 1], or None for the plain mean.

    Returns:
        A Python float (0.0 for an all-zero mask: DyCheck's floor, not NaN).
    """
    if weights is None:
        return float(np.mean(x, dtype=np.float64))
    m = np.broadcast_to(weights, x.shape)
    return float(np.sum(x * m, dtype=np.float64) / max(float(np.sum(m, dtype=np.float64)), EPS))


def _check(pred: object, gt: object, data_range: float) -> tuple[np.ndarray, np.ndarray]:
    if data_range != 1.0:
        raise InputError(f"DyCheck's metrics assume images in [0, 1] (data_range=1), got {data_range}")
    p, g = check_pair(pred, gt)
    return _hwc(p).astype(np.float32), _hwc(g).astype(np.float32)


def dycheck_psnr(pred: object, gt: object, *, weights: object = None,
                 data_range: float = 1.0) -> float:
    """DyCheck's ``compute_psnr``: ``-10 log10(masked_mean((a - b)^2, m))`` in dB.

    Args:
        pred, gt: (H, W) or (H, W, C) images in [0, 1] (already through the 8-bit step).
        weights: (H, W) or (H, W, 1) mask in [0, 1]; None: the whole frame.

    Returns:
        PSNR in dB; ``math.inf`` when the masked error is 0 (DyCheck's jax gives inf too).
    """
    p, g = _check(pred, gt, data_range)
    d = p.astype(np.float64) - g
    mse = masked_mean(d * d, None if weights is None else _weights(weights, p.shape))
    return math.inf if mse == 0.0 else -10.0 * math.log10(mse)


def gaussian_taps() -> np.ndarray:
    """DyCheck's 1-D filter: ``exp(-0.5 ((i - 5) / 1.5)^2)`` normalised, float64 (11,)."""
    i = np.arange(TAPS, dtype=np.float64) - TAPS // 2
    f = np.exp(-0.5 * (i / SIGMA) ** 2)
    return f / f.sum()


def _valid(a: np.ndarray, k: np.ndarray, axis: int) -> np.ndarray:
    """Valid 1-D correlation of (H, W) float64 ``a`` with symmetric ``k`` along ``axis``."""
    import cv2

    r = len(k) // 2
    one = np.ones(1)
    kx, ky = (k, one) if axis == 1 else (one, k)
    full = cv2.sepFilter2D(np.ascontiguousarray(a), cv2.CV_64F, kx, ky,
                           borderType=cv2.BORDER_CONSTANT)
    return full[:, r:-r] if axis == 1 else full[r:-r, :]


def partial_blur(z: np.ndarray, m: np.ndarray, k: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """One partial-convolution pass of DyCheck's SSIM (its ``convolve2d``).

    Args:
        z: (H, W) float64 values; m: (H, W) float64 mask weights.
        k: (taps,) filter; axis: 1 horizontal, 0 vertical.

    Returns:
        ``(where(count != 0, blur(z * m) * taps / count, 0), count != 0)`` cropped to the valid
        windows, ``count`` the mask's sum under each window.
    """
    zb = _valid(z * m, k, axis)
    count = _valid(m, np.ones_like(k), axis)
    support = count != 0
    out = np.where(support, zb * len(k) / np.where(support, count, 1.0), 0.0)
    return out, support.astype(np.float64)


def dycheck_ssim(pred: object, gt: object, *, weights: object = None,
                 data_range: float = 1.0) -> float:
    """DyCheck's ``compute_ssim`` (module docstring): partial-convolution SSIM, mean of the map.

    Args:
        pred, gt: (H, W) or (H, W, C) images in [0, 1], H, W >= 11.
        weights: (H, W) or (H, W, 1) mask in [0, 1]; None: ones (a plain valid-window SSIM
            with clamped variances).

    Returns:
        Mean SSIM over every valid window and channel, a Python float.

    Raises:
        InputError: shapes, a mask of another size, images below 11 x 11.
    """
    p, g = _check(pred, gt, data_range)
    if min(p.shape[:2]) < TAPS:
        raise InputError(f"DyCheck's SSIM needs images of at least {TAPS}x{TAPS}, got {p.shape[:2]}")
    m = _weights(weights, p.shape)[..., 0]
    k = gaussian_taps()

    def blur(z: np.ndarray) -> np.ndarray:
        h, mh = partial_blur(z, m, k, axis=1)
        return partial_blur(h, mh, k, axis=0)[0]

    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    maps = []
    for c in range(p.shape[2]):
        a, b = p[..., c].astype(np.float64), g[..., c].astype(np.float64)
        mu0, mu1 = blur(a), blur(b)
        s00 = np.maximum(0.0, blur(a * a) - mu0 * mu0)
        s11 = np.maximum(0.0, blur(b * b) - mu1 * mu1)
        s01 = blur(a * b) - mu0 * mu1
        s01 = np.sign(s01) * np.minimum(np.sqrt(s00 * s11), np.abs(s01))
        num = (2 * mu0 * mu1 + c1) * (2 * s01 + c2)
        den = (mu0 * mu0 + mu1 * mu1 + c1) * (s00 + s11 + c2)
        maps.append(num / den)
    return float(np.mean(np.stack(maps)))


def dycheck_lpips(score_map: Callable[[np.ndarray, np.ndarray], np.ndarray], pred: object,
                  gt: object, *, weights: object = None) -> float:
    """DyCheck's ``compute_lpips``: spatial LPIPS of the masked images, masked mean of the map.

    Args:
        score_map: ``(pred, gt) -> (H, W)`` spatial LPIPS map (``lpips_map`` with AlexNet).
        pred, gt: (H, W, 3) images in [0, 1].
        weights: (H, W) or (H, W, 1) mask in [0, 1]; None: the whole frame (mean of the map).
    """
    p, g = check_pair(pred, gt)
    p, g = _hwc(p).astype(np.float32), _hwc(g).astype(np.float32)
    if weights is None:
        return float(np.mean(score_map(p, g), dtype=np.float64))
    w = _weights(weights, p.shape)
    w32 = w.astype(np.float32)
    smap = np.asarray(score_map(p * w32, g * w32), dtype=np.float64)
    return masked_mean(smap[..., None], w)


class DyCheckProtocol(Protocol):
    """DyCheck's evaluation: 8-bit truncation, ``dycheck_psnr`` / ``dycheck_ssim`` /
    ``dycheck_lpips`` over the whole frame, and over the covisibility mask as its ``m*``
    metrics (the ``covisible`` region variant, ``mpsnr``, ``mssim``, ``mlpips``)."""

    name = "dycheck"
    reference = ("DyCheck dycheck/core/tasks/novel_view.py (to_quantized_float32, "
                 "mpsnr/mssim/mlpips), dycheck/core/metrics/image.py, "
                 "dycheck/nn/functional/common.py (masked_mean)")
    quantize = "truncate"
    psnr = "dycheck"
    ssim = "dycheck"
    clip = True
    masks = "covisible"
    lpips_reduce = "spatial-mean"

    def mask_regions(self) -> tuple[str, ...]:
        return ("covisible",)

    def apply_masks(self, pred: Any, gt: Any, weights: Any) -> Pair:
        """The images as they are: DyCheck's metrics weigh by the mask themselves."""
        return pred, gt

    def psnr_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return dycheck_psnr(pred, gt, data_range=data_range)

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return dycheck_ssim(pred, gt, data_range=data_range)

    def whole_psnr(self, pred: Any, gt: Any, *, data_range: float = 1.0,
                   weights: Any = None) -> float:
        """``dycheck_psnr``, over the mask's weights when given."""
        self.check_range(data_range)
        return dycheck_psnr(pred, gt, weights=weights, data_range=data_range)

    def whole_ssim(self, pred: Any, gt: Any, *, data_range: float = 1.0,
                   weights: Any = None) -> float:
        """``dycheck_ssim``, over the mask's weights when given."""
        self.check_range(data_range)
        return dycheck_ssim(pred, gt, weights=weights, data_range=data_range)

    def whole_lpips(self, pred: Any, gt: Any, *, score: Score, score_map: Callable[[Any, Any], Any],
                    score_unit: Score, weights: Any = None) -> float:
        """The mean of the spatial map (``dycheck_lpips``), over the mask when given."""
        pred, gt = np.clip(np.asarray(pred), 0, 1), np.clip(np.asarray(gt), 0, 1)
        return dycheck_lpips(score_map, pred, gt, weights=weights)

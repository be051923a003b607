"""MS-SSIM and D-SSIM, whole frame, as torchmetrics 1.9 computes MS-SSIM (K-Planes' call).

K-Planes logs ``MultiScaleStructuralSimilarityIndexMeasure(data_range=1.0)`` of torchmetrics with
every other argument at its default; the DyNeRF-benchmark tables report ``D-SSIM = (1 - MS-SSIM)
/ 2``. This module re-implements that MS-SSIM in float64 numpy (the tests hold it to
torchmetrics itself). Definition, read from torchmetrics 1.9 ``functional/image/ssim.py``
(``_ssim_update``, ``_multiscale_ssim_update``):

* 5 scales; at each, per channel: the Gaussian window (11 taps, sigma 1.5, normalised) over the
  image reflect-padded by 5 px without repeating the edge (torch ``reflect``), so every one of
  the H x W positions has a window;
* ``cs = (2 s_xy + C2) / (s_x^2 + s_y^2 + C2)`` with the variances clamped at 0 (the covariance is
  not clamped); ``ssim = (2 mu_x mu_y + C1) / (mu_x^2 + mu_y^2 + C1) * cs``;
  ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2``;
* per scale, the scale's ``cs`` is the mean of the cs map over the valid windows (the map
  cropped by 5 px on each side) and the channels; its ``ssim`` the mean of the full H x W map
  and the channels; both then pass through ``relu`` (``normalize="relu"``);
* between scales both images are 2 x 2 average-pooled (odd rows/columns dropped);
* ``MS-SSIM = prod_{i<4} relu(cs_i)^beta_i * relu(ssim_4)^beta_4``, betas (0.0448, 0.2856,
  0.3001, 0.2363, 0.1333).

The registry's ``msssim``/``dssim`` are the run's protocol's (``Protocol.whole_msssim``): these
functions, but under ``--protocol 4dgaussians`` 4DGaussians' (``dynaeval.metrics.protocol_3dgs``).

It needs images of at least 176 x 176 pixels (torchmetrics: ``H // 16 > 10``); smaller ones are
``UndefinedMetricError`` (the frame's value is null with the reason). Only the whole frame:
box crops are mostly smaller than that, and no paper defines a masked MS-SSIM.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dynaeval.core.errors import InputError, UndefinedMetricError
from dynaeval.core.validation import check_data_range, check_pair
from dynaeval.metrics.structural import RADIUS, gaussian_window

BETAS = (0.0448, 0.2856, 0.3001, 0.2363, 0.1333)
"""Weights of the 5 scales (Wang et al. 2003, torchmetrics' default)."""
MIN_SIZE = 16 * 10 + 16
"""Smallest height and width: torchmetrics needs ``size // 16 > 10`` (11-tap window, 5 scales)."""


def _scale_terms(x: np.ndarray, y: np.ndarray, c1: float, c2: float) -> tuple[float, float]:
    """(mean ssim over the full map, mean cs over the valid windows) of one scale, channels
    together. x, y: (H, W, C) float64."""
    import cv2

    k, r = gaussian_window(), RADIUS
    ssims, css = [], []
    for c in range(x.shape[2]):
        a, b = np.ascontiguousarray(x[..., c]), np.ascontiguousarray(y[..., c])

        def blur(z: np.ndarray) -> np.ndarray:
            return cv2.sepFilter2D(z, cv2.CV_64F, k, k, borderType=cv2.BORDER_REFLECT_101)

        ma, mb = blur(a), blur(b)
        saa = np.maximum(blur(a * a) - ma * ma, 0.0)
        sbb = np.maximum(blur(b * b) - mb * mb, 0.0)
        sab = blur(a * b) - ma * mb
        cs = (2 * sab + c2) / (saa + sbb + c2)
        ssims.append((2 * ma * mb + c1) / (ma * ma + mb * mb + c1) * cs)
        css.append(cs[r:-r, r:-r])
    return float(np.mean(np.stack(ssims))), float(np.mean(np.stack(css)))


def _pool(z: np.ndarray) -> np.ndarray:
    """2 x 2 average pooling of (H, W, C), odd last row/column dropped (``F.avg_pool2d``)."""
    h, w = z.shape[0] // 2 * 2, z.shape[1] // 2 * 2
    z = z[:h, :w]
    return 0.25 * (z[0::2, 0::2] + z[1::2, 0::2] + z[0::2, 1::2] + z[1::2, 1::2])


def ms_ssim(pred: object, gt: object, *, data_range: float = 1.0, clip: bool = False) -> float:
    """MS-SSIM of one image pair, torchmetrics 1.9's definition (module docstring), in float64.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range], channel last,
            H, W >= 176; values outside [0, data_range] are refused (with ``clip``, only
            those beyond ``validation.CLIPPED_LIMIT`` times the range).
        data_range: L in ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2`` (K-Planes: 1).
        clip: clip both images to [0, 1] first (the kplanes and nerfbaselines protocols): float
            overshoots up to ``validation.CLIPPED_LIMIT`` times the range are then expected and
            not refused; further out (0..255 floats) and integers with ``data_range <= 1``
            still are.

    Returns:
        MS-SSIM in [0, 1] (1 for identical images), a Python float.

    Raises:
        InputError: bad shapes or values. UndefinedMetricError: an image under 176 x 176 pixels.
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt, data_range=data_range, clipped=clip)
    x = (p[..., None] if p.ndim == 2 else p).astype(np.float64)
    y = (g[..., None] if g.ndim == 2 else g).astype(np.float64)
    if clip:
        x, y = np.clip(x, 0, 1), np.clip(y, 0, 1)
    h, w = x.shape[:2]
    if h < MIN_SIZE or w < MIN_SIZE:
        raise UndefinedMetricError(
            f"MS-SSIM needs images of at least {MIN_SIZE}x{MIN_SIZE} pixels (5 scales of an "
            f"11-tap window, as torchmetrics checks); got {h}x{w} (HxW): MS-SSIM and D-SSIM are "
            "undefined for this image (recorded as null)"
        )
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    terms = []
    for i in range(len(BETAS)):
        sim, cs = _scale_terms(x, y, c1, c2)
        terms.append(max(cs, 0.0) if i < len(BETAS) - 1 else max(sim, 0.0))
        x, y = _pool(x), _pool(y)
    return float(np.prod([t**beta for t, beta in zip(terms, BETAS, strict=True)]))


def d_ssim(pred: object, gt: object, *, data_range: float = 1.0, clip: bool = False) -> float:
    """D-SSIM = (1 - MS-SSIM) / 2 (the DyNeRF-benchmark tables'), in [0, 0.5], lower is better.

    Same arguments and errors as ``ms_ssim``.
    """
    return (1.0 - ms_ssim(pred, gt, data_range=data_range, clip=clip)) / 2.0


def _whole_only(name: str, ctx: Any) -> Any:
    """``fn(pred, gt, region)`` of ``msssim`` or ``dssim``: the protocol's MS-SSIM variant
    (``Protocol.whole_msssim`` / ``whole_dssim``), whole frame only."""
    protocol = ctx.whole()
    whole = protocol.whole_msssim if name == "msssim" else protocol.whole_dssim

    def score(pred: np.ndarray, gt: np.ndarray, region: dict[str, Any]) -> float:
        if region:
            raise InputError("MS-SSIM and D-SSIM are whole-frame metrics (no region variant)")
        return whole(pred, gt, data_range=ctx.data_range)

    return score


def build_msssim(ctx: Any) -> Any:
    """The registry's MS-SSIM for a run (whole frame; the protocol's variant, clipped when the
    protocol clips)."""
    return _whole_only("msssim", ctx)


def build_dssim(ctx: Any) -> Any:
    """The registry's D-SSIM for a run (whole frame; as ``build_msssim``)."""
    return _whole_only("dssim", ctx)


def msssim_settings(ctx: Any, enabled: bool, unavailable: str | None) -> dict[str, Any] | None:
    """What the results record of MS-SSIM / D-SSIM (None when neither was asked for): the
    protocol's variant (``Protocol.msssim_settings``)."""
    if not enabled:
        return None
    return ctx.whole().msssim_settings()


def torchmetrics_settings(clip: bool) -> dict[str, Any]:
    """The results' record of this module's MS-SSIM (``clip``: the images clipped to [0, 1]
    first, as ``ms_ssim(clip=...)``)."""
    return {
        "variant": "torchmetrics 1.9 MultiScaleStructuralSimilarityIndexMeasure defaults "
                   "(re-implemented in float64)",
        "win_size": 11, "sigma": 1.5, "k1": 0.01, "k2": 0.03, "betas": list(BETAS),
        "padding": "reflect, 5 px (cs over the valid windows, the last scale's ssim over all)",
        "normalize": "relu", "pooling": "2x2 average", "min_size": MIN_SIZE,
        "clip": clip,
        "dssim": "(1 - msssim) / 2",
    }

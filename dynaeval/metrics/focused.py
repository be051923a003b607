"""Focused (boxes around the action) and masked (moving pixels) metrics: thin names over the core.

* ``focused_*`` score the union of boxes: PSNR over the union's pixels (each counted once); SSIM
  and LPIPS by default on **crops** of each box, box-area-weighted (``region_mode="crop"``), so
  differences outside the boxes cannot change the score; ``region_mode="map"`` averages the
  whole-frame SSIM / spatial LPIPS map over the union instead.
* ``masked_*`` score the pixels of a boolean mask: PSNR of those pixels alone, SSIM / LPIPS as the
  mean of the whole-frame map over them.

A region with no pixel raises ``dynaeval.core.errors.EmptyRegionError`` (recorded as null, never 0).
"""

from __future__ import annotations

from dynaeval.metrics.perceptual import lpips
from dynaeval.metrics.pixel import psnr
from dynaeval.metrics.structural import ssim


def focused_psnr(pred: object, gt: object, boxes: object, *, data_range: float = 1.0) -> float:
    """PSNR in dB of the pixels inside the union of ``boxes`` ((N, 4), max exclusive); see ``psnr``."""
    return psnr(pred, gt, data_range=data_range, boxes=boxes)


def focused_ssim(
    pred: object, gt: object, boxes: object, *, data_range: float = 1.0, region_mode: str = "crop"
) -> float:
    """SSIM in the boxes: area-weighted SSIM of the crops (default) or map mean; see ``ssim``."""
    return ssim(pred, gt, data_range=data_range, boxes=boxes, region_mode=region_mode)


def focused_lpips(
    pred: object,
    gt: object,
    boxes: object,
    *,
    net: str = "alex",
    region_mode: str = "crop",
    device: object = None,
    pretrained_backbone: bool = True,
    seed: int = 0,
    backend: str = "torch",
) -> float:
    """LPIPS in the boxes: area-weighted LPIPS of the crops (default) or map mean; see ``lpips``."""
    return lpips(
        pred, gt, net=net, boxes=boxes, region_mode=region_mode, device=device,
        pretrained_backbone=pretrained_backbone, seed=seed, backend=backend,
    )


def masked_psnr(pred: object, gt: object, mask: object, *, data_range: float = 1.0) -> float:
    """PSNR in dB of the masked pixels alone (bool (H, W) mask); see ``psnr``."""
    return psnr(pred, gt, data_range=data_range, mask=mask)


def masked_ssim(pred: object, gt: object, mask: object, *, data_range: float = 1.0) -> float:
    """Mean of the whole-frame SSIM map over the masked pixels whose window fits; see ``ssim``."""
    return ssim(pred, gt, data_range=data_range, mask=mask)


def masked_lpips(
    pred: object,
    gt: object,
    mask: object,
    *,
    net: str = "alex",
    device: object = None,
    pretrained_backbone: bool = True,
    seed: int = 0,
    backend: str = "torch",
) -> float:
    """Mean of the whole-frame spatial LPIPS map over the masked pixels; see ``lpips``."""
    return lpips(
        pred, gt, net=net, mask=mask, device=device,
        pretrained_backbone=pretrained_backbone, seed=seed, backend=backend,
    )

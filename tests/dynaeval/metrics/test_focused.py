"""focused_* / masked_* are the core metrics restricted to boxes / masks (thin names)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dynaeval.errors import EmptyRegionError
from dynaeval.metrics import (
    focused_lpips,
    focused_psnr,
    focused_ssim,
    lpips,
    masked_lpips,
    masked_psnr,
    masked_ssim,
    psnr,
    ssim,
)


@pytest.fixture
def scene(rng):
    """A 'stadium' frame with a 'player' box; the prediction is perfect outside the box."""
    gt = rng.random((64, 80, 3)).astype(np.float32)
    pred = gt.copy()
    box = np.array([[30, 20, 62, 52]])
    pred[20:52, 30:62] = np.clip(gt[20:52, 30:62] + 0.2 * rng.standard_normal((32, 32, 3)), 0, 1)
    mask = np.zeros(gt.shape[:2], bool)
    mask[20:52, 30:62] = True
    return pred, gt, box, mask


def test_focused_equal_the_core_with_boxes(scene):
    pred, gt, box, _ = scene
    assert focused_psnr(pred, gt, box) == psnr(pred, gt, boxes=box)
    assert focused_ssim(pred, gt, box) == ssim(pred, gt, boxes=box, region_mode="crop")
    assert focused_ssim(pred, gt, box, region_mode="map") == ssim(pred, gt, boxes=box, region_mode="map")


def test_masked_equal_the_core_with_mask(scene):
    pred, gt, _, mask = scene
    assert masked_psnr(pred, gt, mask) == psnr(pred, gt, mask=mask)
    assert masked_ssim(pred, gt, mask) == ssim(pred, gt, mask=mask)


def test_errors_inside_the_region_move_focused_far_more_than_whole_frame(scene):
    pred, gt, box, mask = scene
    assert focused_psnr(pred, gt, box) < psnr(pred, gt) - 3.0  # box is 1/5 of the frame: -7 dB
    assert focused_psnr(pred, gt, box) == pytest.approx(psnr(pred, gt) + 10 * math.log10(mask.mean()), abs=1e-9)
    assert focused_ssim(pred, gt, box) < ssim(pred, gt)
    assert masked_ssim(pred, gt, mask) < ssim(pred, gt)


def test_errors_only_outside_give_perfect_focused_scores(scene):
    pred, gt, box, _ = scene
    outside = gt.copy()
    outside[:20] = pred[20:40]  # wrong content above the box only
    assert focused_psnr(outside, gt, box) == math.inf
    assert focused_ssim(outside, gt, box) == 1.0


def test_lpips_thin_names(scene):
    pytest.importorskip("lpips")
    pred, gt, box, mask = scene
    kw = {"pretrained_backbone": False, "seed": 0}
    assert focused_lpips(pred, gt, box, **kw) == lpips(pred, gt, boxes=box, **kw)
    assert masked_lpips(pred, gt, mask, **kw) == lpips(pred, gt, mask=mask, **kw)
    assert focused_lpips(pred, gt, box, region_mode="map", **kw) == masked_lpips(pred, gt, mask, **kw)


def test_frame_without_region_raises_empty_region(scene):
    pred, gt, _, _ = scene
    with pytest.raises(EmptyRegionError, match="no box"):
        focused_psnr(pred, gt, np.zeros((0, 4)))
    with pytest.raises(EmptyRegionError, match="mask holds no pixel"):
        masked_ssim(pred, gt, np.zeros(gt.shape[:2], bool))

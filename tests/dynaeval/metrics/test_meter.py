"""MetricMeter: mean of per-frame values, pooled PSNR beside it, nothing computed twice."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics import MetricMeter, psnr, ssim


def test_meter_means_per_frame_values_and_reports_pooled_psnr(rng):
    gt = [rng.random((16, 16, 3)) for _ in range(3)]
    pred = [g + s for g, s in zip(gt, (0.01, 0.05, 0.2), strict=True)]
    meter = MetricMeter(("psnr", "ssim"))
    rows = [meter.update(p, g) for p, g in zip(pred, gt, strict=True)]
    assert rows[0] == {"psnr": psnr(pred[0], gt[0]), "ssim": ssim(pred[0], gt[0])}
    out = meter.compute()
    assert out["psnr"] == pytest.approx(np.mean([psnr(p, g) for p, g in zip(pred, gt, strict=True)]), abs=1e-12)
    assert out["ssim"] == pytest.approx(np.mean([ssim(p, g) for p, g in zip(pred, gt, strict=True)]), abs=1e-12)
    pooled = -10 * math.log10((0.01**2 + 0.05**2 + 0.2**2) / 3)
    assert out["psnr_pooled"] == pytest.approx(pooled, abs=1e-9)
    assert out["psnr"] - out["psnr_pooled"] > 5  # the two protocols differ
    meter.reset()
    with pytest.raises(InputError, match="before any update"):
        meter.compute()


def test_failed_frame_is_not_half_recorded(rng):
    meter = MetricMeter(("psnr", "ssim"))
    a = rng.random((20, 20, 3))
    with pytest.raises(EmptyRegionError):
        meter.update(a, a * 0.5, mask=np.zeros((20, 20), bool))
    small = rng.random((8, 8, 3))
    with pytest.raises(InputError, match="at least 11x11"):
        meter.update(small, small * 0.5)  # PSNR succeeds, SSIM fails: nothing is kept
    assert meter.values == {"psnr": [], "ssim": []} and meter.pooled.count == 0


def test_identical_frame_makes_the_psnr_mean_inf(rng):
    a = rng.random((12, 12))
    meter = MetricMeter(("psnr",))
    meter.update(a, a)
    meter.update(a, a * 0.9)
    assert meter.compute()["psnr"] == math.inf


def test_unknown_metric_is_refused():
    with pytest.raises(InputError, match="must be among"):
        MetricMeter(("psnr", "fid"))

"""The metric registry covers every reported name with direction, range and unit."""

from __future__ import annotations

import math

import dynaeval.metrics as M
from dynaeval.metrics import METRICS


def test_every_image_metric_and_region_variant_is_registered():
    for base in ("psnr", "ssim", "lpips"):
        for prefix in ("", "focused_", "masked_"):
            name = prefix + base
            assert METRICS[name].name == name
            assert callable(getattr(M, name))  # a function of that name exists


def test_directions_ranges_units():
    assert METRICS["psnr"].higher_is_better and METRICS["psnr"].unit == "dB"
    assert METRICS["psnr"].range == (0.0, math.inf)
    assert METRICS["ssim"].direction == "higher" and METRICS["ssim"].range == (-1.0, 1.0)
    assert METRICS["masked_lpips"].direction == "lower"
    for name in ("warp_error", "tof", "tlp", "flicker", "lpips_alex", "lpips_vgg"):
        assert METRICS[name].direction == "lower"
    assert all(info.description for info in METRICS.values())

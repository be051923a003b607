"""The metric registry: every reported key is declared once, with direction, range and unit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dynaeval.metrics as M
from dynaeval.metrics import registry
from dynaeval.metrics.registry import METRICS, SPECS, FrameContext, build_frame_metrics, result_key


def test_every_image_metric_and_region_variant_is_registered():
    for base in ("psnr", "ssim", "lpips"):
        for region, prefix in (("whole", ""), ("focused", "focused_"), ("masked", "masked_")):
            name = prefix + base
            assert METRICS[name].name == name == result_key(base, region)
            assert METRICS[name].metric == base and METRICS[name].variant == region
            assert callable(getattr(M, name))  # a function of that name exists


def test_directions_ranges_units():
    assert METRICS["psnr"].higher_is_better and METRICS["psnr"].unit == "dB"
    assert METRICS["psnr"].range == (0.0, math.inf)
    assert METRICS["ssim"].direction == "higher" and METRICS["ssim"].range == (-1.0, 1.0)
    assert METRICS["masked_lpips"].direction == "lower"
    for name in ("warp_error", "tof", "tlp", "flicker", "focused_tof", "focused_flicker"):
        assert METRICS[name].direction == "lower"
    assert METRICS["presence_ball"].range == (0.0, 1.0)
    assert METRICS["tight_psnr_person"].unit == "dB" and METRICS["tight_psnr_person"].precision == 3
    assert all(info.description for info in METRICS.values())


def test_result_keys_are_made_by_the_registry():
    assert result_key("presence", cls="ball") == "presence_ball"
    assert result_key("warp_error", "focused") == "focused_warp_error"
    assert registry.keys_of("pair", "camera") == [
        "warp_error", "tof", "tlp", "flicker", "jod",
        "focused_warp_error", "focused_tof", "focused_tlp", "focused_flicker", "focused_jod"]
    assert registry.temporal_keys() == [  # what the temporal engine computes: not jod
        "warp_error", "tof", "tlp", "flicker",
        "focused_warp_error", "focused_tof", "focused_tlp", "focused_flicker"]
    assert registry.keys_of("object") == [
        "presence_person", "presence_ball", "tight_psnr_person", "tight_psnr_ball"]
    with pytest.raises(KeyError, match="no region variant 'masked'"):
        result_key("tof", "masked")
    with pytest.raises(KeyError, match="no class 'dog'"):
        result_key("presence", cls="dog")
    with pytest.raises(KeyError, match="kinds must be among"):
        registry.keys_of("video")
    with pytest.raises(KeyError, match="unknown metric 'nope'"):
        registry.spec("nope")
    assert registry.spec("focused_ssim") is SPECS["ssim"]


def test_every_spec_names_importable_functions():
    for spec in SPECS.values():
        for attr in ("build", "settings"):
            if getattr(spec, attr) is not None:
                assert callable(spec.load(attr)), (spec.name, attr)
        # frame metrics are built; of the camera metrics, the video ones (jod) are
        assert (spec.build is not None) == (spec.kind == "frame" or spec.name == "jod"), spec.name


def test_build_frame_metrics_orders_keys_region_major_and_records_settings(rng):
    built = build_frame_metrics(FrameContext(), ("psnr", "ssim"), ("whole", "focused", "masked"))
    assert list(built.fns) == ["psnr", "ssim", "focused_psnr", "focused_ssim", "masked_psnr",
                               "masked_ssim"]
    assert built.settings["lpips"] == {"enabled": False, "net": "alex"}  # asked for: no
    assert built.settings["ssim"]["win_size"] == 11
    img = rng.random((40, 40, 3))
    gt = np.clip(img + 0.05, 0, 1)
    region, fn = built.fns["focused_psnr"]
    assert region == "focused"
    assert fn(img, gt, {"boxes": [[0, 0, 20, 20]]}) == M.focused_psnr(img, gt, [[0, 0, 20, 20]])
    assert built.fns["psnr"][1](img, gt, {}) == M.psnr(img, gt)
    with pytest.raises(KeyError, match="unknown metric"):
        build_frame_metrics(FrameContext(), ("psnr", "tof"))



def test_each_metric_says_how_its_regions_reduce():
    assert SPECS["ssim"].rule("focused").startswith("SSIM/LPIPS: box-area-weighted mean over crops")
    assert SPECS["psnr"].rule("whole") is None
    assert "FLIP map over the union of the boxes" in SPECS["flip"].rule("focused")
    assert "FLIP map over the union" in METRICS["focused_flip"].description
    assert "crops" not in METRICS["masked_flip"].description

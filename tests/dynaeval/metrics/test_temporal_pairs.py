"""Per-pair temporal terms (dynaeval.metrics.temporal_pairs): E(x), tOF, tLP and pair_terms."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.errors import EmptyRegionError, InputError, WeightsUnavailableError
from dynaeval.metrics.flow import FlowCache, FlowConfig, valid_warp_mask
from dynaeval.metrics.registry import keys_of
from dynaeval.metrics.temporal_pairs import (
    Frames,
    default_lpips,
    pair_terms,
    tlp,
    tof,
    warping_error,
)

from .temporal_frames import H, W, mean_abs, panning, texture


def test_warping_error_direction_uses_the_flow_from_t_to_t_minus_1(rng):
    prev, cur = panning(texture(rng), 2, step=(3, -2))
    back = np.zeros((H, W, 2), np.float32)
    back[..., 0], back[..., 1] = -3, 2  # flow t -> t-1: content came from (x - 3, y + 2)
    valid = valid_warp_mask(back, -back)
    assert warping_error(prev, cur, back, valid) == 0.0
    assert warping_error(prev, cur, -back, valid_warp_mask(-back, back)) > 1e-3  # wrong direction
    assert warping_error(prev, cur, np.zeros_like(back)) > 1e-3


def test_warping_error_is_mse_on_kept_pixels_only(rng):
    prev = rng.random((H, W, 3)).astype(np.float32)
    cur = prev.copy()
    cur[:10] += 0.5  # error only in the top rows
    zero = np.zeros((H, W, 2), np.float32)
    region = np.zeros((H, W), bool)
    region[20:] = True
    assert warping_error(prev, cur, zero, region=region) == 0.0
    np.testing.assert_allclose(warping_error(prev, cur, zero), 0.25 * 10 / H, rtol=1e-6)
    with pytest.raises(EmptyRegionError, match="no pixel"):
        warping_error(prev, cur, zero, valid=np.zeros((H, W), bool))
    with pytest.raises(InputError, match="bool mask of shape"):
        warping_error(prev, cur, zero, region=region[1:])
    with pytest.raises(InputError, match="one shape"):
        warping_error(prev, cur[1:], zero)


def test_tof_is_mean_endpoint_difference():
    fp = np.zeros((H, W, 2), np.float32)
    fg = np.zeros((H, W, 2), np.float32)
    fg[..., 0], fg[..., 1] = 3.0, 4.0
    assert tof(fp, fg) == pytest.approx(5.0)
    assert tof(fg, fg) == 0.0
    region = np.zeros((H, W), bool)
    with pytest.raises(EmptyRegionError, match="holds no pixel"):
        tof(fp, fg, region)
    with pytest.raises(InputError, match="one shape"):
        tof(fp, fg[1:])


def test_tlp_focused_crop_is_grown_to_min_crop(rng):
    frames = [rng.random((H, W, 3)).astype(np.float32) for _ in range(2)]
    sizes = []

    def size_probe(a, b):
        sizes.append(a.shape[:2])
        return mean_abs(a, b)

    region = np.zeros((H, W), bool)
    region[60:63, 2:5] = True  # 3x3 px near the bottom-left corner
    tlp(*frames, *frames, size_probe, region, min_crop=32)
    assert sizes == [(32, 32), (32, 32)]
    with pytest.raises(EmptyRegionError, match="holds no pixel"):
        tlp(*frames, *frames, mean_abs, np.zeros((H, W), bool))


def test_tlp_with_random_backbone_lpips_is_zero_on_ground_truth(rng):
    torch = pytest.importorskip("torch")
    lpips = pytest.importorskip("lpips")
    net = lpips.LPIPS(pretrained=True, net="alex", pnet_rand=True, verbose=False)

    def lp(a, b):
        ta, tb = (
            torch.from_numpy(np.ascontiguousarray(x)).permute(2, 0, 1)[None] * 2 - 1 for x in (a, b)
        )
        with torch.no_grad():
            return float(net(ta, tb).item())

    prev, cur = panning(texture(rng), 2)
    assert tlp(prev, cur, prev, cur, lp) == 0.0
    noisy = cur + rng.normal(0, 0.1, cur.shape).astype(np.float32)
    assert tlp(prev, noisy, prev, cur, lp) > 0.0


# ------------------------------------------------------------------------------ pair_terms


def _pair(rng, regions=(None, None)):
    gt = panning(texture(rng), 2)
    pred = [np.clip(g + rng.normal(0, 0.05, g.shape), 0, 1).astype(np.float32) for g in gt]
    return Frames(pred[0], gt[0], regions[0]), Frames(pred[1], gt[1], regions[1])


def test_pair_terms_report_the_difference_of_the_two_sequences_warping_errors(rng):
    """per_pair["warp_error"] is |E(pred) - E(gt)| with E = warping_error on the GT's flow and
    visibility; tof and tlp are the pure functions' values, bit for bit."""
    region = np.zeros((H, W), bool)
    region[10:40, 20:60] = True
    prev, cur = _pair(rng, (region, np.roll(region, 3, axis=1)))
    cache = FlowCache()
    got = pair_terms(prev, cur, cache, FlowConfig(), mean_abs, min_crop=16, index=1)
    assert set(got["per_pair"]) == set(keys_of("pair")) and got["lpips_error"] is None

    fw, bw = cache.flow(prev.gt, cur.gt), cache.flow(cur.gt, prev.gt)
    valid = valid_warp_mask(bw, fw)
    union = prev.region | cur.region
    for key, r in (("warp_error", None), ("focused_warp_error", union)):
        e_pred = warping_error(prev.pred, cur.pred, bw, valid, r)
        e_gt = warping_error(prev.gt, cur.gt, bw, valid, r)
        assert got["parts"][key] == {"pred": e_pred, "gt": e_gt, "signed": e_pred - e_gt}
        assert got["per_pair"][key] == abs(e_pred - e_gt) > 0
    fp = cache.flow(prev.pred, cur.pred)
    assert got["per_pair"]["tof"] == tof(fp, fw)
    assert got["per_pair"]["focused_tof"] == tof(fp, fw, union)
    assert got["per_pair"]["tlp"] == tlp(prev.pred, cur.pred, prev.gt, cur.gt, mean_abs)
    assert got["per_pair"]["focused_tlp"] == tlp(
        prev.pred, cur.pred, prev.gt, cur.gt, mean_abs, union, 16
    )


def test_pair_terms_without_or_with_empty_regions_leave_the_focused_terms_null(rng):
    prev, cur = _pair(rng)
    got = pair_terms(prev, cur, FlowCache(), FlowConfig(), mean_abs)
    empty = np.zeros((H, W), bool)
    got_empty = pair_terms(prev._replace(region=empty), cur._replace(region=empty), FlowCache(),
                           FlowConfig(), mean_abs)
    for res in (got, got_empty):
        for key in keys_of("pair", region="focused"):
            assert res["per_pair"][key] is None, key
        assert res["parts"]["focused_warp_error"] == {"pred": None, "gt": None, "signed": None}
        assert res["per_pair"]["warp_error"] > 0
    assert got_empty["per_pair"] == got["per_pair"]


def test_pair_terms_without_lpips_weights_record_why_and_keep_the_other_terms(rng):
    def no_weights(a, b):
        raise WeightsUnavailableError("alexnet-owt-7be5be79.pth is not in ~/.cache/torch")

    prev, cur = _pair(rng)
    got = pair_terms(prev, cur, FlowCache(), FlowConfig(), no_weights)
    assert got["lpips_error"].startswith("LPIPS unavailable: WeightsUnavailableError: alexnet")
    assert "tlp" not in got["per_pair"] and "focused_tlp" not in got["per_pair"]
    assert got["per_pair"]["tof"] > 0
    assert "tlp" not in pair_terms(prev, cur, FlowCache(), FlowConfig(), None)["per_pair"]


def test_default_lpips_is_the_feature_split_for_torch():
    from dynaeval.metrics.perceptual import LpipsFeatures

    assert isinstance(default_lpips("alex"), LpipsFeatures)
    assert not isinstance(default_lpips("alex", backend="onnxruntime"), LpipsFeatures)

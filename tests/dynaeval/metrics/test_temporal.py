"""Temporal metrics: flow direction, warping, occlusion and the sequence API (the streaming engine).

The per-pair functions are tested in test_temporal_pairs.py, flicker in test_static_flicker.py.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from dynaeval.errors import InputError, WeightsUnavailableError
from dynaeval.metrics.flow import (
    FlowCache,
    FlowConfig,
    in_frame_mask,
    optical_flow,
    to_gray_u8,
    valid_warp_mask,
    warp,
    warp_reference,
)
from dynaeval.metrics.registry import keys_of, temporal_keys
from dynaeval.metrics.temporal import (
    TEMPORAL_METRICS,
    TemporalConfig,
    TemporalRun,
    flicker,
    temporal_metrics,
)

from .temporal_frames import H, W, mean_abs, panning, texture

ALL_NAMES = [
    "warp_error", "tof", "tlp", "flicker",
    "focused_warp_error", "focused_tof", "focused_tlp", "focused_flicker",
]
"""The result keys of temporal_metrics, in report order (written out: what users search for)."""


def test_result_keys_are_the_registrys_temporal_keys():
    assert temporal_keys() == ALL_NAMES  # jod, a camera metric too, is not the engine's
    assert keys_of("pair", "camera") == [*ALL_NAMES[:4], "jod", *ALL_NAMES[4:], "focused_jod"]
    assert TEMPORAL_METRICS == ("warp_error", "tof", "tlp", "flicker")


def test_the_engine_module_re_exports_the_per_pair_functions_and_flicker():
    from dynaeval.metrics import static_flicker, temporal, temporal_pairs

    for name in ("warping_error", "tof", "tlp", "default_lpips", "LpipsFn"):
        assert getattr(temporal, name) is getattr(temporal_pairs, name), name
    for name in ("flicker", "TemporalStd"):
        assert getattr(temporal, name) is getattr(static_flicker, name), name
    assert not hasattr(temporal, "warp_error")  # the result key, not a function (issue 15)


# ------------------------------------------------------------------------------ optical flow


@pytest.mark.parametrize("method", ["dis", "farneback", "tvl1"])
def test_flow_of_known_translation_has_right_sign_and_direction(rng, method):
    base = texture(rng)
    a = base[20 : 20 + H, 20 : 20 + W]
    b = base[22 : 22 + H, 17 : 17 + W]  # content moves by (+3, -2) px from a to b
    flow = optical_flow(a, b, FlowConfig(method=method))
    assert flow.shape == (H, W, 2) and flow.dtype == np.float32
    interior = flow[12:-12, 12:-12].reshape(-1, 2)
    np.testing.assert_allclose(np.median(interior, axis=0), [3.0, -2.0], atol=0.25)


@pytest.mark.parametrize("method", ["dis", "farneback", "tvl1"])
def test_flow_and_warp_give_the_same_bits_on_any_opencv_thread_count(rng, method):
    # scoring with workers > 1 runs OpenCV on one thread (runtime.opencv_threads), 1 worker on
    # OpenCV's default: equal numbers for any worker count rest on this
    from dynaeval.core.runtime import opencv_threads

    base = texture(rng, 240, 400)
    a, b = base[20:220, 20:380], base[23:223, 16:376]
    got = {}
    for n in (1, 2, 4):
        with opencv_threads(n):
            flow = optical_flow(a, b, FlowConfig(method=method))
            got[n] = flow, warp(b, flow)
    for n in (2, 4):
        np.testing.assert_array_equal(got[n][0], got[1][0])
        np.testing.assert_array_equal(got[n][1], got[1][1])


def test_flow_of_uint8_equals_flow_of_float_over_255(rng):
    a = (texture(rng)[:H, :W] * 255).round().astype(np.uint8)
    b = np.roll(a, 2, axis=1)
    np.testing.assert_array_equal(
        optical_flow(a, b), optical_flow(a / 255.0, b.astype(np.float32) / 255)
    )


def test_gray_conversion_is_bt601_luma():
    img = np.array(
        [[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]], np.float32
    )
    np.testing.assert_array_equal(to_gray_u8(img), [[76, 150, 29, 255]])


def test_flow_config_rejects_unknown_method_and_preset():
    with pytest.raises(InputError, match="flow method must be one of"):
        FlowConfig(method="raft")
    with pytest.raises(InputError, match="DIS preset must be one of"):
        FlowConfig(dis_preset="slow")


def test_flow_rejects_bad_input(rng):
    a = texture(rng)[:H, :W]
    with pytest.raises(InputError, match="two frames of one size"):
        optical_flow(a, a[:-1])
    with pytest.raises(InputError, match="NaN or Inf"):
        optical_flow(a, np.full_like(a, np.nan))
    with pytest.raises(InputError, match=r"\(H, W\) or \(H, W, C\)"):
        optical_flow(a[..., 0].ravel(), a[..., 0].ravel())
    with pytest.raises(InputError, match="1, 3 or 4 channels"):
        optical_flow(a[..., :2], a[..., :2])
    with pytest.raises(InputError, match="uint8 or float"):
        optical_flow(a > 0.5, a > 0.5)


def test_flow_cache_computes_each_pair_once_and_keys_on_content(rng, tmp_path):
    base = texture(rng)
    a, b = panning(base, 2)
    cache = FlowCache()
    f1 = cache.flow(a, b)
    f2 = cache.flow(a.copy(), b.copy())  # other arrays, same content
    assert f2 is f1 and (cache.hits, cache.misses) == (1, 1)
    cache.flow(b, a)
    cache.flow(a, b, FlowConfig(method="farneback"))
    assert cache.misses == 3
    np.testing.assert_array_equal(f1, optical_flow(a, b))
    assert not f1.flags.writeable

    disk = FlowCache(max_bytes=0, directory=tmp_path)
    f3 = disk.flow(a, b)
    assert len(disk) == 0 and len(list(tmp_path.glob("*.npy"))) == 1
    np.testing.assert_array_equal(FlowCache(directory=tmp_path).flow(a, b), f3)


def test_flow_cache_memory_is_bounded(rng):
    frames = panning(texture(rng), 4)
    one = H * W * 2 * 4
    cache = FlowCache(max_bytes=2 * one)
    for x, y in zip(frames, frames[1:], strict=False):
        cache.flow(x, y)
    assert len(cache) == 2
    with pytest.raises(InputError, match="max_bytes must be >= 0"):
        FlowCache(max_bytes=-1)


# ------------------------------------------------------------------------------ warping


def test_warp_matches_the_numpy_reference(rng):
    img = rng.random((H, W, 3)).astype(np.float32)
    flow = (rng.normal(size=(H, W, 2)) * 3).astype(np.float32)
    # OpenCV 5.0 here agrees to 6e-8; OpenCV 4.x rounds sample positions to 1/32 px (INTER_TAB_SIZE),
    # up to ~0.02 on this white-noise image: the tolerance covers both.
    np.testing.assert_allclose(warp(img, flow), warp_reference(img, flow), rtol=0, atol=0.02)
    np.testing.assert_allclose(
        warp(img[..., 0], flow), warp_reference(img[..., 0], flow), atol=0.02
    )


def test_warp_by_integer_flow_is_an_exact_shift(rng):
    img = rng.random((H, W, 3)).astype(np.float32)
    flow = np.zeros((H, W, 2), np.float32)
    flow[..., 0], flow[..., 1] = 3, -2
    out = warp(img, flow)  # out(y, x) = img(y - 2, x + 3)
    np.testing.assert_array_equal(out[2:, : W - 3], img[:-2, 3:])
    np.testing.assert_array_equal(warp(img, np.zeros_like(flow)), img)


def test_warp_rejects_mismatched_shapes(rng):
    img = rng.random((H, W, 3)).astype(np.float32)
    with pytest.raises(InputError, match="image and flow of one size"):
        warp(img, np.zeros((H + 1, W, 2), np.float32))
    with pytest.raises(InputError, match=r"\(H, W, 2\)"):
        warp(img, np.zeros((H, W, 3), np.float32))
    with pytest.raises(InputError, match="at most 4 channels"):
        warp(rng.random((H, W, 5)), np.zeros((H, W, 2), np.float32))


def test_valid_mask_keeps_consistent_pixels_and_drops_out_of_frame():
    flow_ts = np.zeros((H, W, 2), np.float32)
    flow_ts[..., 0] = -3.0  # frame t samples s three pixels to the left
    flow_st = -flow_ts
    valid = valid_warp_mask(flow_ts, flow_st)
    assert not valid[:, :3].any() and valid[:, 3:].all()
    np.testing.assert_array_equal(in_frame_mask(flow_ts), valid)
    # the same flow both ways is inconsistent (|f + g| = 2|f|) once |f| is large enough
    assert not valid_warp_mask(flow_ts, flow_ts)[:, 3:].any()
    # ... but tolerated for sub-pixel flows by the 0.5 px^2 slack
    small = np.full((H, W, 2), 0.2, np.float32)
    assert valid_warp_mask(small, small)[: H - 1, : W - 1].all()
    with pytest.raises(InputError, match="one shape"):
        valid_warp_mask(flow_ts, flow_st[1:])


# ------------------------------------------------------------------------------ sequence API


def test_ground_truth_against_itself_is_exactly_zero_for_every_metric(rng):
    gt = panning(texture(rng), 4)
    boxes = [np.array([[10 + 2 * t, 10, 40 + 2 * t, 40]]) for t in range(4)]
    res = temporal_metrics(
        gt,
        [g.copy() for g in gt],
        static_mask=np.ones((H, W), bool),
        region_masks=boxes,
        lpips_fn=mean_abs,
    )
    assert list(res) == ALL_NAMES
    for name, entry in res.items():
        assert entry.outcome.value == 0.0 and entry.outcome.detail is None, name
        if name != "flicker" and name != "focused_flicker":
            assert entry.per_pair == (0.0, 0.0, 0.0), name


@pytest.mark.parametrize("window", [1, 2, 5])
def test_pairs_on_an_executor_give_the_sequential_numbers(rng, window):
    """Pairs computed on threads (``executor``) fold in frame order: every value, per-pair list and
    part equals the sequential run's, bit for bit, for windows smaller and larger than the run."""
    from concurrent.futures import ThreadPoolExecutor

    gt = panning(texture(rng), 6)
    pred = [np.clip(g + rng.normal(0, 0.03, g.shape), 0, 1).astype(np.float32) for g in gt]
    boxes = [np.array([[10 + 2 * t, 10, 40 + 2 * t, 40]]) for t in range(6)]
    kw = {"static_mask": np.ones((H, W), bool), "region_masks": boxes, "lpips_fn": mean_abs}
    seq = temporal_metrics(pred, gt, **kw)
    with ThreadPoolExecutor(max_workers=2) as pool:
        par = temporal_metrics(iter(pred), iter(gt), run=TemporalRun(executor=pool, window=window), **kw)
    assert par == seq
    assert len(seq["tof"].per_pair) == 5 and seq["tof"].outcome.value > 0


def test_flow_cache_is_shared_safely_between_threads(rng):
    """Eight threads asking for the same two flows: one array per pair comes back to all of them,
    equal to a fresh computation, and the counters add up."""
    from concurrent.futures import ThreadPoolExecutor

    a, b = panning(texture(rng), 2)
    cache = FlowCache()
    with ThreadPoolExecutor(max_workers=8) as pool:
        got = list(pool.map(lambda k: cache.flow(*((a, b) if k % 2 else (b, a))), range(16)))
    assert len(cache) == 2 and cache.hits + cache.misses == 16
    forward = [f for k, f in enumerate(got) if k % 2]
    assert all(f is cache.flow(a, b) for f in forward)
    np.testing.assert_array_equal(forward[0], optical_flow(a, b))


def test_ground_truth_is_zero_without_a_shared_cache_for_every_flow_method(rng):
    gt = panning(texture(rng), 3)
    for method in ("dis", "farneback"):
        cfg = TemporalConfig(flow=FlowConfig(method=method), tlp=False)
        res = temporal_metrics(gt, gt, config=cfg)
        assert res["warp_error"].outcome.value == 0.0 and res["tof"].outcome.value == 0.0


def test_region_boxes_and_masks_give_the_same_focused_values(rng):
    from dynaeval.core.boxes import boxes_to_mask

    gt = panning(texture(rng), 3)
    pred = [g + rng.normal(0, 0.05, g.shape).astype(np.float32) for g in gt]
    boxes = [np.array([[5, 5, 30, 30], [40, 20, 70, 60]])] * 3
    masks = [boxes_to_mask(b, H, W) for b in boxes]
    a = temporal_metrics(pred, gt, region_masks=boxes, lpips_fn=mean_abs)
    b = temporal_metrics(pred, gt, region_masks=masks, lpips_fn=mean_abs)
    for name in ALL_NAMES:
        assert a[name].outcome.value == b[name].outcome.value, name
    assert a["focused_warp_error"].outcome.value != a["warp_error"].outcome.value


def test_warp_error_summary_is_pred_minus_gt_mean_of_pairs(rng):
    gt = panning(texture(rng), 4)
    pred = [g + rng.normal(0, 0.05, g.shape).astype(np.float32) for g in gt]
    res = temporal_metrics(pred, gt, config=TemporalConfig(tlp=False))
    e = res["warp_error"]
    assert e.parts["signed"] == pytest.approx(e.parts["pred"] - e.parts["gt"], abs=1e-12)
    assert e.outcome.value == pytest.approx(np.mean(e.per_pair), abs=1e-12)
    assert e.outcome.value > 0 and len(e.per_pair) == 3
    assert e.outcome.value >= abs(e.parts["signed"])


def test_warp_error_and_flicker_are_absolute_differences(rng):
    gt = panning(texture(rng), 4, step=(0, 0))
    gt = [g + rng.normal(0, 0.03, g.shape).astype(np.float32) for g in gt]  # noisy sensor
    steady = [gt[0]] * 4  # a prediction steadier than its ground truth
    res = temporal_metrics(steady, gt, static_mask=np.ones((H, W), bool), lpips_fn=mean_abs)
    for name in ("warp_error", "flicker"):
        term = res[name]
        assert term.parts["signed"] < 0 and term.outcome.value == pytest.approx(-term.parts["signed"])
    assert flicker(steady, gt, np.ones((H, W), bool)) == res["flicker"].outcome.value


def test_brightness_flicker_moves_the_metrics_monotonically(rng):
    gt = panning(texture(rng), 5)
    static = np.ones((H, W), bool)
    rows = []
    for amp in (0.0, 0.03, 0.06, 0.12):
        pred = [g * (1 + amp * (-1) ** t) for t, g in enumerate(gt)]
        res = temporal_metrics(pred, gt, static_mask=static, lpips_fn=mean_abs)
        rows.append([res[n].outcome.value for n in ("warp_error", "tlp", "flicker")])
    rows = np.array(rows)
    assert np.all(rows[0] == 0)
    assert np.all(np.diff(rows, axis=0) > 0), rows


def test_temporally_varying_noise_is_told_apart_from_static_noise_of_equal_psnr(rng):
    gt = panning(texture(rng), 5, step=(0, 0))  # static camera, static scene
    noise = rng.normal(0, 0.05, (H, W, 3)).astype(np.float32)
    static_noise = [g + noise for g in gt]
    # the same noise values, shuffled anew every frame: identical per-frame MSE, hence PSNR
    varying = [g + rng.permutation(noise.reshape(-1, 3)).reshape(noise.shape) for g in gt]
    mse = lambda ps: [float(((p - g) ** 2).mean()) for p, g in zip(ps, gt, strict=True)]  # noqa: E731
    np.testing.assert_allclose(mse(static_noise), mse(varying), rtol=1e-5)
    mask = np.ones((H, W), bool)
    s = temporal_metrics(static_noise, gt, static_mask=mask, lpips_fn=mean_abs)
    v = temporal_metrics(varying, gt, static_mask=mask, lpips_fn=mean_abs)
    assert s["flicker"].outcome.value == pytest.approx(0.0, abs=1e-6)
    assert v["flicker"].outcome.value > 0.02
    assert v["warp_error"].outcome.value > s["warp_error"].outcome.value + 1e-3
    assert v["tlp"].outcome.value > s["tlp"].outcome.value


def test_single_frame_gives_null_with_a_reason_for_every_metric(rng):
    frame = texture(rng)[:H, :W]
    res = temporal_metrics([frame], [frame], static_mask=np.ones((H, W), bool), lpips_fn=mean_abs)
    for name, entry in res.items():
        assert entry.outcome.value is None and "at least 2 frames, got 1" in entry.outcome.detail, name
    res = temporal_metrics([], [], lpips_fn=mean_abs)
    assert res["tof"].outcome.detail == "needs at least 2 frames, got 0"
    assert res["tof"].outcome.status == "undefined"


def test_all_dynamic_mask_gives_null_flicker_with_a_reason(rng):
    gt = panning(texture(rng), 3)
    res = temporal_metrics(gt, gt, static_mask=np.zeros((H, W), bool), lpips_fn=mean_abs)
    assert res["flicker"].outcome.value is None
    assert res["flicker"].outcome.detail == "no static pixel: the static mask is empty"
    assert res["flicker"].outcome.status == "empty-region"
    res = temporal_metrics(gt, gt, lpips_fn=mean_abs)
    assert res["flicker"].outcome.detail.startswith("no static mask given")
    assert res["focused_tof"].outcome.detail.startswith("no region masks given")


def test_empty_regions_give_null_per_pair_and_a_reason(rng):
    gt = panning(texture(rng), 3)
    empty = [np.zeros((0, 4))] * 3
    res = temporal_metrics(
        gt, gt, static_mask=np.ones((H, W), bool), region_masks=empty, lpips_fn=mean_abs
    )
    for name in ("focused_warp_error", "focused_tof", "focused_tlp"):
        assert res[name].outcome.value is None and res[name].per_pair == (None, None), name
        assert res[name].outcome.detail == "every pair's region was empty"
        assert res[name].outcome.status == "empty-region"
    assert res["focused_flicker"].outcome.detail == "no static pixel inside the regions"
    # one pair with a region is enough for a value
    some = [np.zeros((0, 4)), np.zeros((0, 4)), np.array([[0, 0, 20, 20]])]
    res = temporal_metrics(gt, gt, region_masks=some, lpips_fn=mean_abs)
    assert res["focused_tof"].per_pair == (None, 0.0) and res["focused_tof"].outcome.value == 0.0


def test_tlp_is_null_with_the_reason_when_lpips_is_off_or_missing(rng, monkeypatch):
    gt = panning(texture(rng), 2)
    res = temporal_metrics(gt, gt, config=TemporalConfig(tlp=False))
    assert res["tlp"].outcome.value is None and "disabled" in res["tlp"].outcome.detail

    import dynaeval.metrics.temporal as temporal

    def missing(net="alex", device=None, backend="torch"):
        raise ImportError("no module named lpips")

    monkeypatch.setattr(temporal, "default_lpips", missing)
    res = temporal_metrics(gt, gt)
    assert res["tlp"].outcome.detail == "LPIPS unavailable: ImportError: no module named lpips"
    assert res["tlp"].outcome.status == "unavailable"
    assert res["tof"].outcome.value == 0.0

    def no_weights(a, b):
        raise WeightsUnavailableError("alexnet-owt-7be5be79.pth is not in ~/.cache/torch")

    res = temporal_metrics(gt, gt, lpips_fn=no_weights, region_masks=[np.ones((H, W), bool)] * 2)
    for name in ("tlp", "focused_tlp"):
        assert res[name].outcome.value is None and res[name].per_pair == ()
        assert res[name].outcome.detail.startswith("LPIPS unavailable: WeightsUnavailableError: alexnet")
    assert res["focused_tof"].outcome.value == 0.0


def test_sequence_api_rejects_bad_input(rng):
    gt = panning(texture(rng), 3)
    with pytest.raises(InputError, match="different numbers of frames"):
        temporal_metrics(gt, gt[:2], lpips_fn=mean_abs)
    with pytest.raises(InputError, match="differ in shape"):
        temporal_metrics(gt, [g[1:] for g in gt], lpips_fn=mean_abs)
    with pytest.raises(InputError, match="fewer items than the 2 frames"):
        temporal_metrics(gt, gt, region_masks=[np.zeros((0, 4))], lpips_fn=mean_abs)
    with pytest.raises(InputError, match="region mask of frame 0 must have shape"):
        temporal_metrics(gt, gt, region_masks=[np.ones((3, 3), bool)] * 3, lpips_fn=mean_abs)
    with pytest.raises(InputError, match="frame 1 has shape"):
        temporal_metrics([gt[0], gt[1][1:]], [gt[0], gt[1][1:]], lpips_fn=mean_abs)
    with pytest.raises(InputError, match="static_mask must be a bool"):
        temporal_metrics(gt, gt, static_mask=np.ones((H, W)), lpips_fn=mean_abs)
    with pytest.raises(InputError, match="frame 1 has shape"):  # not an IndexError of the flicker
        temporal_metrics([gt[0], gt[1][1:]], [gt[0], gt[1][1:]], lpips_fn=mean_abs,
                         static_mask=np.ones((H, W), bool))


def test_settings_describe_the_flow_method():
    d = TemporalConfig(flow=FlowConfig(method="farneback")).describe()
    assert d["flow"]["method"] == "farneback" and d["flow"]["winsize"] == 15
    assert TemporalConfig().describe()["flow"] == {"method": "dis", "dis_preset": "medium"}


def test_importing_the_temporal_metrics_pulls_in_neither_torch_nor_cv2():
    code = (
        "import sys, dynaeval.metrics.temporal, dynaeval.metrics.temporal_pairs, "
        "dynaeval.metrics.static_flicker; "
        "print(sorted(m for m in ('torch', 'cv2', 'lpips') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


class CountingFeatures:
    """LpipsFeatures on a random backbone that counts its backbone runs."""

    def __init__(self):
        from dynaeval.metrics.perceptual import LpipsFeatures

        self.inner = LpipsFeatures(pretrained_backbone=False)
        self.calls = 0

    def features(self, x):
        self.calls += 1
        return self.inner.features(x)

    def distance(self, a, b):
        return self.inner.distance(a, b)

    def __call__(self, a, b):
        return self.inner(a, b)


@pytest.mark.parametrize("workers", [0, 2])
def test_tlp_from_features_equals_pairwise_lpips_and_runs_the_backbone_once_per_frame(rng, workers):
    """tLP through LpipsFeatures (each frame's features once, kept while a pair needs them) equals
    tLP through plain LPIPS calls bit for bit, sequentially and on threads."""
    from concurrent.futures import ThreadPoolExecutor

    from dynaeval.metrics.perceptual import lpips

    gt = panning(texture(rng), 5)
    pred = [np.clip(g + rng.normal(0, 0.05, g.shape), 0, 1).astype(np.float32) for g in gt]
    boxes = [np.array([[10, 10, 50, 50]])] * 5
    plain = temporal_metrics(pred, gt, region_masks=boxes,
                             lpips_fn=lambda a, b: lpips(a, b, pretrained_backbone=False))
    counting = CountingFeatures()
    pool = ThreadPoolExecutor(max_workers=workers) if workers else None
    try:
        got = temporal_metrics(pred, gt, region_masks=boxes, lpips_fn=counting,
                               run=TemporalRun(executor=pool))
    finally:
        if pool:
            pool.shutdown()
    for name in ("tlp", "focused_tlp"):
        assert got[name] == plain[name], name
    assert plain["tlp"].outcome.value > 0
    assert counting.calls == 2 * 5  # pred and gt of each frame, not 4 per pair



@pytest.mark.parametrize("shape", [(8, 100, 3), (12, 1000, 3), (15, 15)])
def test_optical_flow_refuses_frames_too_small_instead_of_crashing(shape):
    """OpenCV's DIS crashes the interpreter on an 8x100 frame: the flow refuses first."""
    from dynaeval.errors import UndefinedMetricError
    from dynaeval.metrics.flow import optical_flow

    a = np.zeros(shape, np.float32)
    with pytest.raises(UndefinedMetricError, match="optical flow needs frames of at least 16x16"):
        optical_flow(a, a)
    with pytest.raises(UndefinedMetricError, match="at least 16x16"):
        temporal_metrics([a, a], [a, a])


# ------------------------------------------------------------------------------ gaps (issue 32)


def test_frames_left_out_make_no_pair_but_the_pairs_around_them_are_scored():
    """Issue 32 item 6: frames 0, 1, 2, 4, 5 of a sequence (3 missing): the pairs (0, 1), (1, 2)
    and (4, 5) have the values they have in the full sequence, (2, 4) is None, and flicker is the
    std over the five frames given (as without positions: a std needs no neighbours)."""
    rng = np.random.default_rng(7)
    gt = panning(texture(rng), 6)
    pred = [np.clip(f + rng.normal(0, 0.02, f.shape).astype(np.float32), 0, 1) for f in gt]
    static = np.ones((H, W), bool)
    full = temporal_metrics(pred, gt, static_mask=static, lpips_fn=mean_abs)
    kept = [0, 1, 2, 4, 5]
    sub = ([pred[i] for i in kept], [gt[i] for i in kept])
    gapped = temporal_metrics(*sub, static_mask=static, lpips_fn=mean_abs, frame_indices=kept)
    for key in ("warp_error", "tof", "tlp"):
        want = [full[key].per_pair[k] for k in (0, 1, 4)]
        got = gapped[key].per_pair
        assert got[2] is None and [got[k] for k in (0, 1, 3)] == pytest.approx(want, rel=1e-9)
        assert gapped[key].outcome.value == pytest.approx(np.mean(want), rel=1e-9)
    plain = temporal_metrics(*sub, static_mask=static, lpips_fn=mean_abs)
    assert gapped["flicker"].outcome.value == plain["flicker"].outcome.value


def test_no_consecutive_frames_at_all_is_null_with_the_reason_and_bad_positions_raise():
    rng = np.random.default_rng(8)
    gt = panning(texture(rng), 3)
    res = temporal_metrics(gt, gt, lpips_fn=mean_abs, frame_indices=[0, 2, 4])
    assert res["tof"].outcome.value is None and res["tof"].per_pair == ()
    assert "no two of the 3 frames are consecutive" in res["tof"].outcome.detail
    with pytest.raises(InputError, match="frame_indices must increase: frame 1 is at 0"):
        temporal_metrics(gt, gt, lpips_fn=mean_abs, frame_indices=[1, 0, 2])
    with pytest.raises(InputError, match="frame_indices has 2 items, fewer than the frames"):
        temporal_metrics(gt, gt, lpips_fn=mean_abs, frame_indices=[0, 1])

"""SSIM: fast path vs scikit-image (1e-6) and vs the float64 reference, hard cases, regions.

Oracle: ``skimage.metrics.structural_similarity(gaussian_weights=True, sigma=1.5,
use_sample_covariance=False, data_range=1)`` on float64 input.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics import ssim, ssim_map, ssim_reference
from dynaeval.metrics.structural import K1, K2, WIN_SIZE, gaussian_window

skm = pytest.importorskip("skimage.metrics")

TOL = 1e-6


def _sk(a: np.ndarray, b: np.ndarray, data_range: float = 1.0) -> float:
    kw = {"gaussian_weights": True, "sigma": 1.5, "use_sample_covariance": False, "data_range": data_range}
    if a.ndim == 3:
        kw["channel_axis"] = -1
    return float(skm.structural_similarity(a.astype(np.float64), b.astype(np.float64), **kw))


@pytest.mark.parametrize("shape", [(11, 11, 3), (13, 29, 3), (37, 53, 3), (64, 41), (30, 30, 1), (25, 40, 5)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_ssim_matches_skimage_random(rng, shape, dtype):
    a = rng.random(shape).astype(dtype)
    b = np.clip(a + 0.1 * rng.standard_normal(shape), 0, 1).astype(dtype)
    assert abs(ssim(a, b) - _sk(a, b)) < TOL


@pytest.mark.parametrize("shape", [(31, 45), (64, 77)])
def test_ssim_matches_skimage_structured(rng, structured, shape):
    a = structured(*shape)
    b = np.clip(a + rng.normal(0, 0.03, a.shape), 0, 1)
    blurred = (a + np.roll(a, 1, axis=1)) / 2  # structural change, no noise
    assert abs(ssim(a, b) - _sk(a, b)) < TOL
    assert abs(ssim(a, blurred) - _sk(a, blurred)) < TOL


def test_ssim_matches_skimage_uint8_with_data_range_255(rng):
    a = rng.integers(0, 256, (40, 33, 3), dtype=np.uint8)
    b = np.clip(a.astype(int) + rng.integers(-20, 20, a.shape), 0, 255).astype(np.uint8)
    assert abs(ssim(a, b, data_range=255) - _sk(a, b, data_range=255)) < TOL
    assert abs(ssim(a, b, data_range=255) - ssim(a / 255.0, b / 255.0)) < TOL


def test_fast_map_equals_float64_reference(rng):
    a = rng.random((45, 38, 3))
    b = np.clip(a + 0.2 * rng.standard_normal(a.shape), 0, 1)
    fast, ref = ssim_map(a, b), ssim_reference(a, b)
    assert fast.shape == ref.shape == (45 - 10, 38 - 10)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-5)  # per window (float32 work)
    assert abs(fast.mean(dtype=np.float64) - ref.mean()) < TOL  # the score
    assert abs(ref.mean() - _sk(a, b)) < 1e-12  # the reference is scikit-image's number


def test_window_is_11_taps_summing_to_one():
    k = gaussian_window()
    assert k.shape == (WIN_SIZE,) == (11,)
    assert k.sum() == pytest.approx(1.0, abs=1e-15)
    assert k[5] == k.max() and np.allclose(k, k[::-1])


def test_constant_images():
    a = np.full((15, 15, 3), 0.25)
    assert ssim(a, a) == 1.0
    assert ssim(np.zeros((15, 15)), np.zeros((15, 15))) == 1.0  # 0/0 is handled by C1, C2
    b = np.full((15, 15, 3), 0.75)
    c1 = K1**2
    expected = (2 * 0.25 * 0.75 + c1) / (0.25**2 + 0.75**2 + c1)  # the structure term is C2/C2
    assert ssim(a, b) == pytest.approx(expected, abs=TOL)
    assert abs(ssim(a, b) - _sk(a, b)) < TOL
    assert K2 == 0.03


@pytest.mark.parametrize("shape", [(10, 20, 3), (20, 10), (1, 1, 3), (1, 1)])
def test_images_smaller_than_the_window_raise(shape):
    with pytest.raises(InputError, match=rf"at least 11x11 pixels.*got {shape[0]}x{shape[1]}"):
        ssim(np.zeros(shape), np.zeros(shape))
    with pytest.raises(InputError, match="at least 11x11"):
        ssim_map(np.zeros(shape), np.zeros(shape))


def test_float16_is_upcast(rng):
    a = rng.random((20, 20, 3)).astype(np.float16)
    b = rng.random((20, 20, 3)).astype(np.float16)
    assert ssim(a, b) == ssim(a.astype(np.float32), b.astype(np.float32))
    assert abs(ssim(a, b) - _sk(a, b)) < TOL


def test_grayscale_2d_equals_single_channel(rng):
    a, b = rng.random((20, 24)), rng.random((20, 24))
    assert ssim(a, b) == ssim(a[..., None], b[..., None])


def test_torch_tensor_input(rng):
    torch = pytest.importorskip("torch")
    a, b = rng.random((16, 16, 3)), rng.random((16, 16, 3))
    assert ssim(torch.from_numpy(a), torch.from_numpy(b)) == ssim(a, b)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), h=st.integers(11, 30), w=st.integers(11, 30), sigma=st.floats(0.02, 0.3))
def test_ssim_properties(seed, h, w, sigma):
    rng = np.random.default_rng(seed)
    gt = rng.random((h, w, 3))
    noise = sigma * rng.standard_normal(gt.shape)
    p1, p2 = gt + noise, gt + 2 * noise
    lo = min(p2.min(), 0.0)  # shifted into [0, L]: the noise leaves [0, 1]
    gt, p1, p2 = gt - lo, p1 - lo, p2 - lo
    L = float(max(p2.max(), gt.max(), 1.0))
    assert ssim(p1, gt, data_range=L) == ssim(gt, p1, data_range=L)  # symmetric
    assert ssim(gt, gt, data_range=L) == 1.0  # identical -> ideal
    assert ssim(p1, gt, data_range=L) <= 1.0 + 1e-7  # bounded (float32 may round up by < 1e-7)
    assert ssim(p2, gt, data_range=L) < ssim(p1, gt, data_range=L)  # more noise -> worse


# ---- regions ----------------------------------------------------------------------------------


def _pair(rng, shape=(60, 70, 3)):
    a = rng.random(shape)
    return a, np.clip(a + 0.15 * rng.standard_normal(shape), 0, 1)


def test_masked_ssim_is_the_map_mean_over_the_mask(rng):
    a, b = _pair(rng)
    mask = np.zeros(a.shape[:2], bool)
    mask[20:35, 12:50] = True
    mask[2:8, 2:8] = True  # partly within 5 px of the border: those pixels have no window
    ref = ssim_reference(a, b)  # map of pixels [5:-5, 5:-5]
    expected = ref[mask[5:-5, 5:-5]].mean()
    assert abs(ssim(a, b, mask=mask) - expected) < TOL


def test_counting_windows_without_mask_support_as_one_biases_towards_one(rng):
    """The trap: fill the map with 1 outside the mask (or copy gt there) and average everything."""
    a, b = _pair(rng)
    mask = np.zeros(a.shape[:2], bool)
    mask[20:35, 12:50] = True
    ours = ssim(a, b, mask=mask)
    full = ssim_map(a, b).astype(np.float64)
    biased = np.where(mask[5:-5, 5:-5], full, 1.0).mean()
    pasted = ssim(np.where(mask[..., None], b, a), a)  # pred = gt outside the mask
    assert ours + 0.05 < biased and ours < pasted
    assert abs(ours - full[mask[5:-5, 5:-5]].mean()) < TOL


def test_masked_ssim_uses_real_pixels_outside_the_mask(rng):
    a, b = _pair(rng)
    mask = np.zeros(a.shape[:2], bool)
    mask[30, 30] = True
    # the single window centred at (30, 30) sees pixels outside the mask
    expected = _sk(a[25:36, 25:36], b[25:36, 25:36])
    assert abs(ssim(a, b, mask=mask) - expected) < TOL


def test_mask_only_in_the_border_band_is_empty(rng):
    a, b = _pair(rng)
    mask = np.zeros(a.shape[:2], bool)
    mask[:5, :] = True
    with pytest.raises(EmptyRegionError, match="within 5 px of the image border"):
        ssim(a, b, mask=mask)


def test_focused_crop_mode_is_area_weighted_ssim_of_crops(rng):
    a, b = _pair(rng)
    boxes = np.array([[0, 0, 30, 20], [40, 30, 70, 60]])
    vals = [_sk(a[y0:y1, x0:x1], b[y0:y1, x0:x1]) for x0, y0, x1, y1 in boxes]
    areas = [600, 900]
    assert abs(ssim(a, b, boxes=boxes) - np.average(vals, weights=areas)) < TOL


def test_boxes_smaller_than_the_window_are_grown_with_real_pixels(rng):
    a, b = _pair(rng)
    # 4x4 box at (x 20..24, y 10..14) -> 11x11 crop x 17..28, y 7..18 (3 px before, 4 after)
    assert abs(ssim(a, b, boxes=[[20, 10, 24, 14]]) - _sk(a[7:18, 17:28], b[7:18, 17:28])) < TOL
    # near the corner with negative coordinates: clipped to [0, 0, 3, 2], grown to [0, 0, 11, 11]
    assert abs(ssim(a, b, boxes=[[-5, -5, 3, 2]]) - _sk(a[:11, :11], b[:11, :11])) < TOL


def test_crop_mode_ignores_differences_outside_the_boxes_map_mode_does_not(rng):
    gt = rng.random((60, 70, 3))
    pred = np.clip(gt + 0.2 * rng.standard_normal(gt.shape), 0, 1)
    box = np.array([[20, 20, 45, 40]])
    inside = np.zeros(gt.shape[:2], bool)
    inside[20:40, 20:45] = True
    pred[inside] = gt[inside]  # differs only outside the box
    assert ssim(pred, gt, boxes=box) == 1.0
    assert ssim(pred, gt, boxes=box, region_mode="crop") == 1.0
    assert ssim(pred, gt, boxes=box, region_mode="map") < 0.99  # windows at the box edge see outside


def test_map_mode_with_boxes_equals_mask_of_their_union(rng):
    a, b = _pair(rng)
    boxes = [[0, 0, 30, 20], [10, 10, 50, 50]]
    from dynaeval.core.boxes import boxes_to_mask

    m = boxes_to_mask(boxes, 60, 70)
    assert ssim(a, b, boxes=boxes, region_mode="map") == ssim(a, b, mask=m)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"region_mode": "mean"}, r"region_mode must be one of \('crop', 'map'\)"),
        ({"region_mode": "crop", "mask": np.ones((20, 20), bool)}, "region_mode='crop' needs boxes"),
        ({"data_range": -1}, "positive number"),
    ],
)
def test_ssim_input_errors(kwargs, match):
    with pytest.raises(InputError, match=match):
        ssim(np.zeros((20, 20)), np.zeros((20, 20)), **kwargs)


def test_ssim_shape_mismatch_and_nan():
    with pytest.raises(InputError, match="same shape"):
        ssim(np.zeros((20, 20)), np.zeros((20, 21)))
    bad = np.zeros((20, 20))
    bad[3, 3] = np.nan
    with pytest.raises(InputError, match="NaN or Inf"):
        ssim(bad, np.zeros((20, 20)))


def test_empty_regions_raise():
    z = np.zeros((20, 20))
    with pytest.raises(EmptyRegionError, match="mask holds no pixel"):
        ssim(z, z, mask=np.zeros((20, 20), bool))
    with pytest.raises(EmptyRegionError, match="no box"):
        ssim(z, z, boxes=[[30, 30, 40, 40]])


def test_opencv_gaussian_kernel_is_our_window():
    """OpenCV's (11, 1.5) Gaussian and the fast path's float32 taps are gaussian_window()."""
    cv2 = pytest.importorskip("cv2")
    from dynaeval.metrics.structural import _kernel

    k = cv2.getGaussianKernel(WIN_SIZE, 1.5, ktype=cv2.CV_64F).ravel()
    np.testing.assert_allclose(k, gaussian_window(), rtol=0, atol=1e-15)
    assert _kernel().dtype == np.float32
    np.testing.assert_allclose(_kernel(), gaussian_window(), rtol=1e-7, atol=0)


def test_banded_computation_equals_one_band(rng, monkeypatch):
    from dynaeval.metrics import structural

    a, b = _pair(rng, (150, 40, 3))
    whole = ssim_map(a, b)
    monkeypatch.setattr(structural, "BAND_ROWS", 7)  # 140 output rows in 20 bands
    np.testing.assert_array_equal(ssim_map(a, b), whole)


@pytest.mark.parametrize("threads", [2, 3, 50])
def test_threads_give_bit_identical_numbers(rng, monkeypatch, threads):
    from dynaeval.metrics import structural

    monkeypatch.setattr(structural, "BAND_ROWS", 9)  # 130 output rows in 15 bands
    a, b = _pair(rng, (140, 33, 3))
    assert ssim(a, b, threads=threads) == ssim(a, b)
    np.testing.assert_array_equal(ssim_map(a, b, threads=threads), ssim_map(a, b))


def test_whole_image_sum_path_equals_the_map_mean(rng):
    """ssim() sums bands without building the map; it must be the map's mean and scikit-image's."""
    a, b = _pair(rng, (75, 90, 3))
    assert abs(ssim(a, b) - float(ssim_map(a, b).mean(dtype=np.float64))) < 1e-9
    assert abs(ssim(a, b) - _sk(a, b)) < TOL


@pytest.mark.parametrize("level", [0.0, 1e-3, 0.5, 1.0])
def test_flat_dark_and_bright_windows_keep_the_constants_exact(rng, level):
    """Flat regions are where C1/C2 dominate and float32 cancellation would show (the fast path
    subtracts moments before adding the constants): nearly constant images near 0, 0.5 and 1."""
    a = np.full((40, 50, 3), level) + 1e-3 * rng.random((40, 50, 3))
    a = np.clip(a, 0, 1)
    b = np.clip(a + 2e-3 * rng.standard_normal(a.shape), 0, 1)
    assert abs(ssim(a, b) - _sk(a, b)) < TOL
    np.testing.assert_allclose(ssim_map(a, b), ssim_reference(a, b), rtol=0, atol=1e-5)


def test_too_small_is_an_undefined_metric_not_a_bad_input():
    """Issue 16 item 11: ``dynaeval.score`` records null for it and goes on (a distinct class,
    still an InputError for a direct call)."""
    from dynaeval.errors import UndefinedMetricError

    with pytest.raises(UndefinedMetricError, match=r"at least 11x11 pixels.*got 5x5.*undefined"):
        ssim(np.zeros((5, 5)), np.zeros((5, 5)))
    with pytest.raises(InputError, match="same shape") as info:
        ssim(np.zeros((12, 12)), np.zeros((12, 13)))
    assert not isinstance(info.value, UndefinedMetricError)


@pytest.mark.parametrize("channels", [1, 2, 3, 4, 7])
def test_tiles_cover_the_valid_columns_in_simd_clean_widths(channels):
    from dynaeval.metrics import structural

    span = structural.SIMD_SPAN // np.gcd(structural.SIMD_SPAN, channels)
    for width in range(WIN_SIZE, 900):
        tiles = structural._tiles(width, channels)
        covered = np.zeros(width, bool)
        for t0, t1 in tiles:
            assert 0 <= t0 and t1 <= width and t1 - t0 >= WIN_SIZE
            assert len(tiles) == 1 and width < span or (t1 - t0) % span == 0, (width, tiles)
            covered[t0 + structural.RADIUS : t1 - structural.RADIUS] = True
        assert covered[structural.RADIUS : width - structural.RADIUS].all() and tiles[-1][1] == width


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("width", [11, 40, 63, 64, 65, 71, 134, 199, 330, 701])
def test_tiling_changes_no_bit(rng, monkeypatch, channels, width):
    """The band's tiles (any TILE_VALUES) give the bits of one tile per row, for any channel
    count and width: no value is rounded by OpenCV's scalar tail code in one and not the other."""
    import threading

    from dynaeval.metrics import structural

    a, b = _pair(rng, (30, width, channels) if channels > 1 else (30, width))
    a255, b255 = np.round(a * 255), np.round(b * 255)
    results = []
    for tile_values in (64, 600, 10**6):
        monkeypatch.setattr(structural, "TILE_VALUES", tile_values)
        monkeypatch.setattr(structural, "_WORKSPACES", threading.local())
        results.append((ssim_map(a, b), ssim(a, b), ssim_map(a255, b255, data_range=255.0)))
    for got in results[1:]:
        np.testing.assert_array_equal(got[0], results[0][0])
        assert got[1] == results[0][1]
        np.testing.assert_array_equal(got[2], results[0][2])


def test_0_255_input_is_refused_not_scored_as_0_1(rng):
    """Issue 32: ssim of uint8 / float x 255 images at data_range=1 was scored (0.61)."""
    from dynaeval.metrics import focused_ssim, masked_ssim

    a = rng.integers(0, 256, (40, 50, 3)).astype(np.uint8)
    b = np.clip(a.astype(int) + rng.integers(-20, 21, a.shape), 0, 255).astype(np.uint8)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255, or pred / 255"):
        ssim(a, b)
    with pytest.raises(InputError, match=r"pred holds values in \[0, 255\].* data_range=255"):
        ssim(a * 1.0, b * 1.0)
    with pytest.raises(InputError, match="pass data_range=255"):
        ssim_map(a, b)
    with pytest.raises(InputError, match="pass data_range=255"):
        focused_ssim(a, b, np.array([[5, 5, 30, 30]]))
    mask = np.zeros((40, 50), bool)
    mask[10:30, 10:30] = True
    with pytest.raises(InputError, match="pass data_range=255"):
        masked_ssim(a, b, mask)
    assert abs(ssim(a, b, data_range=255) - ssim(a / 255, b / 255)) < TOL


def test_channel_first_tensor_is_told_to_permute(rng):
    """Issue 32: a (3, H, W) tensor got "SSIM needs at least 11x11 ... got 3x383"."""
    torch = pytest.importorskip("torch")
    t = torch.from_numpy(rng.random((3, 40, 383)))
    with pytest.raises(InputError, match=r"pred looks channel-first: shape \(3, 40, 383\) read as "
                                         r"\(C, H, W\).* pass x\.permute\(1, 2, 0\)"):
        ssim(t, t)


def _regions(rng, h, w):
    """Boxes of every kind (narrower than a SIMD-clean tile, at the edges, overlapping, thin,
    the whole image) and a mask."""
    boxes = np.array([[0, 0, w, h], [3, 2, 9, 7], [w - 70, h - 20, w, h], [0, 5, 66, 40],
                      [20, 10, 20 + min(64, w - 20), 30], [10, 0, 200, 3], [5, 5, 90, 60],
                      [40, 30, 120, 70]])
    mask = rng.random((h, w)) > 0.7
    mask[:, : w // 3] = False
    return boxes, mask


@pytest.mark.parametrize("shape", [(75, 210, 3), (64, 130), (50, 190, 1), (40, 150, 4)])
@pytest.mark.parametrize("data_range", [1.0, 255.0])
def test_reusing_the_whole_map_changes_no_bit(rng, monkeypatch, shape, data_range):
    """Issue 33: inside ``reusing_whole_map`` SSIM over boxes and masks reads the windows the
    whole-image SSIM of the same arrays computed; the numbers are the bits of the crops
    filtered on their own (every box alone, all boxes, the mask), and no crop is filtered
    again (but one narrower than a SIMD-clean tile)."""
    from dynaeval.metrics import structural

    a, b = _pair(rng, shape)
    a, b = (a * data_range).astype(np.float32), (b * data_range).astype(np.float32)
    boxes, mask = _regions(rng, *shape[:2])
    kw = {"data_range": data_range}
    cases = [{"boxes": boxes[i : i + 1]} for i in range(len(boxes))]
    cases += [{"boxes": boxes}, {"mask": mask}, {"boxes": boxes, "region_mode": "map"}]
    want = [ssim(a, b, **kw)] + [ssim(a, b, **kw, **c) for c in cases]
    bands = []
    real = structural._band
    monkeypatch.setattr(structural, "_band", lambda *x: bands.append(x[0].shape) or real(*x))
    with structural.reusing_whole_map():
        got = [ssim(a, b, **kw)]
        whole = len(bands)
        got += [ssim(a, b, **kw, **c) for c in cases]
    assert got == want
    span = structural._simd_span(1 if a.ndim == 2 else a.shape[2])
    assert all(s[1] < span * (1 if a.ndim == 2 else a.shape[2]) for s in bands[whole:])


def test_the_whole_map_is_reused_only_for_the_same_arrays(rng):
    from dynaeval.metrics import structural

    a, b = _pair(rng, (60, 140, 3))
    a, b = a.astype(np.float32), b.astype(np.float32)
    other = np.ascontiguousarray(a[::-1])
    boxes = np.array([[4, 4, 120, 50]])
    with structural.reusing_whole_map():
        ssim(a, b)
        assert ssim(other, b, boxes=boxes) == ssim(other.copy(), b, boxes=boxes)
        assert ssim(a, b, boxes=boxes, data_range=2.0) == ssim(a.copy(), b, boxes=boxes,
                                                               data_range=2.0)
    with structural.reusing_whole_map():
        assert structural._WHOLE.last is None  # nothing kept from an earlier block
    assert structural._WHOLE.last is None and not structural._WHOLE.on

"""PSNR, its sufficient statistics and 8-bit quantisation.

Oracle: a float64 numpy PSNR written out here (``_psnr64``), tolerance 1e-9 dB.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynaeval.core.boxes import boxes_to_mask
from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics import (
    SquaredErrorStats,
    psnr,
    psnr_from_stats,
    quantize,
    squared_error_stats,
)

ATOL_DB = 1e-9


def _psnr64(a: np.ndarray, b: np.ndarray, data_range: float = 1.0) -> float:
    d = a.astype(np.float64) - b.astype(np.float64)
    return 10.0 * math.log10(data_range**2 / np.mean(d * d))


@pytest.mark.parametrize("shape", [(37, 53, 3), (1, 1, 3), (64, 41), (7, 5, 1), (120, 91, 3)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_psnr_matches_float64_reference_random(rng, shape, dtype):
    a = rng.random(shape).astype(dtype)
    b = np.clip(a + 0.05 * rng.standard_normal(shape), 0, 1).astype(dtype)
    assert abs(psnr(a, b) - _psnr64(a, b)) < ATOL_DB


@pytest.mark.parametrize("shape", [(33, 47), (80, 60)])
def test_psnr_matches_float64_reference_structured(rng, structured, shape):
    a = structured(*shape).astype(np.float32)
    b = np.clip(a + rng.normal(0, 0.02, a.shape), 0, 1).astype(np.float32)
    assert abs(psnr(a, b) - _psnr64(a, b)) < ATOL_DB


def test_psnr_large_image_float32_accumulates_in_float64(rng):
    # 1.2M values with tiny errors: a float32 accumulator would drift by far more than 1e-9 dB
    a = rng.random((500, 800, 3)).astype(np.float32)
    b = (a + np.float32(1e-4) * rng.standard_normal(a.shape).astype(np.float32)).astype(np.float32)
    assert abs(psnr(a, b) - _psnr64(a, b)) < ATOL_DB


def test_identical_images_give_inf():
    a = np.full((4, 4, 3), 0.3)
    assert psnr(a, a) == math.inf
    assert squared_error_stats(a, a) == SquaredErrorStats(0.0, 48)


def test_uint8_with_data_range_255_equals_float(rng):
    a = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    b = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    assert abs(psnr(a, b, data_range=255) - psnr(a / 255.0, b / 255.0)) < ATOL_DB


def test_data_range_scales_as_20_log10(rng):
    a, b = rng.random((10, 10)), rng.random((10, 10))
    assert psnr(a * 2, b * 2, data_range=2.0) == pytest.approx(psnr(a, b), abs=ATOL_DB)
    assert psnr(a, b, data_range=2.0) == pytest.approx(psnr(a, b) + 20 * math.log10(2), abs=ATOL_DB)


def test_float16_is_upcast(rng):
    a = rng.random((9, 9, 3)).astype(np.float16)
    b = rng.random((9, 9, 3)).astype(np.float16)
    assert psnr(a, b) == psnr(a.astype(np.float32), b.astype(np.float32))


def test_torch_tensors_score_like_numpy(rng):
    torch = pytest.importorskip("torch")
    a, b = rng.random((12, 10, 3)).astype(np.float32), rng.random((12, 10, 3)).astype(np.float32)
    assert psnr(torch.from_numpy(a), torch.from_numpy(b)) == psnr(a, b)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_masked_psnr_is_psnr_of_the_masked_pixels_alone(rng, dtype):
    a = rng.random((40, 50, 3)).astype(dtype) ** 3
    b = np.clip(a + 0.1 * rng.standard_normal(a.shape), 0, 1).astype(dtype)
    mask = np.zeros((40, 50), bool)
    mask[5:15, 10:40] = True  # a rectangle: its bounding box is all True
    assert abs(psnr(a, b, mask=mask) - _psnr64(a[mask], b[mask])) < ATOL_DB
    mask[7, 12] = False  # not a rectangle any more
    mask[30:33, 0:4] = True
    assert abs(psnr(a, b, mask=mask) - _psnr64(a[mask], b[mask])) < ATOL_DB


def test_zeroing_outside_the_mask_inflates_psnr_by_minus_10_log10_fraction(rng):
    """The trap: zero pixels outside the mask and average the whole frame."""
    a = rng.random((40, 50, 3))
    b = np.clip(a + 0.1 * rng.standard_normal(a.shape), 0, 1)
    mask = np.zeros((40, 50), bool)
    mask[5:15, 10:40] = True
    fraction = mask.mean()
    naive = _psnr64(a * mask[..., None], b * mask[..., None])
    ours = psnr(a, b, mask=mask)
    assert naive - ours == pytest.approx(-10 * math.log10(fraction), abs=1e-9)
    assert naive - ours > 2.0  # a quarter-frame mask: +6 dB of inflation avoided


def test_boxes_are_their_union_each_pixel_once(rng):
    a = rng.random((30, 30, 3))
    b = rng.random((30, 30, 3))
    boxes = np.array([[0, 0, 20, 20], [10, 10, 30, 30]])
    mask = boxes_to_mask(boxes, 30, 30)
    assert psnr(a, b, boxes=boxes) == pytest.approx(psnr(a, b, mask=mask), abs=ATOL_DB)
    assert abs(psnr(a, b, boxes=boxes) - _psnr64(a[mask], b[mask])) < ATOL_DB
    stacked = np.concatenate([a[0:20, 0:20].reshape(-1, 3), a[10:30, 10:30].reshape(-1, 3)])
    stacked_b = np.concatenate([b[0:20, 0:20].reshape(-1, 3), b[10:30, 10:30].reshape(-1, 3)])
    assert squared_error_stats(a, b, boxes=boxes).count == mask.sum() * 3 < stacked.size
    assert psnr(a, b, boxes=boxes) != _psnr64(stacked, stacked_b)


def test_negative_box_coordinates_are_clipped_not_wrapped(rng):
    a, b = rng.random((20, 20)), rng.random((20, 20))
    assert psnr(a, b, boxes=[[-5, -3, 8, 6]]) == psnr(a, b, boxes=[[0, 0, 8, 6]])


def test_mean_of_per_frame_psnr_differs_from_pooled_psnr(rng):
    """style.md #3: NeRF tables mean per-frame PSNRs; pooling the squared error gives another number."""
    gt = [rng.random((16, 16, 3)) for _ in range(2)]
    pred = [gt[0] + 0.01, gt[1] + 0.2]
    stats = [squared_error_stats(p, g) for p, g in zip(pred, gt, strict=True)]
    per_frame = [psnr_from_stats(s) for s in stats]
    assert per_frame == pytest.approx([40.0, 20 * math.log10(5)], abs=1e-9)
    mean_of_frames = float(np.mean(per_frame))
    pooled = psnr_from_stats(stats[0] + stats[1])
    assert pooled == pytest.approx(-10 * math.log10((0.01**2 + 0.2**2) / 2), abs=1e-9)
    assert mean_of_frames - pooled > 10.0  # the two protocols disagree by 10.0 dB here


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), h=st.integers(1, 20), w=st.integers(1, 20), sigma=st.floats(0.001, 0.5))
def test_psnr_properties(seed, h, w, sigma):
    rng = np.random.default_rng(seed)
    gt = rng.random((h, w, 3))
    noise = sigma * rng.standard_normal(gt.shape)
    p1, p2 = gt + noise, gt + 2 * noise
    lo = min(p2.min(), gt.min(), 0.0)  # shifted into [0, L]: the noise leaves [0, 1]
    gt, p1, p2 = gt - lo, p1 - lo, p2 - lo
    L = max(p2.max(), gt.max())
    assert psnr(p1, gt, data_range=L) == psnr(gt, p1, data_range=L)  # symmetric
    assert psnr(gt, gt, data_range=L) == math.inf  # identical -> ideal
    assert psnr(p2, gt, data_range=L) < psnr(p1, gt, data_range=L)  # more noise -> worse
    assert psnr(p1, gt, data_range=L) - psnr(p2, gt, data_range=L) == pytest.approx(
        20 * math.log10(2), abs=1e-9)  # by 20 log10 2 dB
    gt, p1 = gt + lo, p1 + lo
    q, g8 = (np.clip(p1, 0, 1) * 255).astype(np.uint8), (gt * 255).astype(np.uint8)
    if np.any(q != g8):
        assert abs(psnr(q, g8, data_range=255) - psnr(q / 255.0, g8 / 255.0)) < ATOL_DB


def test_quantize_modes():
    x = np.array([[0.0, 0.5 / 255 + 1e-6, 254.7 / 255, 1.0, 1.2, -0.1]], dtype=np.float32)
    r = quantize(x, "round") * 255
    t = quantize(x, "truncate") * 255
    np.testing.assert_allclose(r, [[0, 1, 255, 255, 255, 0]], atol=1e-4)
    np.testing.assert_allclose(t, [[0, 0, 254, 255, 255, 0]], atol=1e-4)
    assert quantize(x, "round").dtype == np.float32
    assert np.array_equal(quantize(x, "none"), x)


def test_quantize_truncate_matches_astype_uint8(rng):
    x = rng.random((10, 10, 3)).astype(np.float32)
    np.testing.assert_array_equal(quantize(x, "truncate"), (x * 255).astype(np.uint8) / np.float32(255))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"pred": np.zeros((4, 4)), "gt": np.zeros((4, 5))}, "same shape"),
        ({"pred": np.zeros(4), "gt": np.zeros(4)}, r"\(H, W\) or \(H, W, C\)"),
        ({"pred": np.zeros((0, 4)), "gt": np.zeros((0, 4))}, "empty"),
        ({"pred": np.array([[np.nan, 0.0]]), "gt": np.zeros((1, 2))}, "pred contains 1 NaN or Inf"),
        ({"pred": np.zeros((1, 2)), "gt": np.array([[np.inf, 0.0]])}, "gt contains 1 NaN or Inf"),
        ({"pred": np.array([["a"]]), "gt": np.array([["b"]])}, "must hold numbers"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "data_range": 0}, "positive number"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "data_range": "x"}, "positive number"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "mask": np.ones((2, 3), bool)}, r"mask must have the image's shape \(2, 2\)"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "mask": np.full((2, 2), 0.5)}, "boolean"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "mask": np.ones((2, 2), bool), "boxes": [[0, 0, 1, 1]]}, "not both"),
        ({"pred": np.zeros((2, 2)), "gt": np.ones((2, 2)), "boxes": [[0, 0, 1]]}, r"shape \(N, 4\)"),
    ],
)
def test_psnr_input_errors(kwargs, match):
    with pytest.raises(InputError, match=match):
        psnr(**kwargs)


@pytest.mark.parametrize(
    "region",
    [
        {"mask": np.zeros((5, 5), bool)},
        {"boxes": [[10, 10, 20, 20]]},
        {"boxes": np.zeros((0, 4))},
        {"boxes": [[3, 3, 3, 5]]},
    ],
)
def test_empty_region_raises(region):
    with pytest.raises(EmptyRegionError, match="no"):
        psnr(np.zeros((5, 5)), np.ones((5, 5)), **region)


def test_psnr_from_stats_and_quantize_errors():
    with pytest.raises(InputError, match="at least one value"):
        psnr_from_stats(SquaredErrorStats(1.0, 0))
    with pytest.raises(InputError, match="quantize mode must be one of none, round, truncate"):
        quantize(np.zeros((2, 2)), "floor")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_differences_are_taken_in_float64(dtype):
    """1 - 3e-8 rounds to 1 in float32: a float32 subtraction would be off by 1.2e-5 dB here."""
    a = np.ones((40, 40, 3), dtype=dtype)
    b = np.full((40, 40, 3), 3e-8, dtype=np.float32).astype(dtype)
    assert abs(psnr(a, b) - _psnr64(a, b)) < ATOL_DB


@pytest.mark.parametrize("shape", [(37, 53, 3), (50, 20), (9, 9, 6), (3, 1, 4)])
def test_fast_sse_equals_numpy_reference(rng, shape):
    from dynaeval.metrics.pixel import _sse, _sse_numpy

    a = rng.random(shape).astype(np.float32) ** 3
    b = rng.random(shape).astype(np.float32)
    assert _sse(a, b) == pytest.approx(_sse_numpy(a, b), rel=1e-13)
    assert _sse(a, b.astype(np.float64)) == pytest.approx(_sse_numpy(a, b), rel=1e-13)
    nc = np.asfortranarray(a)  # non-contiguous layouts are handled too
    assert _sse(nc, b) == pytest.approx(_sse_numpy(a, b), rel=1e-13)
    mask = rng.random(shape[:2]) > 0.3  # the masked path indexes first: (n, C) arrays
    assert _sse(a[mask], b[mask]) == pytest.approx(_sse_numpy(a[mask], b[mask]), rel=1e-13)


def test_bad_pixels_are_errors_inside_and_outside_the_region():
    a = np.zeros((8, 8))
    b = np.zeros((8, 8))
    b[0, 0] = np.inf
    a[0, 0] = np.inf  # inf - inf is NaN: still caught
    with pytest.raises(InputError, match="pred contains 1 NaN or Inf"):
        psnr(a, b)
    with pytest.raises(InputError, match="NaN or Inf"):
        psnr(a, b, boxes=[[4, 4, 8, 8]])


def test_overflowing_squared_error_is_an_error():
    with pytest.raises(InputError, match="overflows float64"):
        psnr(np.full((2, 2), 1e200), np.zeros((2, 2)), data_range=1e200)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(-5, 30), st.integers(-5, 30), st.integers(1, 20), st.integers(1, 20)), min_size=1, max_size=6))
def test_disjoint_rectangles_cover_the_union_once(raw):
    from dynaeval.core.boxes import clip_boxes
    from dynaeval.metrics.pixel import disjoint_rectangles

    boxes = clip_boxes(np.array([[x, y, x + w, y + h] for x, y, w, h in raw]), 25, 30)
    cover = np.zeros((25, 30), int)
    for x0, y0, x1, y1 in disjoint_rectangles(boxes):
        cover[y0:y1, x0:x1] += 1
    assert np.array_equal(cover, boxes_to_mask(boxes, 25, 30).astype(int))


def _u8_pair(rng, shape=(40, 50, 3)):
    a = rng.integers(0, 256, shape).astype(np.uint8)
    return a, np.clip(a.astype(int) + rng.integers(-20, 21, shape), 0, 255).astype(np.uint8)


def test_0_255_input_is_refused_not_scored_as_0_1(rng):
    """Issue 32: psnr(uint8, uint8) returned -17.39 dB; float x 255 as much nonsense."""
    from dynaeval.metrics import focused_psnr, masked_psnr

    a, b = _u8_pair(rng)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255, or pred / 255"):
        psnr(a, b)
    with pytest.raises(InputError, match=r"pred holds values in \[0, 255\].* data_range=255"):
        psnr(a.astype(np.float32), b.astype(np.float32))
    with pytest.raises(InputError, match=r"gt holds values in \[0, 255\]"):
        psnr(a / 255.0, b.astype(np.float32))
    boxes = np.array([[5, 5, 30, 30]])
    with pytest.raises(InputError, match="pass data_range=255"):
        focused_psnr(a, b, boxes)
    with pytest.raises(InputError, match="pass data_range=255"):
        masked_psnr(a, b, boxes_to_mask(boxes, 40, 50))
    with pytest.raises(InputError, match="pass data_range=255"):
        squared_error_stats(a, b, data_range=1.0)
    want = psnr(a / 255.0, b / 255.0)  # the fixes the messages give, and they agree
    assert abs(psnr(a, b, data_range=255) - want) < ATOL_DB
    assert abs(focused_psnr(a, b, boxes, data_range=255) - focused_psnr(a / 255, b / 255, boxes)) < ATOL_DB


def test_channel_first_input_is_refused_not_scored(rng):
    """Issue 32: psnr on (3, H, W) silently scored an image 3 pixels high."""
    a, b = _u8_pair(rng, (3, 40, 50))
    with pytest.raises(InputError, match=r"pred looks channel-first: shape \(3, 40, 50\).*"
                                         r"np\.moveaxis\(x, 0, -1\)"):
        psnr(a / 255.0, b / 255.0)
    torch = pytest.importorskip("torch")
    with pytest.raises(InputError, match=r"x\.permute\(1, 2, 0\)"):
        psnr(torch.from_numpy(a / 255.0), torch.from_numpy(b / 255.0))

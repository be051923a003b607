"""Box geometry (dynaeval.core.boxes): format checks, clipping, masks, growing, IoU and NMS."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynaeval.core.boxes import (
    as_boxes,
    batched_nms,
    box_iou_matrix,
    boxes_to_mask,
    clip_boxes,
    grow_box,
    mask_to_box,
    nms,
)
from dynaeval.errors import InputError


def test_as_boxes_accepts_one_box_many_or_none():
    assert as_boxes([1, 2, 3, 4]).tolist() == [[1, 2, 3, 4]]
    assert as_boxes(np.array([[0.0, 1.0, 2.0, 3.0]])).tolist() == [[0, 1, 2, 3]]  # whole floats
    assert as_boxes(np.array([[0.0, 1.0, 2.0, 3.0]])).dtype == np.int64
    assert as_boxes([[5, 5, 5, 9]]).tolist() == [[5, 5, 5, 9]]  # empty, not inverted: no pixel
    assert as_boxes([]).shape == (0, 4)


@pytest.mark.parametrize(
    ("boxes", "match"),
    [
        ([1, 2, 3], r"shape \(N, 4\) as \[x_min, y_min, x_max, y_max\], got \(3,\)"),
        ([[1, 2, 3, 4, 5]], r"shape \(N, 4\).*got \(1, 5\)"),
        ([[0, 0, np.nan, 4]], "NaN or Inf coordinates"),
        ([[0, 0, np.inf, 4]], "NaN or Inf coordinates"),
        ([[0, 0, 4, 4], [0.4, 0.6, 2.5, 3.5]],
         r"box 1 \[0\.4, 0\.6, 2\.5, 3\.5\] has fractional pixel coordinates.*np\.floor"),
        ([[20, 10, 10, 20]], r"box 0: inverted box \[20, 10, 10, 20\]: x_max must be >= x_min"),
        ([[0, 0, 4, 4], [0, 9, 4, 3]], r"box 1: inverted box \[0, 9, 4, 3\]: y_max must be >= y_min"),
    ],
)
def test_as_boxes_errors(boxes, match):
    with pytest.raises(InputError, match=match):
        as_boxes(boxes)


def test_clip_boxes_clips_never_wraps_and_drops_empty():
    out = clip_boxes([[-5, -5, 3, 4], [8, 8, 20, 20], [12, 0, 15, 5]], height=10, width=10)
    assert out.tolist() == [[0, 0, 3, 4], [8, 8, 10, 10]]


def test_boxes_to_mask_is_the_union_and_mask_to_box_the_tight_box():
    mask = boxes_to_mask([[1, 1, 4, 3], [2, 2, 5, 6], [-3, 8, 2, 20]], 10, 8)
    assert mask.sum() == 6 + 12 - 2 + 4
    assert mask_to_box(mask).tolist() == [0, 1, 5, 10]
    assert mask_to_box(np.zeros((4, 4), bool)) is None
    one = np.zeros((6, 6), bool)
    one[2, 3] = True
    assert mask_to_box(one).tolist() == [3, 2, 4, 3]  # max exclusive


@pytest.mark.parametrize(
    ("box", "expected"),
    [
        ([10, 10, 14, 20], [8, 10, 16, 20]),  # width 4 -> 8, centred; height kept
        ([10, 10, 13, 20], [8, 10, 16, 20]),  # odd extra (5): the extra pixel goes right
        ([0, 0, 2, 2], [0, 0, 8, 8]),  # shifted inside at the top-left
        ([38, 28, 40, 30], [32, 22, 40, 30]),  # and at the bottom-right
    ],
)
def test_grow_box(box, expected):
    assert grow_box(np.array(box), 8, 8, height=30, width=40).tolist() == expected


def test_grow_box_to_the_whole_image_when_it_is_smaller_than_the_minimum():
    assert grow_box(np.array([2, 2, 4, 4]), 64, 3, height=10, width=20).tolist() == [2, 0, 5, 10]


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.integers(0, 50), st.data())
def test_grow_box_contains_the_box_and_stays_inside(h, w, minimum, data):
    x0 = data.draw(st.integers(0, w - 1))
    y0 = data.draw(st.integers(0, h - 1))
    x1 = data.draw(st.integers(x0 + 1, w))
    y1 = data.draw(st.integers(y0 + 1, h))
    gx0, gy0, gx1, gy1 = grow_box(np.array([x0, y0, x1, y1]), minimum, minimum, h, w).tolist()
    assert 0 <= gx0 <= x0 and x1 <= gx1 <= w and 0 <= gy0 <= y0 and y1 <= gy1 <= h
    assert gx1 - gx0 == max(x1 - x0, min(minimum, w))
    assert gy1 - gy0 == max(y1 - y0, min(minimum, h))


def _tlp_crop_reference(box, min_side, h, w):
    """The tLP crop rule as metrics/temporal wrote it, before it used grow_box."""
    box = list(box)
    for lo, hi, size, idx in ((box[0], box[2], w, 0), (box[1], box[3], h, 1)):
        side = min(max(hi - lo, min_side), size)
        start = min(max((lo + hi - side) // 2, 0), size - side)
        box[idx], box[idx + 2] = start, start + side
    return box


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.integers(0, 50), st.data())
def test_grow_box_odd_pixel_before_is_the_tlp_crop(h, w, minimum, data):
    x0 = data.draw(st.integers(0, w - 1))
    y0 = data.draw(st.integers(0, h - 1))
    box = [x0, y0, data.draw(st.integers(x0 + 1, w)), data.draw(st.integers(y0 + 1, h))]
    ours = grow_box(np.array(box), minimum, minimum, h, w, odd_pixel="before").tolist()
    assert ours == _tlp_crop_reference(box, minimum, h, w)


def test_grow_box_odd_pixel():
    box = np.array([10, 10, 13, 20])
    assert grow_box(box, 8, 8, 30, 40, odd_pixel="before").tolist() == [7, 10, 15, 20]
    with pytest.raises(InputError, match="odd_pixel must be 'after' or 'before', got 'left'"):
        grow_box(box, 8, 8, 30, 40, odd_pixel="left")


def test_box_iou_matrix():
    a = np.array([[0, 0, 2, 2], [0, 0, 0, 0]], float)
    b = np.array([[1, 1, 3, 3], [0, 0, 2, 2], [5, 5, 6, 6]], float)
    iou = box_iou_matrix(a, b)
    np.testing.assert_allclose(iou, [[1 / 7, 1.0, 0.0], [0.0, 0.0, 0.0]])
    # integer boxes (pixel coordinates from a boxes file) give the float64 answer, not a
    # casting error; float32 boxes keep their dtype
    np.testing.assert_array_equal(box_iou_matrix(a.astype(np.int64), b.astype(np.int32)), iou)
    assert box_iou_matrix(a.astype(np.float32), b.astype(np.float32)).dtype == np.float32


def test_batched_nms_of_nothing():
    assert batched_nms(np.zeros((0, 4)), np.zeros(0), np.zeros(0, np.int64), 0.5).shape == (0,)


boxes_strategy = st.lists(
    st.tuples(
        st.floats(0, 50), st.floats(0, 50), st.floats(0.5, 30), st.floats(0.5, 30), st.integers(0, 2)
    ),
    min_size=0,
    max_size=40,
)


@settings(max_examples=60, deadline=None)
@given(boxes_strategy, st.floats(0.0, 1.0))
def test_nms_matches_torchvision(rows, iou):
    torch = pytest.importorskip("torch")
    ops = pytest.importorskip("torchvision.ops")
    b = np.array([[x, y, x + w, y + h] for x, y, w, h, _ in rows], np.float64).reshape(-1, 4)
    cls = np.array([c for *_, c in rows], np.int64)
    scores = np.linspace(1.0, 0.01, len(rows))[np.random.default_rng(len(rows)).permutation(len(rows))]
    ours = nms(b, scores, iou)
    ref = ops.nms(torch.from_numpy(b), torch.from_numpy(scores), iou).numpy()
    np.testing.assert_array_equal(ours, ref)
    np.testing.assert_array_equal(nms(b, scores, iou, block=3), ref)  # many blocks
    ours_b = batched_nms(b, scores, cls, iou)
    ref_b = ops.batched_nms(torch.from_numpy(b), torch.from_numpy(scores), torch.from_numpy(cls), iou).numpy()
    np.testing.assert_array_equal(ours_b, ref_b)


def test_metric_on_an_inverted_box_names_it_not_an_empty_region():
    """``psnr(..., boxes=)`` used to drop an inverted box and report "no box has a pixel inside
    the image"; a fractional box was rounded without a word."""
    from dynaeval.metrics import psnr

    img = np.zeros((32, 32, 3), np.float32)
    with pytest.raises(InputError, match=r"inverted box \[20, 10, 10, 20\]"):
        psnr(img, img + 0.1, boxes=[[20, 10, 10, 20]])
    with pytest.raises(InputError, match="fractional pixel coordinates"):
        psnr(img, img + 0.1, boxes=[[10.6, 10, 20, 20]])

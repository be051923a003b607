"""Box expansion (paper / margin / none), clipping and merging."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynaeval.core.boxes import boxes_to_mask
from dynaeval.errors import InputError
from dynaeval.regions.expand import ExpandConfig, expand_box, expand_boxes, merge_boxes


def test_paper_rule_scales_about_centre():
    # 10 x 20 box centred at (15, 20): width x7 = 70, height x2.5 = 50
    assert expand_box([10, 10, 20, 30], rule="paper").tolist() == [-20, -5, 50, 45]


def test_paper_rule_rounds_outwards():
    # 3 x 3 box at (0, 0): centre 1.5, half width 10.5 -> [-9, -2.25] .. [12, 5.25]
    assert expand_box([0, 0, 3, 3], rule="paper").tolist() == [-9, -3, 12, 6]


def test_margin_rule():
    cfg = ExpandConfig.preset("margin", margin_px=2, margin_frac=0.5)
    # w=10 -> dx = 2 + 5 = 7; h=20 -> dy = 2 + 10 = 12
    assert expand_box([10, 10, 20, 30], rule=cfg).tolist() == [3, -2, 27, 42]


def test_none_rule_is_identity():
    assert expand_box([1, 2, 3, 4], rule="none").tolist() == [1, 2, 3, 4]


def test_expand_boxes_clips_negative_coordinates_and_crops_correctly():
    img = np.arange(40 * 60).reshape(40, 60)
    out = expand_boxes([[0, 0, 4, 8]], ExpandConfig.preset("paper", merge=False), 40, 60)
    # unclipped [-12, -6, 16, 14]: clipped to the image, never wrapped around
    assert out.tolist() == [[0, 0, 16, 14]]
    x0, y0, x1, y1 = out[0]
    np.testing.assert_array_equal(img[y0:y1, x0:x1], img[:14, :16])


def test_expand_boxes_keeps_every_box_and_merges_overlaps():
    boxes = [[10, 10, 12, 14], [14, 10, 16, 14], [80, 80, 82, 84]]
    out = expand_boxes(boxes, "paper", 100, 100)
    # 2 x 4 boxes -> 14 x 10: x [4, 18] and [8, 22] overlap -> merged; the third stays apart
    assert out.tolist() == [[4, 7, 22, 17], [74, 77, 88, 87]]


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-5, 60), st.integers(-5, 60), st.integers(1, 25), st.integers(1, 25)),
        max_size=12,
    ),
    st.sampled_from(["paper", "margin", "none"]),
)
def test_expanded_contains_original_and_merged_cover_union(rows, rule):
    h, w = 50, 70
    boxes = np.array([[x, y, x + bw, y + bh] for x, y, bw, bh in rows], np.int64).reshape(-1, 4)
    for b in boxes:
        e = expand_box(b, rule=rule)
        assert e[0] <= b[0] and e[1] <= b[1] and e[2] >= b[2] and e[3] >= b[3]
    merged = expand_boxes(boxes, rule, h, w)
    unmerged = expand_boxes(boxes, ExpandConfig.preset(rule, merge=False), h, w)
    union = boxes_to_mask(unmerged, h, w)
    cover = boxes_to_mask(merged, h, w)
    assert np.all(cover[union])  # merged boxes cover every expanded pixel
    # pairwise disjoint and not touching: total area equals the area of their union
    areas = (merged[:, 2] - merged[:, 0]) * (merged[:, 3] - merged[:, 1])
    assert areas.sum() == cover.sum()
    assert np.all(merged[:, :2] >= 0) and np.all(merged[:, 2] <= w) and np.all(merged[:, 3] <= h)


def test_merge_touching_boxes():
    # max-exclusive: [0, 0, 5, 5] and [5, 0, 9, 5] share an edge -> one box
    assert merge_boxes([[0, 0, 5, 5], [5, 0, 9, 5]]).tolist() == [[0, 0, 9, 5]]
    assert merge_boxes([[0, 0, 5, 5], [6, 0, 9, 5]]).tolist() == [[0, 0, 5, 5], [6, 0, 9, 5]]


def test_merge_is_iterated_and_may_cover_more_than_union():
    # A and B overlap; their bounding box reaches C, which touches neither A nor B.
    a, b, c = [0, 0, 10, 10], [8, 8, 20, 20], [15, 0, 20, 5]
    out = merge_boxes([a, b, c])
    assert out.tolist() == [[0, 0, 20, 20]]
    union = boxes_to_mask([a, b, c], 20, 20)
    assert union.sum() < 400  # the merged box holds pixels in none of the inputs


def test_merge_empty_and_single():
    assert merge_boxes(np.zeros((0, 4))).shape == (0, 4)
    assert merge_boxes([[1, 2, 3, 4]]).tolist() == [[1, 2, 3, 4]]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rule": "huge"}, "unknown expansion rule"),
        ({"scale_x": 0.5}, "scale_x must be a finite factor >= 1"),
        ({"margin_px": -1}, "margin_px must be finite and >= 0"),
        ({"margin_frac": float("nan")}, "margin_frac must be finite"),
    ],
)
def test_bad_config(kwargs, match):
    with pytest.raises(InputError, match=match):
        ExpandConfig(**kwargs)


def test_bad_preset_and_box():
    with pytest.raises(InputError, match="unknown expansion preset 'wide'"):
        ExpandConfig.preset("wide")
    with pytest.raises(InputError, match="takes one box"):
        expand_box([[0, 0, 1, 1], [2, 2, 3, 3]])

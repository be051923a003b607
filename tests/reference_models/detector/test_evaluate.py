"""AP, matching with ignored ground truth, and which boxes are ignored."""

import numpy as np
import pytest

from reference_models.detector.evaluate import average_precision, ignored, match


def test_average_precision_reference_values():
    assert average_precision(np.array([0.9, 0.8]), np.array([True, True]), 2) == pytest.approx(1.0)
    # a false positive ranked first: precision 1/2 at recall 1/2... then 2/3 at recall 1
    assert average_precision(np.array([0.9, 0.8, 0.7]), np.array([False, True, True]), 2) == pytest.approx(2 / 3)
    # half the ground truth never found: AP is bounded by recall 0.5
    assert average_precision(np.array([0.9]), np.array([True]), 2) == pytest.approx(0.5)
    assert average_precision(np.zeros(0), np.zeros(0, dtype=bool), 3) == 0.0
    assert average_precision(np.array([0.9]), np.array([False]), 0) is None


def test_match_counts_each_ground_truth_once_and_skips_ignored():
    gt = np.array([[0, 0, 10, 10], [20, 20, 30, 30]])
    ign = np.array([False, True])
    det = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [20, 20, 30, 30], [50, 50, 60, 60]])
    scores = np.array([0.9, 0.8, 0.7, 0.6])
    tp, counted, found = match(det, scores, gt, ign)
    assert tp.tolist() == [True, False, False, False]  # the duplicate is a false positive
    assert counted.tolist() == [True, True, False, True]  # the ignored box's detection counts for nothing
    assert found == 1


def test_ignored_by_visibility_and_size_at_model_input():
    recs = [{"box": [0, 0, 20, 40], "visible": 0.2}, {"box": [0, 0, 4, 4], "visible": 1.0},
            {"box": [0, 0, 20, 40], "visible": 0.9}]
    # 1920 px wide -> 416: a 4-px box becomes < 1 px
    assert ignored(recs, 1080, 1920, 416).tolist() == [True, True, False]
    assert ignored(recs, 180, 320, 416).tolist() == [True, False, False]

"""Training targets, letterboxing of ground truth, augmentation and the learning-rate schedule."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_models.detector.model import STRIDE
from reference_models.detector.train import (
    TrainConfig,
    augment,
    loss_fn,
    lr_at,
    prepare,
    targets,
)


def _sample(h=90, w=160):
    img = np.zeros((h, w, 3), dtype=np.uint8)
    img[20:60, 40:60] = 255  # the "player"
    img[70:74, 100:104] = 200  # the "ball"
    boxes = [{"class": "person", "id": 1, "box": [40, 20, 60, 60], "visible": 1.0},
             {"class": "ball", "id": 2, "box": [100, 70, 104, 74], "visible": 1.0},
             {"class": "person", "id": 3, "box": [0, 0, 10, 10], "visible": 0.1}]
    return {"image": img, "boxes": boxes}


def test_prepare_maps_boxes_like_the_runtime_letterbox():
    canvas, boxes, cls, ignore = prepare(_sample(), 320)
    # 160x90 -> 320x180, centred vertically: offset (0, 70)
    np.testing.assert_allclose(boxes[0], [80, 110, 120, 190])
    assert canvas[150, 100].min() == pytest.approx(1.0) and canvas[10, 10, 0] == pytest.approx(114 / 255)
    assert cls.tolist() == [0, 1, 0]
    assert ignore.tolist() == [False, False, True]  # visible 0.1 < 0.3


def test_targets_peak_size_offset_and_ignore():
    boxes = np.array([[8.0, 12.0, 24.0, 44.0], [40.0, 40.0, 48.0, 48.0]])
    t = targets(boxes, np.array([0, 1]), np.array([False, True]), 64)
    g = 64 // STRIDE
    assert t["heat"].shape == (2, g, g)
    cx, cy = 16 / STRIDE, 28 / STRIDE
    assert t["heat"][0, int(cy), int(cx)] == 1.0 and (t["heat"][0] == 1.0).sum() == 1
    np.testing.assert_allclose(t["size"][0:2, int(cy), int(cx)], np.log([16 / STRIDE, 32 / STRIDE]), rtol=1e-6)
    np.testing.assert_allclose(t["offset"][0:2, int(cy), int(cx)], [cx - int(cx), cy - int(cy)], atol=1e-6)
    assert t["heat"][1].max() == 0.0 and t["weight"][1, 10:12, 10:12].max() == 0.0
    assert t["weight"][0].min() == 1.0 and t["reg_mask"].sum() == 1 and t["reg_mask"][0].sum() == 1


def test_a_ball_in_front_of_the_body_keeps_the_players_size_target():
    boxes = np.array([[8.0, 12.0, 24.0, 44.0], [14.0, 26.0, 18.0, 30.0]])  # same centre cell
    t = targets(boxes, np.array([0, 1]), np.array([False, False]), 64)
    iy, ix = int(28 / STRIDE), int(16 / STRIDE)
    assert t["reg_mask"][:, iy, ix].tolist() == [1.0, 1.0]
    np.testing.assert_allclose(t["size"][:, iy, ix], np.log([4, 8, 1, 1]), rtol=1e-6)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_augment_boxes_stay_in_the_crop(seed):
    cfg = TrainConfig(crop=64)
    img, boxes, cls, ignore = augment(_sample(), cfg, np.random.default_rng(seed))
    assert img.shape == (3, 64, 64) and img.dtype == np.float32
    assert 0.0 <= img.min() and img.max() <= 1.0
    assert np.all((boxes >= 0) & (boxes <= 64))
    assert np.all(boxes[:, 2] > boxes[:, 0]) and np.all(boxes[:, 3] > boxes[:, 1])
    assert len(cls) == len(ignore) == len(boxes)


def test_loss_is_lower_for_the_right_answer():
    boxes = np.array([[8.0, 12.0, 24.0, 44.0]])
    t = {k: torch.from_numpy(v[None]) for k, v in targets(boxes, np.array([0]), np.array([False]), 64).items()}
    right = (torch.logit(t["heat"].clamp(1e-4, 1 - 1e-4)), t["size"].clone(), torch.logit(t["offset"].clamp(1e-4, 1 - 1e-4)))
    wrong = (torch.zeros_like(right[0]), torch.zeros_like(right[1]), torch.zeros_like(right[2]))
    cfg = TrainConfig()
    assert float(loss_fn(right, t, cfg)[0]) < 0.1 * float(loss_fn(wrong, t, cfg)[0])


def test_lr_warms_up_then_decays():
    cfg = TrainConfig(steps=1000, lr=1.0)
    assert lr_at(0, cfg) == pytest.approx(0.01)
    assert lr_at(99, cfg) == pytest.approx(1.0)
    assert lr_at(999, cfg) == pytest.approx(0.02, abs=1e-4)
    assert lr_at(500, cfg) < lr_at(200, cfg)

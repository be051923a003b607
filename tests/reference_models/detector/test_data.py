"""Rendering training and evaluation views, and the cache."""

import numpy as np

from reference_models.detector.data import (
    EVAL_SEED0,
    TINY_PLAN,
    TRAIN_SEED0,
    render_eval_shard,
    render_shard,
    training_samples,
)


def test_train_and_eval_seeds_never_overlap():
    assert EVAL_SEED0 + 100 <= TRAIN_SEED0


def test_training_views_are_deterministic_sized_and_boxed():
    a = render_shard("single-player-closeup", TRAIN_SEED0, TINY_PLAN)
    b = render_shard("single-player-closeup", TRAIN_SEED0, TINY_PLAN)
    assert len(a) == TINY_PLAN.cameras * TINY_PLAN.frames
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x["image"], y["image"]) and x["boxes"] == y["boxes"]
        h, w = x["image"].shape[:2]
        assert x["image"].dtype == np.uint8 and TINY_PLAN.min_width - 2 <= w <= TINY_PLAN.max_width + 2
        for r in x["boxes"]:
            x0, y0, x1, y1 = r["box"]
            assert 0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h and r["class"] in ("person", "ball")


def test_eval_views_start_with_the_evaluation_camera():
    views = render_eval_shard("single-player-broadcast", EVAL_SEED0, 64, 36, cameras=2, frames=1)
    assert [v["camera"] for v in views] == ["eval00", "cam00"]
    assert all(v["image"].shape == (36, 64, 3) for v in views)


def test_cache_is_written_once_and_read_back(tmp_path):
    plan = TINY_PLAN.__class__(**{**TINY_PLAN.__dict__, "seeds": 1})
    first = training_samples(tmp_path, plan, presets=("single-player-closeup",))
    files = list(tmp_path.rglob("*.pkl"))
    assert len(files) == 1
    mtime = files[0].stat().st_mtime_ns
    again = training_samples(tmp_path, plan, presets=("single-player-closeup",))
    assert files[0].stat().st_mtime_ns == mtime
    assert all(np.array_equal(x["image"], y["image"]) for x, y in zip(first, again, strict=True))

"""The temporal sensitivity study's ground truth and artefacts, on a tiny sequence."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.metrics.flow import in_frame_mask, optical_flow, warp
from reference_models.studies.temporal_sensitivity import (
    inject_ball_blink,
    inject_drops,
    inject_flicker,
    inject_noise,
    synthetic_sequence,
)


@pytest.fixture(scope="module")
def seq():
    return synthetic_sequence(h=68, w=120, n_frames=5, seed=0)


def test_sequence_is_deterministic_and_in_range(seq):
    again = synthetic_sequence(h=68, w=120, n_frames=5, seed=0)
    for a, b in zip(seq.frames, again.frames, strict=True):
        np.testing.assert_array_equal(a, b)
    assert all(f.dtype == np.float32 and f.min() >= 0 and f.max() <= 1 for f in seq.frames)
    assert len(seq.flows) == 4 and seq.static.any() and not seq.static.all()


def test_exact_flow_maps_frame_t_onto_t_plus_1(seq):
    """gt_t(p) == gt_{t+1}(p + flow_t(p)) wherever p's object is visible in both frames."""
    for t, flow in enumerate(seq.flows):
        back = warp(seq.frames[t + 1], flow)
        err = np.abs(back - seq.frames[t]).max(axis=-1)
        static = in_frame_mask(flow) & np.all(flow == 0, axis=-1) & seq.static
        assert err[static].max() == 0.0  # background does not move
        moving = np.any(flow != 0, axis=-1)
        # inside the objects: bilinear resampling of a textured object at sub-pixel offsets
        assert np.median(err[moving]) < 0.1


def test_dis_follows_the_exact_flow_on_static_pixels(seq):
    est = optical_flow(seq.frames[0], seq.frames[1])
    epe = np.linalg.norm(est - seq.flows[0], axis=-1)
    assert epe[seq.static].mean() < 0.2


def test_injections_are_identity_at_zero_strength(seq):
    for pred in (inject_flicker(seq, 0), inject_drops(seq, 0), inject_ball_blink(seq, 0)):
        for p, g in zip(pred, seq.frames, strict=True):
            np.testing.assert_array_equal(p, g)


def test_static_and_varying_noise_have_equal_per_frame_error(seq):
    s = inject_noise(seq, 0.01, varying=False)
    v = inject_noise(seq, 0.01, varying=True)
    mse = lambda ps: [float(((p - g) ** 2).mean()) for p, g in zip(ps, seq.frames, strict=True)]  # noqa: E731
    np.testing.assert_allclose(mse(s), mse(v), rtol=0.02)  # equal up to clipping at 0 and 1
    assert not np.array_equal(v[0], v[1] - seq.frames[1] + seq.frames[0])


def test_scene_sequence_has_exact_flow_boxes_and_a_ball_less_render():
    from reference_models.studies.temporal_sensitivity import scene_sequence

    seq = scene_sequence(n_frames=3, size="tiny")
    assert len(seq.frames) == len(seq.frames_no_ball) == 3 and len(seq.flows) == 2
    assert all(f.shape == (36, 64, 3) and f.dtype == np.float32 for f in seq.frames)
    assert all(b.shape[1] == 4 for b in seq.boxes) and seq.static.any()
    # hiding the ball changes some pixels of some frame (and only where an object may be)
    diff = [
        np.abs(f - nb).max(axis=-1) > 0
        for f, nb in zip(seq.frames, seq.frames_no_ball, strict=True)
    ]
    assert any(d.any() for d in diff)
    assert not any((d & seq.static).any() for d in diff)

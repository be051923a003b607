"""Static-region flicker (dynaeval.metrics.static_flicker): TemporalStd, SequenceFlicker, flicker."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics.static_flicker import SequenceFlicker, TemporalStd, flicker, static_mean

from .temporal_frames import H, W, panning, texture


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_temporal_std_matches_numpy(n_frames, seed):
    rng = np.random.default_rng(seed)
    frames = rng.random((n_frames, 5, 6, 3))
    pixels = rng.random((5, 6)) < 0.5
    acc = TemporalStd(pixels)
    for f in frames:
        acc.update(f)
    np.testing.assert_allclose(acc.std(), frames.std(axis=0)[pixels], rtol=1e-9, atol=1e-12)


def test_flicker_grows_with_brightness_flicker_amplitude(rng):
    gt = panning(texture(rng), 5, step=(0, 0))
    static = np.ones((H, W), bool)
    values = [
        flicker([g * (1 + a * (-1) ** t) for t, g in enumerate(gt)], gt, static)
        for a in (0, 0.02, 0.05, 0.1)
    ]
    assert values[0] == 0.0
    assert all(x < y for x, y in zip(values, values[1:], strict=False))


def test_flicker_undefined_cases_raise():
    frame = np.zeros((H, W, 3), np.float32)
    with pytest.raises(InputError, match="at least 2 frames, got 1"):
        flicker([frame], [frame], np.ones((H, W), bool))
    with pytest.raises(EmptyRegionError, match="no static pixel"):
        flicker([frame, frame], [frame, frame], np.zeros((H, W), bool))
    with pytest.raises(InputError, match="static_mask must be a bool"):
        flicker([frame, frame], [frame, frame], np.ones((H, W), np.uint8))
    with pytest.raises(InputError, match="frame 1 has shape"):
        flicker([frame, frame[1:]], [frame, frame[1:]], np.ones((H, W), bool))


def test_sequence_flicker_over_a_region_equals_following_only_the_region(rng):
    """The engine follows every static pixel and selects a region at the end; flicker() follows
    static & region from the start: one computation, the same numbers bit for bit."""
    gt = panning(texture(rng), 4, step=(1, 0))
    pred = [np.clip(g + rng.normal(0, 0.03, g.shape), 0, 1).astype(np.float32) for g in gt]
    static = rng.random((H, W)) < 0.7
    region = np.zeros((H, W), bool)
    region[5:40, 10:50] = True
    every, only = SequenceFlicker(static), SequenceFlicker(static & region)
    for p, g in zip(pred, gt, strict=True):
        every.update(p, g)
        only.update(p, g)
    terms = every.terms(region)
    assert terms == only.terms() and list(terms) == ["value", "signed", "pred", "gt"]
    assert terms["value"] == abs(terms["signed"]) > 0
    assert terms["value"] == flicker(pred, gt, static, region)
    assert every.terms(np.zeros((H, W), bool)) is None
    with pytest.raises(InputError, match="bool mask of shape"):
        flicker(pred, gt, static, region[1:])


def test_given_ground_truth_means_give_the_accumulated_terms_bit_for_bit(rng):
    """``dynaeval prepare`` stores ``S(gt)`` (whole, focused) as ``static_mean`` of the ground
    truth's std: the terms are those of a sequence that accumulates the ground truth."""
    pixels = rng.random((24, 32)) > 0.3
    preds = [rng.random((24, 32, 3), dtype=np.float32) for _ in range(5)]
    gts = [rng.random((24, 32, 3), dtype=np.float32) for _ in range(5)]
    region = rng.random((24, 32)) > 0.5
    gt_std = TemporalStd(pixels)
    for g in gts:
        gt_std.update(g)
    means = (static_mean(gt_std.std(), pixels, None), static_mean(gt_std.std(), pixels, region))
    both, given = SequenceFlicker(pixels), SequenceFlicker(pixels, means)
    for p, g in zip(preds, gts, strict=True):
        both.update(p, g)
        given.update(p, None)  # the ground truth is not looked at
    assert given.terms() == both.terms()
    assert given.terms(region, focused=True) == both.terms(region)
    empty = np.zeros((24, 32), bool)
    assert static_mean(gt_std.std(), pixels, empty) is None
    assert given.terms(empty, focused=True) is None is both.terms(empty)


@pytest.mark.parametrize("shape", [(24, 32, 3), (24, 32)])
def test_the_std_is_computed_once_per_frame_count_and_read_only(rng, shape):
    """Issue 33: the whole-frame and the focused flicker read one std of the frames so far (it
    was computed again for each); an update makes it stale, and it is never written to."""
    pixels = rng.random(shape[:2]) > 0.3
    acc, fresh = TemporalStd(pixels), TemporalStd(pixels)
    for _ in range(3):
        frame = rng.random(shape, dtype=np.float32)
        acc.update(frame)
        fresh.update(frame)
        first = acc.std()
        assert acc.std() is first and not first.flags.writeable
        assert np.array_equal(first.view(np.uint64), _numpy_std(fresh).view(np.uint64))
        assert first.shape == (pixels.sum(), *shape[2:])


def _numpy_std(acc):
    """The std as ``TemporalStd.std`` computed it before it kept its result: a fresh array."""
    from dynaeval.metrics.flicker_kernels import population_std

    out = np.empty_like(acc._m2)
    population_std(acc._m2, np.float64(acc.count), out)
    return out.reshape(acc._index.size, *acc._tail)


def test_the_focused_terms_select_the_region_as_the_boolean_index_did(rng):
    pixels = rng.random((30, 40)) > 0.2
    seq = SequenceFlicker(pixels)
    for _ in range(4):
        seq.update(rng.random((30, 40, 3), dtype=np.float32), rng.random((30, 40, 3), dtype=np.float32))
    region = rng.random((30, 40)) > 0.6
    sel = (pixels & region)[pixels]
    vp = float(seq.pred.std()[sel].mean())
    vg = float(seq.gt.std()[sel].mean())
    assert seq.terms(region) == {"value": abs(vp - vg), "signed": vp - vg, "pred": vp, "gt": vg}

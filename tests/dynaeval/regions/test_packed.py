"""Per-frame masks are kept bit-packed (issue 20 item 5: a long camera's memory stays bounded)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.regions.focus import FocusConfig, camera_regions, open_sources
from dynaeval.regions.motion import LazyFrames, MotionConfig, iter_motion_masks
from dynaeval.regions.packed import PackedMask, union

H, W = 45, 61  # H * W = 2745: not a multiple of 8, the last byte is padded


def _video(n: int = 8) -> list[np.ndarray]:
    """``n`` (H, W, 3) float32 frames of a static noisy background with a moving square."""
    rng = np.random.default_rng(0)
    base = rng.random((H, W, 3), dtype=np.float32) * 0.2
    out = []
    for t in range(n):
        f = base.copy()
        f[10:22, 4 + 5 * t: 16 + 5 * t] = 0.9
        out.append(f)
    return out


def test_pack_round_trips_and_takes_an_eighth():
    m = np.random.default_rng(1).random((H, W)) > 0.5
    p = PackedMask.pack(m)
    assert p.shape == (H, W) and p.bits.dtype == np.uint8
    assert p.nbytes == -(-H * W // 8)
    np.testing.assert_array_equal(p.unpack(), m)
    assert p.unpack().dtype == bool


def test_union_equals_the_or_of_the_masks():
    rng = np.random.default_rng(2)
    masks = [rng.random((H, W)) > 0.9 for _ in range(5)]
    np.testing.assert_array_equal(union(PackedMask.pack(m) for m in masks),
                                  np.logical_or.reduce(masks))
    assert union([]) is None


def test_pack_and_union_say_what_is_wrong():
    with pytest.raises(InputError, match=r"\(H, W\) bool mask, got uint8"):
        PackedMask.pack(np.zeros((H, W), np.uint8))
    with pytest.raises(InputError, match="masks differ in shape"):
        union([PackedMask.pack(np.ones((4, 4), bool)), PackedMask.pack(np.ones((4, 5), bool))])


def test_frame_regions_hold_no_full_size_mask():
    frames = _video()
    src = open_sources(FocusConfig(source="motion"))
    out = camera_regions("c", [f"{t:02d}" for t in range(len(frames))], lambda i: frames[i],
                         (H, W), src)
    want = list(iter_motion_masks(LazyFrames(list(range(len(frames))), lambda i: frames[i]),
                                  MotionConfig()))
    assert sum(r.packed_mask is not None for r in out.frames) >= len(frames) - 1  # the square moves
    for r, m in zip(out.frames, want, strict=True):
        if r.packed_mask is not None:
            np.testing.assert_array_equal(r.mask, m)  # the masks themselves are unchanged
        # nothing a frame keeps is a full-size array: the mask is packed, 8 pixels a byte
        for f in dataclasses.fields(r):
            value = getattr(r, f.name)
            arrays = [value.bits] if isinstance(value, PackedMask) else [value]
            for a in arrays:
                if isinstance(a, np.ndarray):
                    assert a.nbytes <= -(-H * W // 8), (f.name, a.shape, a.dtype)

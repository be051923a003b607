"""FrameCache: decoded once, read-only, bounded, and scoring decodes each file once."""

from __future__ import annotations

from collections import Counter

import cv2
import numpy as np
import pytest

import dynaeval
from dynaeval.io import FrameRef
from dynaeval.io.images import FrameCache
from dynaeval.regions.focus import FocusConfig

from ..helpers import moving_square_scene, write_frames


def _png(path, value):
    cv2.imwrite(str(path), np.full((4, 5, 3), value, np.uint8))
    return FrameRef(path)


def test_second_read_is_a_hit_and_read_only(tmp_path):
    cache = FrameCache(10**6)
    ref = _png(tmp_path / "a.png", 7)
    a, b = cache.read(ref), cache.read(ref)
    assert a is b and (cache.hits, cache.misses) == (1, 1)
    with pytest.raises(ValueError, match="read-only"):
        a[0, 0, 0] = 1.0


def test_full_cache_keeps_what_it_has_and_still_reads_the_rest(tmp_path):
    one = 4 * 5 * 3 * 4  # bytes of one float32 frame
    cache = FrameCache(one)
    r1, r2 = _png(tmp_path / "1.png", 1), _png(tmp_path / "2.png", 2)
    cache.read(r1)
    np.testing.assert_allclose(cache.read(r2), 2 / 255)
    cache.read(r1)
    cache.read(r2)
    assert cache.bytes == one and (cache.hits, cache.misses) == (1, 3)


def test_score_decodes_every_file_once(tmp_path, monkeypatch):
    gt, frames = moving_square_scene(tmp_path / "gt")
    for cam, seq in frames.items():
        write_frames(tmp_path / "pred", cam, [f // 2 for f in seq])
    import dynaeval.io.images as images_mod

    calls: Counter = Counter()
    real = images_mod.decode_file

    def counting(path):
        calls[str(path)] += 1
        return real(path)

    monkeypatch.setattr(images_mod, "decode_file", counting)
    dynaeval.score(tmp_path / "pred", gt, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"),
                   progress=False)
    assert len(calls) == 16 and set(calls.values()) == {1}
    calls.clear()
    dynaeval.score(tmp_path / "pred", gt, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"),
                   progress=False, cache_mb=0)
    assert max(calls.values()) > 1  # without a cache, the passes decode again

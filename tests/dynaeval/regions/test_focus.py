"""camera_regions on cameras that are no video (issue 16 item 9)."""

from __future__ import annotations

import numpy as np

from dynaeval.core.outcome import Status

from dynaeval.regions.focus import NOT_A_VIDEO, FocusConfig, camera_regions, open_sources


def _frames() -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    return [rng.random(s, dtype=np.float32) for s in [(20, 24, 3), (20, 24, 3), (16, 30, 3),
                                                        (20, 24, 1)]]


def test_frames_of_different_shapes_get_no_motion_mask_with_the_reason():
    frames = _frames()
    src = open_sources(FocusConfig(source="motion"))
    out = camera_regions("c", ["a", "b", "c", "d"], lambda i: frames[i], (20, 24), src)
    assert all(r.mask is None and r.boxes is None for r in out)
    assert {r.not_video.index for r in out} == {2}
    why = out[0].mask_missing.detail
    assert why.startswith(NOT_A_VIDEO) and "frame 2 is 30x16 px" in why
    assert out[0].mask_missing.status is Status.NOT_A_VIDEO
    assert out[0].boxes_missing == out[0].mask_missing


def test_a_video_is_unchanged():
    frames = [f for f in _frames() if f.shape == (20, 24, 3)] * 2
    src = open_sources(FocusConfig(source="none"))
    out = camera_regions("c", list("abcd"), lambda i: frames[i], (20, 24), src)
    assert all(r.not_video is None and (r.mask_missing is None
                                      or r.mask_missing.status is not Status.NOT_A_VIDEO) for r in out)

"""camera_regions on cameras that are no video (issue 16 item 9), and the camera's facts held
once by its ``CameraRegions`` (issue 41)."""

from __future__ import annotations

import dataclasses

import numpy as np

from dynaeval.core.outcome import Outcome, Status
from dynaeval.regions import sources
from dynaeval.regions.focus import (
    NOT_A_VIDEO,
    CameraRegions,
    FocusConfig,
    FrameRegions,
    camera_regions,
    fit_to,
    open_sources,
)
from dynaeval.regions.static_camera import CameraMotion


def _frames() -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    return [rng.random(s, dtype=np.float32) for s in [(20, 24, 3), (20, 24, 3), (16, 30, 3),
                                                        (20, 24, 1)]]


def test_frames_of_different_shapes_get_no_motion_mask_with_the_reason():
    frames = _frames()
    src = open_sources(FocusConfig(source="motion"))
    out = camera_regions("c", ["a", "b", "c", "d"], lambda i: frames[i], (20, 24), src)
    assert all(r.mask is None and r.boxes is None for r in out.frames)
    assert out.not_video.index == 2 and out.motion is None
    why = out.frames[0].mask_missing.detail
    assert why.startswith(NOT_A_VIDEO) and "frame 2 is 30x16 px" in why
    assert why == out.not_video.reason()
    assert out.frames[0].mask_missing.status is Status.NOT_A_VIDEO
    assert out.frames[0].boxes_missing == out.frames[0].mask_missing


def test_a_video_is_unchanged():
    frames = [f for f in _frames() if f.shape == (20, 24, 3)] * 2
    src = open_sources(FocusConfig(source="none"))
    out = camera_regions("c", list("abcd"), lambda i: frames[i], (20, 24), src)
    assert out.not_video is None
    assert all(r.mask_missing is None or r.mask_missing.status is not Status.NOT_A_VIDEO
               for r in out.frames)


def test_the_camera_facts_are_held_once_by_the_camera_not_copied_onto_each_frame():
    """A static video with motion masks: its static check is one typed ``CameraMotion`` on
    the camera's ``CameraRegions`` (it was the same dict set on every ``FrameRegions``)."""
    rng = np.random.default_rng(1)
    background = rng.random((40, 48, 3), dtype=np.float32)
    frames = []
    for t in range(5):
        f = background.copy()
        f[10:18, 4 + 6 * t:12 + 6 * t] = 1.0  # a square moves over a still background
        frames.append(f)
    src = open_sources(FocusConfig(source="motion"))
    out = camera_regions("c", list("abcde"), lambda i: frames[i], (40, 48), src)
    assert isinstance(out, CameraRegions) and len(out.frames) == 5
    assert isinstance(out.motion, CameraMotion) and out.motion.reason is None
    assert out.motion.global_motion_px is None or out.motion.global_motion_px < 0.5
    assert out.not_video is None
    per_frame = {f.name for f in dataclasses.fields(FrameRegions)}
    assert per_frame.isdisjoint({"not_video", "camera_motion", "motion"}), per_frame


def test_a_new_focus_source_names_why_a_frame_has_no_box_itself(monkeypatch):
    """A frame whose boxes all fall outside it gets its source's ``no_box`` words: a kind added
    in ``SOURCE_KINDS`` alone needs no entry elsewhere (they were a dict keyed by the source's
    name in ``regions/focus.py``, which raised KeyError for a new kind)."""

    class ToyBoxes(sources.BoxesFileSource):
        name = spec = "toyboxes"
        no_box = "the toy file has no box in this frame"

    monkeypatch.setitem(sources.SOURCE_KINDS, "toyboxes", ToyBoxes())
    frame = FrameRegions(raw_boxes=np.array([[30, 30, 40, 40]]), size=(40, 48),
                         boxes=np.array([[30, 30, 40, 40]]))
    got = fit_to(frame, (20, 24), FocusConfig(source="toyboxes", boxes_file="toy.json"))
    assert got.boxes is None and len(got.raw_boxes) == 0
    assert got.boxes_missing == Outcome(None, Status.NO_REGION, ToyBoxes.no_box)
    for kind in sources.SOURCE_KINDS.values():
        assert not kind.gives_boxes or kind.no_box, kind.name

"""Static-camera check of the motion masks (issue 17 item 5): a pan of a real photograph is
flagged, the bundled sample's static cameras are not."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

import dynaeval
from dynaeval.regions.focus import FocusConfig
from dynaeval.regions.static_camera import (
    MASK_FRACTION_MAX,
    MOVING_CAMERA_PX,
    camera_motion,
    global_motion,
    moving_camera_reason,
)

from ..helpers import write_frames

SAMPLE = Path(dynaeval.__file__).resolve().parent / "data" / "sample"


def _pan(step: float, n: int = 6, name: str = "chelsea") -> list[np.ndarray]:
    """n crops (120 x 200) of a photograph, the window moving ``step`` px right per frame."""
    skdata = pytest.importorskip("skimage.data")
    photo = getattr(skdata, name)().astype(np.float32) / 255
    m = np.float32([[1, 0, 0], [0, 1, 0]])
    out = []
    for t in range(n):
        m[0, 2] = -step * t  # sub-pixel shifts through warpAffine
        out.append(cv2.warpAffine(photo, m, (photo.shape[1], photo.shape[0]))[20:140, 20:220])
    return out


@pytest.mark.parametrize("step", [1.0, 2.5, 4.0])
@pytest.mark.parametrize("name", ["chelsea", "coffee"])
def test_global_motion_measures_a_pan(step, name):
    frames = _pan(step, name=name)
    assert camera_motion(lambda i: frames[i], len(frames)) == pytest.approx(step, abs=0.15)


def test_global_motion_of_a_static_frame_is_zero_and_of_a_flat_one_unknown():
    frames = _pan(0.0)
    assert camera_motion(lambda i: frames[i], len(frames)) < 0.05
    flat = np.full((50, 60, 3), 0.5, np.float32)
    assert global_motion(flat, flat) is None
    assert camera_motion(lambda i: flat, 1) is None


def _sample_frames(cam: str) -> list[np.ndarray]:
    return [cv2.imread(str(p))[..., ::-1].astype(np.float32) / 255
            for p in sorted((SAMPLE / "gt" / cam).glob("*.png"))]


@pytest.mark.parametrize("cam", ["cam07", "eval00"])
def test_the_sample_cameras_are_static(cam):
    frames = _sample_frames(cam)
    px = camera_motion(lambda i: frames[i], len(frames))
    assert px is not None and px < 0.05 < MOVING_CAMERA_PX


def test_reason_rules():
    assert moving_camera_reason(0.2, 0.1, "detector") is None
    assert moving_camera_reason(None, None, "detector") is None
    why = moving_camera_reason(2.0, 0.6, "motion")
    assert "moves by 2.0 px per frame" in why and "covers 60%" in why and "--focus motion boxes" in why
    assert "--no-masked" in why
    assert "covers most of the frame" in moving_camera_reason(0.1, MASK_FRACTION_MAX + 0.01, "none")


@pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")
def test_a_panning_camera_is_flagged_per_camera_and_the_sample_is_not(tmp_path):
    pan = [np.round(f * 255).astype(np.uint8) for f in _pan(2.0)]
    write_frames(tmp_path / "gt", "pan", pan)
    write_frames(tmp_path / "pred", "pan", [np.clip(f.astype(int) + 3, 0, 255).astype(np.uint8) for f in pan])
    kw = dict(metrics=("psnr",), presence=False, temporal=False, progress=False)
    res = dynaeval.score(tmp_path / "pred", tmp_path / "gt", focus=FocusConfig(source="motion"), **kw)
    flagged = [w for w in res["warnings"] if w.get("camera") == "pan" and "frame" not in w
               and "motion masks need a static camera" in w["reason"]]
    assert len(flagged) == 1 and "--focus motion boxes" in flagged[0]["reason"]
    assert res["regions"]["cameras"]["pan"]["global_motion_px"] == pytest.approx(2.0, abs=0.15)
    sample = dynaeval.score(SAMPLE / "pred", SAMPLE / "gt",
                            focus=FocusConfig.parse(f"boxes:{SAMPLE / 'boxes.json'}"), **kw)
    assert not any("static camera" in w["reason"] for w in sample["warnings"])
    for cam in sample["regions"]["cameras"].values():
        assert cam["global_motion_px"] < 0.05 and cam["mask_fraction"]["mean"] < 0.05


@pytest.mark.parametrize("shape", [(1080, 1920, 3), (7, 5, 3), (1, 1, 3), (40, 30, 4), (3, 100, 3)])
def test_grey_mean_is_numpys_channel_mean_bit_for_bit(shape):
    """``_mean3`` (two whole-frame adds) is ``f[..., :3].mean(axis=2)`` (issue 33: 30 ms a 1080p
    frame as numpy reduced it), on values of very different sizes (the order of the adds shows)."""
    from dynaeval.regions.static_camera import _mean3

    rng = np.random.default_rng(sum(shape))
    f = rng.random(shape, dtype=np.float32) * rng.choice([1, 1e-3, 1e3], size=shape).astype(np.float32)
    want = f[..., :3].mean(axis=2)
    np.testing.assert_array_equal(_mean3(f).view(np.int32), want.view(np.int32))


def test_camera_motion_loads_each_frame_once_and_equals_the_pairs_median():
    """A frame in two consecutive pairs is loaded and turned grey once; the value is the median
    of ``global_motion`` over the pairs, as it was."""
    frames = _pan(1.5, n=7)
    loads = []
    got = camera_motion(lambda i: loads.append(i) or frames[i], len(frames))
    assert sorted(loads) == list(range(7))
    assert got == float(np.median([global_motion(frames[i], frames[i + 1]) for i in range(6)]))


@pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")
def test_with_given_masks_no_motion_mask_is_computed_and_the_moving_camera_note_is_true(
        tmp_path, monkeypatch):
    """Issue 43: DyCheck with its covisibility masks (``--masks``) still computed motion masks,
    which the given masks then replaced, and a moving camera's note said "masked_* values are
    close to the whole-frame ones" while masked_* were over the given masks. No motion mask is
    computed there (the camera check still is); the note says what the motion does touch; the
    numbers are the given masks'."""
    from dynaeval.metrics import psnr
    from dynaeval.regions import focus

    pan = [np.round(f * 255).astype(np.uint8) for f in _pan(2.0)]
    pred = [np.clip(f.astype(int) + 3 + 2 * (i % 2), 0, 255).astype(np.uint8)
            for i, f in enumerate(pan)]
    write_frames(tmp_path / "gt", "pan", pan)
    write_frames(tmp_path / "pred", "pan", pred)
    masks = tmp_path / "covisible" / "pan"
    masks.mkdir(parents=True)
    for f in sorted((tmp_path / "gt" / "pan").iterdir()):
        m = np.zeros(pan[0].shape[:2], np.uint8)
        m[:, :120] = 255
        cv2.imwrite(str(masks / f.name), m)

    def no_motion_masks(*args, **kwargs):
        raise AssertionError("motion masks computed, though the given masks replace them")

    monkeypatch.setattr(focus, "iter_motion_masks", no_motion_masks)
    res = dynaeval.score(tmp_path / "pred", tmp_path / "gt", masks=str(tmp_path / "covisible"),
                         protocol="dycheck", metrics=("psnr",), presence=False, progress=False,
                         focus=FocusConfig(source="none"))
    notes = [w["reason"] for w in res["warnings"] if w.get("camera") == "pan" and "frame" not in w
             and "moves by" in w["reason"]]
    assert len(notes) == 1, res["warnings"]
    assert "masked_* values" not in notes[0] and "--no-masked" not in notes[0]
    assert "flicker's 'static' pixels (those outside every given mask) are not static" in notes[0]
    assert res["regions"]["cameras"]["pan"]["global_motion_px"] == pytest.approx(2.0, abs=0.15)
    unit = [f.astype(np.float32) / np.float32(255) for f in (*pred, *pan)]
    want = [psnr(p[:, :120], g[:, :120]) for p, g in zip(unit[:6], unit[6:], strict=True)]
    assert [r["masked_psnr"] for r in res["frames"]] == pytest.approx(want, rel=1e-6)

"""Scoring one camera on the inputs users really have (issue 16 items 8, 9, 10, 11, 15)."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

import dynaeval
from dynaeval.errors import InputError
from dynaeval.evaluate import ScoreConfig
from dynaeval.io import pair_frames
from dynaeval.io.cache import FrameCache
from dynaeval.regions.focus import NOT_A_VIDEO, FocusConfig
from dynaeval.metrics.flow import MIN_FLOW_SIZE as TEMPORAL_MIN_SIZE
from dynaeval.scoring import camera_regions_of, prepare_run, score_frame

from .helpers import textured_frame

pytestmark = pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")


def _write(root: Path, frames: list[np.ndarray], noise: int = 3) -> None:
    for side, delta in (("gt", 0), ("pred", noise)):
        (root / side).mkdir(parents=True, exist_ok=True)
        for i, f in enumerate(frames):
            g = np.clip(f.astype(int) + delta, 0, 255).astype(np.uint8)
            cv2.imwrite(str(root / side / f"{i:04d}.png"), g)


def _score(root: Path, **kw):  # noqa: ANN202
    return dynaeval.score(root / "pred", root / "gt", progress=False, **kw)


def test_flat_folder_of_unrelated_images_scores_each_frame(tmp_path):
    """Item 9: photos of different sizes, one grayscale, under the default settings (detector
    focus, motion masks, temporal terms): every frame's per-frame values, the camera marked not
    a video with one warning naming the first differing file, its temporal and masked values
    null with that reason. Before: exit 2, "frame 1: shape … differs from frame 0's"."""
    rng = np.random.default_rng(0)
    frames = [textured_frame(rng, 48, 64), textured_frame(rng, 40, 56),
              textured_frame(rng, 48, 64)[..., 0], textured_frame(rng, 32, 72)]
    _write(tmp_path, frames)
    res = _score(tmp_path)
    assert [f["frame"] for f in res["frames"]] == ["0000", "0001", "0002", "0003"]
    for f in res["frames"]:
        assert math.isfinite(f["psnr"]) and math.isfinite(f["ssim"])
        assert f["masked_psnr"] is None
    camera_warnings = [w for w in res["warnings"] if w.get("camera") == "." and "frame" not in w
                       and "metric" not in w]
    assert len(camera_warnings) == 1
    assert camera_warnings[0]["reason"].startswith(NOT_A_VIDEO)
    assert "gt/0001.png differs from" in camera_warnings[0]["reason"]
    masked = [w for w in res["warnings"] if w.get("metric") == "masked_psnr" and "frame" in w]
    assert len(masked) == 4 and all(w["reason"].startswith(NOT_A_VIDEO) for w in masked)
    temporal = [w for w in res["warnings"] if w.get("metric") == "warp_error"]
    assert temporal and NOT_A_VIDEO in temporal[0]["reason"]


def test_flat_folder_scores_as_it_did_with_no_masked_focus_none(tmp_path):
    """The per-frame numbers are those the old workaround (--no-masked --focus none) gave."""
    rng = np.random.default_rng(1)
    _write(tmp_path, [textured_frame(rng, 48, 64), textured_frame(rng, 40, 56)])
    a = _score(tmp_path, focus=FocusConfig(source="none"))
    b = _score(tmp_path, focus=FocusConfig(source="none", masked=False), temporal=False)
    assert [f["psnr"] for f in a["frames"]] == [f["psnr"] for f in b["frames"]]
    assert [f["ssim"] for f in a["frames"]] == [f["ssim"] for f in b["frames"]]


def test_images_smaller_than_the_ssim_window_score_psnr(tmp_path):
    """Item 11: the whole run used to exit 2; now PSNR is scored, SSIM null with the reason,
    the temporal terms null (optical flow needs 16 px)."""
    rng = np.random.default_rng(2)
    _write(tmp_path, [rng.integers(0, 255, (8, 9, 3), dtype=np.uint8) for _ in range(4)])
    res = _score(tmp_path)
    assert all(math.isfinite(f["psnr"]) and f["ssim"] is None for f in res["frames"])
    why = [w["reason"] for w in res["warnings"] if w.get("metric") == "ssim" and "frame" in w]
    assert len(why) == 4 and "at least 11x11 pixels" in why[0]
    tw = [w["reason"] for w in res["warnings"] if w.get("metric") == "warp_error"]
    assert tw and f"at least {TEMPORAL_MIN_SIZE}x{TEMPORAL_MIN_SIZE}" in tw[0]


@pytest.mark.parametrize("focus", ["none", "motion", "detector"])
def test_huge_float_tiff_is_refused_under_every_focus(tmp_path, focus):
    """Item 8: one rule for every path (before: RuntimeError "ssim is NaN" under --focus none,
    PSNR -200 dB for values of 1e10, refused under detector/motion)."""
    rng = np.random.default_rng(3)
    _write(tmp_path, [textured_frame(rng, 24, 32) for _ in range(3)])
    cv2.imwrite(str(tmp_path / "pred" / "0001.tif"), np.full((24, 32, 3), 1e30, np.float32))
    (tmp_path / "pred" / "0001.png").unlink()
    with pytest.raises(InputError, match=r"pred/0001\.tif: float pixel values must be in \[0, 1\]"):
        _score(tmp_path, focus=FocusConfig.parse(focus))


def test_grayscale_scores_under_the_default_detector_focus(tmp_path):
    """Item 10: grey 8-bit ground truth and predictions under --focus detector."""
    rng = np.random.default_rng(4)
    _write(tmp_path, [textured_frame(rng, 48, 64)[..., 0] for _ in range(3)])
    res = _score(tmp_path)
    assert all(math.isfinite(f["psnr"]) for f in res["frames"])
    assert res["settings"]["focus"]["source"] == "detector"


def _run_and_pairs(tmp_path: Path, **kw):  # noqa: ANN202
    rng = np.random.default_rng(5)
    _write(tmp_path, [textured_frame(rng, 24, 32) for _ in range(2)])
    run = prepare_run(ScoreConfig(**kw))
    return run, pair_frames(tmp_path / "pred", tmp_path / "gt").pairs


def test_an_input_error_inside_a_frame_names_camera_frame_and_files(tmp_path):
    """Item 15: errors raised by a frame's work with no file (the presence step here) are
    raised again naming the camera, the frame and both files."""
    run, pairs = _run_and_pairs(tmp_path, focus=FocusConfig(source="none", masked=False))

    def fails(*_a):  # noqa: ANN202
        raise InputError("float images must be in [0, 1]")

    run.presence = fails
    regions = camera_regions_of(".", pairs, run, FrameCache(0))
    with pytest.raises(InputError, match=r"pred/0001\.png: camera '\.' frame '0001' \(ground "
                                         r"truth .*gt/0001\.png\): float images must be in"):
        score_frame(pairs[1], regions[1], run, FrameCache(0))


def test_a_detector_error_names_the_ground_truth_file(tmp_path):
    """Item 15: "detector input must be an (H, W, 3) RGB image" named no file."""
    run, pairs = _run_and_pairs(tmp_path, focus=FocusConfig(source="detector", masked=False))

    def fails(_image):  # noqa: ANN202
        raise InputError("detector input must be an (H, W, 3) RGB image")

    run.sources.detector = fails
    with pytest.raises(InputError, match=r"gt/0000\.png: camera '\.' frame '0000': detector input"):
        camera_regions_of(".", pairs, run, FrameCache(0))


def test_boxes_file_boxes_fit_each_frame_of_a_camera_that_is_no_video(tmp_path):
    """Item 9 with ``--focus boxes:FILE --no-masked``: nothing reads frame 1 before it is
    scored, so its boxes (clipped to frame 0's size) are fitted to its own size then: the
    focused value is that of the box clipped and expanded in frame 1."""
    from dynaeval import metrics as M
    from dynaeval.regions import write_boxes_file
    from dynaeval.regions.expand import expand_boxes

    rng = np.random.default_rng(6)
    _write(tmp_path, [textured_frame(rng, 24, 32), textured_frame(rng, 48, 64)], noise=9)
    box = [40, 30, 52, 44]  # outside frame 0, inside frame 1
    write_boxes_file(tmp_path / "b.json", {"./0000": [], "./0001": [
        {"class": "person", "id": 0, "box": box}]})
    res = _score(tmp_path, focus=FocusConfig(source="boxes", boxes_file=str(tmp_path / "b.json"),
                                             masked=False), presence=False)
    pred = cv2.imread(str(tmp_path / "pred" / "0001.png"))[..., ::-1] / np.float32(255)
    gt = cv2.imread(str(tmp_path / "gt" / "0001.png"))[..., ::-1] / np.float32(255)
    want = M.psnr(pred, gt, boxes=expand_boxes(np.array([box]), "paper", 48, 64))
    assert res["frames"][1]["focused_psnr"] == pytest.approx(want, rel=1e-12)


def test_frames_too_small_for_lpips_score_the_rest(tmp_path, random_lpips):
    """Item 11 with LPIPS on: 20x24 frames fit SSIM and the optical flow but not AlexNet's
    31 px: LPIPS and tLP are null with the reason, the rest is scored (before: exit 2)."""
    rng = np.random.default_rng(7)
    _write(tmp_path, [textured_frame(rng, 20, 24) for _ in range(4)], noise=5)
    res = _score(tmp_path, focus=FocusConfig(source="none"))
    assert all(f["lpips"] is None and math.isfinite(f["ssim"]) for f in res["frames"])
    why = [w["reason"] for w in res["warnings"] if w.get("metric") == "lpips" and "frame" in w]
    assert len(why) == 4 and "at least 31x31 pixels" in why[0]
    tlp = [w["reason"] for w in res["warnings"] if w.get("metric") == "tlp"]
    assert tlp and "tLP needs frames of at least 31x31 pixels" in tlp[0]
    assert math.isfinite(res["summary"]["warp_error"])

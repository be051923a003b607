"""Scoring one camera on the inputs users really have (issue 16 items 8, 9, 10, 11, 15)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

import dynaeval
from dynaeval.core.outcome import CameraTerm, Outcome, Status
from dynaeval.errors import InputError
from dynaeval.io import FramePair, pair_frames
from dynaeval.io.frames import FrameRef
from dynaeval.io.images import FrameCache
from dynaeval.metrics.flow import MIN_FLOW_SIZE as TEMPORAL_MIN_SIZE
from dynaeval.regions.focus import NOT_A_VIDEO, FocusConfig, FrameRegions
from dynaeval.run.evaluate import ScoreConfig
from dynaeval.run.executor import RunWorkers
from dynaeval.run.plan import build_plan
from dynaeval.run.scoring import camera_regions_of, name_regionless_frames, score_frame

from ..helpers import textured_frame

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
    run = build_plan(ScoreConfig(**kw))
    return run, pair_frames(tmp_path / "pred", tmp_path / "gt").pairs


def test_an_input_error_inside_a_frame_names_camera_frame_and_files(tmp_path):
    """Item 15: errors raised by a frame's work with no file (the presence step here) are
    raised again naming the camera, the frame and both files."""
    run, pairs = _run_and_pairs(tmp_path, focus=FocusConfig(source="none", masked=False))

    def fails(*_a):  # noqa: ANN202
        raise InputError("float images must be in [0, 1]")

    run = replace(run, presence=fails)
    executor = RunWorkers(1, cache_mb=0)
    regions = camera_regions_of(".", pairs, run, executor, FrameCache(0))
    with pytest.raises(InputError, match=r"pred/0001\.png: camera '\.' frame '0001' \(ground "
                                         r"truth .*gt/0001\.png\): float images must be in"):
        score_frame(pairs[1], regions.frames[1], run, FrameCache(0), executor)


def test_a_detector_error_names_the_ground_truth_file(tmp_path):
    """Item 15: "detector input must be an (H, W, 3) RGB image" named no file."""
    run, pairs = _run_and_pairs(tmp_path, focus=FocusConfig(source="detector", masked=False))

    def fails(_image):  # noqa: ANN202
        raise InputError("detector input must be an (H, W, 3) RGB image")

    run.sources.detector = fails
    with pytest.raises(InputError, match=r"gt/0000\.png: camera '\.' frame '0000': detector input"):
        camera_regions_of(".", pairs, run, RunWorkers(1, cache_mb=0), FrameCache(0))


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


def _square_scene_with_boxes(tmp_path: Path, empty: set[str]) -> Path:
    """The moving-square scene (2 cameras x 4 frames, predictions 5 levels brighter) and a
    boxes file with the square's box in every frame except the keys in ``empty``."""
    import json

    from ..helpers import moving_square_scene, write_frames

    _, frames = moving_square_scene(tmp_path / "gt")
    boxes = {}
    for cam, seq in frames.items():
        write_frames(tmp_path / "pred", cam, [np.clip(f.astype(int) + 5, 0, 255).astype(np.uint8)
                                              for f in seq])
        for t in range(len(seq)):
            key = f"{cam}/{t:04d}"
            boxes[key] = [] if key in empty else [
                {"class": "person", "id": 0, "box": [8 + 4 * t, 20, 18 + 4 * t, 30]}]
    path = tmp_path / "boxes.json"
    path.write_text(json.dumps(boxes))
    return path


def test_a_frame_without_boxes_nulls_only_its_pairs(tmp_path):
    """Issue 17 item 6: one frame without boxes used to null focused_warp_error / focused_tof
    of every frame of its camera, with the reason "no region masks given (focus: none)"."""
    full = _square_scene_with_boxes(tmp_path / "full", set())
    holed = _square_scene_with_boxes(tmp_path / "holed", {"cam00/0002"})
    kw = dict(metrics=("psnr",), presence=False, progress=False)
    ref = dynaeval.score(tmp_path / "full/pred", tmp_path / "full/gt",
                         focus=FocusConfig.parse(f"boxes:{full}"), **kw)
    got = dynaeval.score(tmp_path / "holed/pred", tmp_path / "holed/gt",
                         focus=FocusConfig.parse(f"boxes:{holed}"), **kw)
    rows = {(r["camera"], r["frame"]): r for r in got["frames"]}
    want = {(r["camera"], r["frame"]): r for r in ref["frames"]}
    for key in ("focused_warp_error", "focused_tof"):
        assert want[("cam00", "0001")][key] is not None
        assert rows[("cam00", "0001")][key] == want[("cam00", "0001")][key]  # pair (0, 1): scored
        assert rows[("cam00", "0002")][key] is None and rows[("cam00", "0003")][key] is None
        for t in ("0001", "0002", "0003"):  # the other camera is untouched
            assert rows[("cam01", t)][key] == want[("cam01", t)][key]
        assert got["cameras"]["cam00"][key] == want[("cam00", "0001")][key]
        notes = [w["reason"] for w in got["warnings"] if w.get("camera") == "cam00"
                 and w.get("metric") == key]
        assert any("1 of 4 frames have no box" in n and "'0002'" in n
                   and "the boxes file lists no box for this frame" in n for n in notes), notes
        assert not any("focus: none" in n for n in notes)


def test_a_camera_without_any_box_says_which_frames(tmp_path):
    empty = {f"cam00/{t:04d}" for t in range(4)}
    path = _square_scene_with_boxes(tmp_path, empty)
    got = dynaeval.score(tmp_path / "pred", tmp_path / "gt", focus=FocusConfig.parse(f"boxes:{path}"),
                         metrics=("psnr",), presence=False, progress=False)
    assert got["cameras"]["cam00"]["focused_warp_error"] is None
    assert got["cameras"]["cam00"]["focused_flicker"] is None  # not the whole-frame flicker
    notes = [w["reason"] for w in got["warnings"] if w.get("camera") == "cam00"
             and w.get("metric") == "focused_warp_error"]
    assert any("4 of 4 frames have no box" in n and "no pair of consecutive frames has boxes in both" in n
               for n in notes), notes


def test_the_frames_without_boxes_are_named_by_status_not_by_words():
    """Issue 31: ``name_regionless_frames`` rewrote a null focused term's reason when the reason
    began with words of temporal.py (``REGIONLESS_REASONS``); now when its status is
    ``no-region``, whatever the words, and never for another status."""
    pairs = [FramePair("cam00", f"{t:04d}", t, FrameRef(Path("p")), FrameRef(Path("g")))
             for t in range(3)]
    regions = [FrameRegions(boxes=None, boxes_missing=Outcome(None, Status.NO_REGION, "no box here")),
               FrameRegions(boxes=np.array([[0, 0, 4, 4]])),
               FrameRegions(boxes=None, boxes_missing=Outcome(None, Status.NO_REGION, "no box here"))]
    temporal = {
        "focused_tof": CameraTerm.null(Status.NO_REGION, "any words"),
        "focused_warp_error": CameraTerm.null(Status.UNDEFINED, "no frame has a region"),
    }
    named, _ = name_regionless_frames("cam00", pairs, regions, temporal)
    assert named["focused_tof"].outcome.detail == (
        "2 of 3 frames have no box (no box here): '0000', '0002'; no pair of consecutive "
        "frames has boxes in both")
    assert named["focused_warp_error"].outcome.detail == "no frame has a region"
    assert temporal["focused_tof"].outcome.detail == "any words"  # not changed in place


def test_frames_read_from_files_get_no_second_range_pass(tmp_path, monkeypatch):
    """Issue 32 item 1: io.images checked the frames' range when it read them; the metrics do
    not check it again per metric (values_known_in), unless the run's data_range is narrower."""
    import dynaeval.core.validation as validation

    rng = np.random.default_rng(1)
    _write(tmp_path, [textured_frame(rng, 48, 64), textured_frame(rng, 48, 64)])
    calls = []
    real = validation.check_value_range
    monkeypatch.setattr(validation, "check_value_range",
                        lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    res = _score(tmp_path, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"),
                 temporal=False)
    assert all(f["psnr"] is not None and f["ssim"] is not None for f in res["frames"])
    assert calls == []
    for wrong in (0.5, 255, 255.0, True):  # files are in [0, 1]: 255 would add 48 dB silently
        with pytest.raises(InputError, match=r"data_range must be 1\.0 when scoring files, got "
                                             r".*data_range=255"):
            _score(tmp_path, metrics=("psnr",), focus=FocusConfig(source="none"), temporal=False,
                   data_range=wrong)

def test_allow_missing_scores_the_consecutive_pairs_present_and_says_which_frames(tmp_path, capsys):
    """Issue 32 item 6: one missing prediction used to null the camera's whole temporal pass
    ("frames are not consecutive"). The pairs around the gap are scored as in the full run, the
    pair across it is null with the reason, the counts are in ``inputs.temporal_pairs`` and the
    console names the missing frame."""
    import json

    from dynaeval.cli import main

    rng = np.random.default_rng(3)
    base = textured_frame(rng, 64, 96)
    _write(tmp_path, [np.roll(base, 2 * t, axis=1) for t in range(6)])
    full = _score(tmp_path, metrics=("psnr",), focus=FocusConfig(source="none", masked=False))
    (tmp_path / "pred" / "0003.png").unlink()
    out = tmp_path / "r.json"
    assert main(["score", str(tmp_path / "pred"), str(tmp_path / "gt"), "--allow-missing",
                 "--metrics", "psnr", "--focus", "none", "--no-masked", "-q", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert ("--allow-missing: 1 ground-truth frame(s) have no prediction and are not scored "
            "(camera .: 0003; temporal pairs 3 of 5)") in err
    got = json.loads(out.read_text())
    assert got["inputs"]["temporal_pairs"] == {".": {"scored": 3, "expected": 5}}
    rows = {r["frame"]: r for r in got["frames"]}
    want = {r["frame"]: r for r in full["frames"]}
    for key in ("warp_error", "tof"):
        assert [rows[t][key] for t in ("0001", "0002", "0005")] == [
            want[t][key] for t in ("0001", "0002", "0005")]
        assert rows["0004"][key] is None and got["counts"][key] == 3
        reasons = [w["reason"] for w in got["warnings"] if w.get("frame") == "0004"
                   and w.get("metric") == key]
        assert reasons == ["not a pair of consecutive frames: the ground-truth frame(s) between "
                           "'0002' and '0004' have no prediction (--allow-missing)"]


def test_frames_read_from_files_get_no_second_finite_pass(tmp_path, monkeypatch):
    """Issue 33: io.images refused NaN/Inf when it read the frames (integer pixels cannot hold
    them); the frame metrics and the temporal terms do not look for them again per metric."""
    import dynaeval.core.validation as validation

    rng = np.random.default_rng(1)
    base = textured_frame(rng, 48, 64)
    _write(tmp_path, [np.roll(base, 2 * t, axis=1) for t in range(3)])
    calls = []
    real = validation.check_finite_image
    monkeypatch.setattr(validation, "check_finite_image",
                        lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    res = _score(tmp_path, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"))
    assert all(f["psnr"] is not None and f["ssim"] is not None for f in res["frames"])
    assert res["cameras"][next(iter(res["cameras"]))]["warp_error"] is not None
    # the motion masks (regions layer) check each ground-truth frame they are made of, once
    assert calls and [c for c in calls if not c.startswith("frame ")] == []
    with validation.values_known_in(1.0):  # without finite=True the pass stays
        with pytest.raises(InputError, match="pred contains 1 NaN"):
            validation.check_pair(np.array([[np.nan, 0.5]]), np.zeros((1, 2)), data_range=1.0)


@pytest.mark.parametrize("ext", [".tiff", ".npy.gz", ".exr"])
@pytest.mark.parametrize("prepared", [False, True])
def test_a_non_finite_float_prediction_is_exit_2_naming_the_file(tmp_path, capsys, ext, prepared):
    """Skipping the per-metric NaN/Inf pass loses no check: a float prediction file holding NaN
    or Inf is still refused when read, with or without a prepared ground truth."""
    import gzip

    from dynaeval.cli import main

    rng = np.random.default_rng(2)
    base = textured_frame(rng, 48, 64)
    _write(tmp_path, [np.roll(base, 2 * t, axis=1) for t in range(3)])
    bad = (base / 255.0).astype(np.float32)
    bad[3, 4, 1] = np.nan if ext != ".exr" else np.inf
    (tmp_path / "pred" / "0001.png").unlink()
    path = tmp_path / "pred" / f"0001{ext}"
    if ext == ".tiff":
        cv2.imwrite(str(path), bad)
    elif ext == ".npy.gz":
        with gzip.open(path, "wb") as f:
            np.save(f, bad)
    else:
        openexr = pytest.importorskip("OpenEXR")
        with openexr.File({"compression": openexr.ZIP_COMPRESSION, "type": openexr.scanlineimage},
                          {"RGB": bad}) as f:
            f.write(str(path))
    args = ["score", str(tmp_path / "pred"), str(tmp_path / "gt"), "--no-lpips", "-q",
            "--focus", "motion", "-o", str(tmp_path / "r.json")]
    if prepared:
        prep = tmp_path / "prep"
        assert main(["prepare", str(tmp_path / "gt"), "-o", str(prep), "--focus", "motion",
                     "-q"]) == 0
        args += ["--prepared", str(prep)]
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"0001{ext}" in err and "NaN or Inf" in err
    assert not (tmp_path / "r.json").exists()


def test_without_workers_the_next_frames_are_read_ahead_on_a_thread(tmp_path, monkeypatch):
    """Issue 33: with one worker, frame i + 1 is read (decoded) on a thread of its own while
    frame i is scored; the numbers are those of reading in turn, and with worker threads
    nothing is read ahead (the pool overlaps the frames already)."""
    import threading

    import dynaeval.run.plan as plan_mod

    rng = np.random.default_rng(4)
    base = textured_frame(rng, 48, 64)
    _write(tmp_path, [np.roll(base, 2 * t, axis=1) for t in range(4)])
    threads = []
    real = plan_mod.RunPlan.read_pair
    monkeypatch.setattr(plan_mod.RunPlan, "read_pair", lambda self, *a: threads.append(
        threading.current_thread().name) or real(self, *a))
    one = _score(tmp_path, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"))
    ahead = [t for t in threads if t.startswith("dynaeval-read")]
    assert len(ahead) == 4  # every frame
    # the thread is gone (named, not counted: other tests' threads may end meanwhile)
    assert not [t for t in threading.enumerate() if t.name.startswith("dynaeval-read")]
    threads.clear()
    two = _score(tmp_path, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"),
                 workers=2)
    assert not [t for t in threads if t.startswith("dynaeval-read")]
    assert [f["ssim"] for f in one["frames"]] == [f["ssim"] for f in two["frames"]]
    assert one["cameras"] == two["cameras"]


def test_a_broken_frame_read_ahead_is_refused_at_its_own_frame(tmp_path):
    rng = np.random.default_rng(5)
    base = textured_frame(rng, 48, 64)
    _write(tmp_path, [np.roll(base, 2 * t, axis=1) for t in range(4)])
    bad = tmp_path / "pred" / "0002.png"
    bad.write_bytes(bad.read_bytes()[:200])  # truncated
    with pytest.raises(InputError, match="0002.png"):
        _score(tmp_path, metrics=("psnr",), focus=FocusConfig(source="none"))

"""The detector shipped in the package: format, and that it finds the player in a held-out render."""

import json

import cv2
import numpy as np
import pytest

from dynaeval.cli import main
from dynaeval.regions.detector import DEFAULT_DETECTOR, Detector, DetectorConfig, file_sha256
from reference_models.detector.evaluate import _iou_matrix
from reference_models.scenes import build_scene, render_scene, render_view


@pytest.fixture(scope="module")
def shipped():
    return Detector(DetectorConfig())  # model=None: the packaged file


def test_shipped_model_is_small_yolo_with_person_and_ball(shipped):
    assert shipped.path == DEFAULT_DETECTOR
    assert DEFAULT_DETECTOR.stat().st_size < 3e6
    assert shipped.convention == "yolo"
    assert shipped.class_names == {0: "person", 1: "ball"}
    assert shipped.selected_ids == (0, 1)
    assert shipped._input_hw() == (416, 416)


@pytest.mark.parametrize(("preset", "width", "height"), [
    ("single-player-closeup", 64, 36),  # the generator's tiny size: the player is ~5 x 12 px
    ("single-player-broadcast", 160, 90),  # at 64 x 36 the player is 3 x 7 px: IoU 0.47 there
])
def test_finds_the_player_in_a_held_out_frame(shipped, preset, width, height):
    # seed 0 is a held-out seed (training uses seeds >= 1000)
    scene = build_scene(preset, seed=0, size="tiny", width=width, height=height)
    view = render_view(scene, "eval00", frame=3)
    gt = np.array([b["box"] for b in view.boxes if b["class"] == "person"])
    found = shipped(np.round(view.rgb * 255).astype(np.uint8))
    person = found.boxes[np.array(found.classes) == "person"]
    assert person.shape[0] >= 1, found
    assert _iou_matrix(gt, person).max() > 0.5


def test_score_with_the_default_detector(tmp_path, capsys):
    gt = tmp_path / "gt"
    render_scene("single-player-closeup", gt, size="tiny", seed=1)
    pred = tmp_path / "pred"
    for src in sorted((gt / "images").rglob("*.png")):
        dst = pred / src.relative_to(gt / "images")
        dst.parent.mkdir(parents=True, exist_ok=True)
        img = cv2.imread(str(src))
        cv2.imwrite(str(dst), np.clip(img.astype(int) + 6, 0, 255).astype(np.uint8))
    out = tmp_path / "r.json"
    code = main(["score", str(pred), str(gt / "images"), "-o", str(out), "--no-lpips", "-q",
                 "--no-temporal"])
    _, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(out.read_text())
    focus = doc["settings"]["focus"]
    assert focus["source"] == "detector"
    assert focus["detector"]["model_sha256"] == file_sha256(DEFAULT_DETECTOR)
    focused = [f["focused_psnr"] for f in doc["frames"] if f["focused_psnr"] is not None]
    assert len(focused) >= len(doc["frames"]) // 2  # the player is found in most tiny frames

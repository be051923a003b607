"""Issue 17 item 4: on the bundled sample the bundled detector finds the generator's objects, and
only those: person and ball precision and recall >= 0.9 at IoU 0.5 (before its per-class score
thresholds it found 3-5 "balls" in the crowd of cam07, scores 0.25-0.32)."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.cli import sample_dir
from dynaeval.core.boxes import box_iou_matrix
from dynaeval.io import find_frames
from dynaeval.regions.boxes_file import frame_key, read_boxes_file
from dynaeval.regions.detector import Detector, DetectorConfig


def _counts(det: Detector) -> dict[str, list[int]]:
    """Per class ``[ground truth, detections, matched]`` over the sample (greedy by score,
    IoU >= 0.5, one match per box)."""
    truth = read_boxes_file(sample_dir() / "boxes.json").boxes
    out = {"person": [0, 0, 0], "ball": [0, 0, 0]}
    for cam in find_frames(sample_dir() / "gt", role="ground truth").values():
        for name, ref in cam.frames:
            found = det(ref.read())
            for c, acc in out.items():
                gt = np.array([r["box"] for r in truth[frame_key(cam.name, name)]
                               if r["class"] == c], dtype=np.int64).reshape(-1, 4)
                mine = found.boxes[[k == c for k in found.classes]].reshape(-1, 4)
                acc[0] += len(gt)
                acc[1] += len(mine)
                iou = box_iou_matrix(mine.astype(float), gt.astype(float))
                taken = np.zeros(len(gt), bool)
                for i in range(len(mine)):  # already sorted by score
                    cand = np.where(taken, -1.0, iou[i]) if len(gt) else np.array([-1.0])
                    j = int(np.argmax(cand))
                    if cand[j] >= 0.5:
                        taken[j] = True
                acc[2] += int(taken.sum())
    return out


def test_bundled_detector_matches_the_generator_boxes_on_the_sample():
    for c, (n_gt, n_det, hit) in _counts(Detector()).items():
        assert hit / n_gt >= 0.9, (c, "recall", hit, n_gt)
        assert hit / n_det >= 0.9, (c, "precision", hit, n_det)


def test_without_its_class_thresholds_the_crowd_gives_false_balls():
    """The per-class thresholds are what removes them (the same model, the old rule)."""
    n_gt, n_det, hit = _counts(Detector(DetectorConfig(model_thresholds=False)))["ball"]
    assert hit / n_det < 0.9 and n_det - hit >= 5


def test_class_thresholds_come_from_the_model_and_are_recorded():
    det = Detector()
    assert set(det.class_thresholds) == {0, 1}
    assert all(t >= det.config.score_threshold for t in det.class_thresholds.values())
    assert det.source()["class_score_thresholds"] == {
        det.class_names[i]: t for i, t in sorted(det.class_thresholds.items())}


def test_bad_threshold_metadata_is_an_input_error(tmp_path):
    onnx = pytest.importorskip("onnx")
    from dynaeval.errors import InputError
    from dynaeval.regions.detector import DEFAULT_DETECTOR
    from dynaeval.regions.fetch import write_onnx_metadata

    path = tmp_path / "d.onnx"
    path.write_bytes(DEFAULT_DETECTOR.read_bytes())
    write_onnx_metadata(path, {"score_thresholds": "{'ball': 1.5}"})
    assert onnx.load(str(path)).metadata_props
    with pytest.raises(InputError, match="score_thresholds must be in"):
        Detector(DetectorConfig(model=path))
    write_onnx_metadata(path, {"score_thresholds": "ball=0.4"})
    with pytest.raises(InputError, match="not a {class: score} mapping"):
        Detector(DetectorConfig(model=path))


def test_detections_say_how_many_input_pixels_an_image_pixel_is():
    """The bundled detector letterboxes a frame into 416 x 416: a 320 x 180 frame is scaled by
    1.3, a 1920 x 1080 one by 416 / 1920; presence's small-object rule reads it (issue 43)."""
    det = Detector()
    assert det.input_scale((180, 320)) == pytest.approx(416 / 320)
    assert det.input_scale((1080, 1920)) == pytest.approx(416 / 1920)
    found = det(np.zeros((180, 320, 3), np.uint8))
    assert found.input_scale == pytest.approx(416 / 320)

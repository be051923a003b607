"""The CLI's region options and lines (issue 17 items 2, 3): ``--classes`` for ``score`` and
``detect``, the regions found per camera, the bundled-detector warning and the no-box headline."""

from __future__ import annotations

import json

import pytest

from dynaeval.cli import main, parse_classes, sample_dir
from dynaeval.errors import InputError

from .test_cli import run


def test_parse_classes_names_ids_commas_and_spaces():
    assert parse_classes(["person,32", " sports ball "]) == ("person", 32, "sports ball")
    assert parse_classes(["person", "ball"]) == ("person", "ball")
    assert parse_classes(None) is None
    with pytest.raises(InputError, match="--classes names no class"):
        parse_classes([" , "])


def test_score_classes_select_the_detector_classes(tmp_path, scene, capsys):
    pred, gt = scene
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--no-temporal",
                       "--classes", "ball", "-o", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert doc["settings"]["focus"]["detector"]["class_ids"] == [1]  # the bundled {0: person, 1: ball}
    assert list(doc["regions"]["cameras"]["cam00"]["boxes"]) == ["ball"]
    assert "dynaeval: regions: cam00: " in err and " ball boxes in " in err


def test_unknown_class_exits_2_naming_it_and_the_model_names(tmp_path, scene, capsys):
    pred, gt = scene
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "--classes", "person,cat")
    assert code == 2
    assert "class 'cat' is not among the detector's classes (ball, person)" in err
    code, _, err = run(capsys, "detect", gt, "-o", tmp_path / "b.json", "--classes", "referee")
    assert code == 2 and "'referee' is not among" in err and not (tmp_path / "b.json").exists()
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "--focus", "motion", "--classes", "person")
    assert code == 2 and "need focus 'detector'" in err


def test_detect_with_classes_and_the_bundled_detector_warning(tmp_path, scene, capsys):
    _, gt = scene
    code, out, err = run(capsys, "detect", gt, "-o", tmp_path / "b.json", "-q", "--classes", "0")
    assert code == 0, err
    assert err.count("bundled synthetic-scene detector") == 1
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["source"]["detector"]["class_ids"] == [0]
    assert all(r["class"] == "person" for recs in doc["boxes"].values() for r in recs)


def test_detect_device_auto_is_the_cpu_without_a_gpu_and_gives_the_cpu_boxes(tmp_path, scene, capsys):
    """``detect --device`` is the table's option (as ``score --device``): ``auto`` runs where no
    GPU is and finds the same boxes as ``cpu`` (it was a cpu/cuda choice of its own)."""
    _, gt = scene
    docs = []
    for device in ("cpu", "auto"):
        code, _, err = run(capsys, "detect", gt, "-o", tmp_path / f"{device}.json", "-q",
                           "--device", device)
        assert code == 0, err
        docs.append(json.loads((tmp_path / f"{device}.json").read_text())["boxes"])
    assert docs[0] == docs[1] and docs[0]


def test_no_box_headline_replaces_the_null_summary_lines(tmp_path, scene, capsys):
    pred, gt = scene
    boxes = tmp_path / "empty.json"
    keys = [f"{c}/{t:04d}" for c in ("cam00", "cam01") for t in range(4)]
    boxes.write_text(json.dumps(dict.fromkeys(keys, [])))
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", f"boxes:{boxes}")
    assert code == 0, err
    lines = [ln for ln in err.splitlines() if ln.startswith("dynaeval: warning:")]
    assert lines[0].startswith("dynaeval: warning: no focus box in any of the 8 ground-truth frames")
    assert not any("focused_" in ln and "summary is null" in ln for ln in lines), lines
    assert not any("presence_" in ln and "summary is null" in ln for ln in lines), lines
    assert "dynaeval: regions: cam00: 0 person and 0 ball boxes in 0 of 4 frames (boxes)" in err


def test_detect_motion_on_a_panning_camera_warns(tmp_path, capsys):
    skdata = pytest.importorskip("skimage.data")

    from ..helpers import write_frames

    photo = skdata.chelsea()
    write_frames(tmp_path / "gt", "pan", [photo[20:140, 20 + 2 * t:220 + 2 * t] for t in range(5)])
    code, _, err = run(capsys, "detect", tmp_path / "gt", "-o", tmp_path / "b.json", "-q",
                       "--source", "motion")
    assert code == 0, err
    assert "warning: camera pan: motion masks need a static camera" in err
    assert len(json.loads((tmp_path / "b.json").read_text())["boxes"]) == 5  # written all the same


def test_a_flat_folders_regions_line_names_it_as_the_report_does(tmp_path, capsys):
    """Issue 43 item 5: the console said "regions: .:" for a flat folder (camera "."); it names
    it after the ground-truth folder, as the report does (``camera_label``)."""
    s = sample_dir()
    code = main(["score", str(s / "pred" / "cam07"), str(s / "gt" / "cam07"), "--focus", "motion",
                 "--no-lpips", "--no-temporal", "-q", "-o", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert code == 0 and "regions: cam07:" in err and "regions: .:" not in err

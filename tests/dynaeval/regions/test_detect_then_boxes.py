"""Issue 17 item 4: ``dynaeval detect`` -> ``--focus boxes:FILE`` scores what ``--focus detector``
scores, presence included (the boxes file's detector is re-run on the prediction)."""

from __future__ import annotations

import json

from dynaeval.cli import main, sample_dir


def _score(tmp_path, name: str, *focus: str) -> dict:
    root = sample_dir()
    out = tmp_path / f"{name}.json"
    assert main(["score", str(root / "pred"), str(root / "gt"), *focus, "--no-lpips",
                 "--no-temporal", "-q", "-o", str(out)]) == 0
    return json.loads(out.read_text())


def test_detect_then_boxes_scores_as_the_detector(tmp_path):
    boxes = tmp_path / "boxes.json"
    assert main(["detect", str(sample_dir() / "gt"), "-o", str(boxes), "-q"]) == 0
    direct = _score(tmp_path, "direct")
    reused = _score(tmp_path, "reused", "--focus", f"boxes:{boxes}")
    assert reused["settings"]["presence"]["detector_test"] is True
    assert direct["settings"]["presence"]["detector_test"] is True
    assert reused["summary"] == direct["summary"]
    assert reused["cameras"] == direct["cameras"]
    assert [f | {"objects": None} for f in reused["frames"]] == \
           [f | {"objects": None} for f in direct["frames"]]


def test_boxes_file_of_a_missing_detector_runs_the_region_test_and_says_so(tmp_path):
    boxes = tmp_path / "boxes.json"
    assert main(["detect", str(sample_dir() / "gt"), "-o", str(boxes), "-q"]) == 0
    doc = json.loads(boxes.read_text())
    doc["source"]["detector"]["model_sha256"] = "0" * 64
    boxes.write_text(json.dumps(doc))
    res = _score(tmp_path, "other", "--focus", f"boxes:{boxes}")
    presence = res["settings"]["presence"]
    assert presence["detector_test"] is False
    assert "not on this machine with the same SHA-256" in presence["detector_test_skipped"]


def test_generator_boxes_run_the_region_test_only(tmp_path):
    res = _score(tmp_path, "gen", "--focus", f"boxes:{sample_dir() / 'boxes.json'}")
    assert res["settings"]["presence"]["detector_test"] is False
    assert "detector_test_skipped" not in res["settings"]["presence"]

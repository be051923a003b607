"""The results document: summaries, strict JSON, atomic writes, schema checks."""

from __future__ import annotations

import json
import math

import pytest

from dynaeval.core.outcome import CameraTerm, Outcome, Status
from dynaeval.errors import InputError
from dynaeval.regions import sources
from dynaeval.report import (
    RunRecord,
    build_results,
    load_results,
    schema_path,
    strict,
    write_json_atomic,
)
from dynaeval.report.results import no_regions_warning


def _doc(rows, names=("psnr",)):
    return build_results(RunRecord(
        rows=rows, metric_names=list(names), method="m", scene="s", pred_dir="p", gt_dir="g",
        settings={}, unscored_cameras=[], skipped=[], warnings=[], timing={"total_s": 1.0},
        version="0",
    ))


def _row(cam, i, **values):
    return {"camera": cam, "frame": str(i), "index": i, "pred": "p", "gt": "g", **values}


def test_summary_is_mean_of_frames_and_cameras_mean_their_frames():
    doc = _doc([_row("a", 0, psnr=10.0), _row("a", 1, psnr=20.0), _row("b", 0, psnr=40.0)])
    assert doc["cameras"]["a"]["psnr"] == 15.0 and doc["cameras"]["b"]["psnr"] == 40.0
    # every frame weighs the same: (10 + 20 + 40) / 3, not the mean of camera means (27.5)
    assert doc["summary"]["psnr"] == pytest.approx(70 / 3)
    assert doc["summary"]["n_frames"] == 3 and doc["counts"]["psnr"] == 3


def test_infinite_frame_value_becomes_null_and_summary_null_with_reason():
    doc = _doc([_row("a", 0, psnr=math.inf), _row("a", 1, psnr=30.0)])
    assert doc["frames"][0]["psnr"] is None and doc["frames"][1]["psnr"] == 30.0
    assert doc["summary"]["psnr"] is None
    assert any("infinite" in w["reason"] for w in doc["warnings"])
    json.dumps(doc, allow_nan=False)  # strict JSON


def test_undefined_frames_are_left_out_of_the_mean_and_counted():
    doc = _doc([_row("a", 0, psnr=None), _row("a", 1, psnr=30.0)])
    assert doc["summary"]["psnr"] == 30.0 and doc["counts"]["psnr"] == 1


def test_strict_replaces_non_finite_everywhere():
    assert strict({"a": [1.0, math.nan, {"b": -math.inf}]}) == {"a": [1.0, None, {"b": None}]}


def test_document_validates_against_shipped_schema():
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(schema_path().read_text())
    doc = _doc([_row("a", 0, psnr=12.0, ssim=0.5)], names=("psnr", "ssim"))
    jsonschema.validate(doc, schema)
    doc["frames"][0]["psnr"] = "12"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(doc, schema)


def test_write_is_atomic_and_refuses_to_overwrite(tmp_path):
    out = tmp_path / "r.json"
    write_json_atomic(out, {"a": 1})
    with pytest.raises(InputError, match=r"r\.json: results file exists; pass --overwrite"):
        write_json_atomic(out, {"a": 2})
    write_json_atomic(out, {"a": 3}, overwrite=True)
    assert json.loads(out.read_text()) == {"a": 3}


def test_failed_write_leaves_no_file(tmp_path):
    out = tmp_path / "r.json"
    with pytest.raises(ValueError):
        write_json_atomic(out, {"a": math.nan})  # allow_nan=False refuses
    assert list(tmp_path.iterdir()) == []


def test_write_into_missing_folder_creates_it(tmp_path):
    assert json.loads(write_json_atomic(tmp_path / "no" / "r.json", {}).read_text()) == {}
    with pytest.raises(InputError, match="cannot create the folder for the results file"):
        write_json_atomic(tmp_path / "no" / "r.json" / "x.json", {})


def test_load_results_checks_schema(tmp_path):
    good = tmp_path / "good.json"
    good.write_text(json.dumps(_doc([_row("a", 0, psnr=1.0)])))
    assert load_results(good)["method"] == "m"
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"schema": "dynaeval/results/v0"}))
    with pytest.raises(InputError, match=r"old\.json: results schema 'dynaeval/results/v0' is not"):
        load_results(old)
    other = tmp_path / "other.json"
    other.write_text("[1, 2]")
    with pytest.raises(InputError, match="not a dynaeval results file"):
        load_results(other)
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(InputError, match="not valid JSON"):
        load_results(bad)


def test_temporal_pairs_go_to_the_later_frame_and_flicker_stays_per_camera():
    rows = [_row("a", i, psnr=20.0 + i) for i in range(3)] + [_row("b", 0, psnr=30.0)]
    few = CameraTerm.null(Status.UNDEFINED, "fewer than 2 frames")
    temporal = {
        "a": {"warp_error": CameraTerm(Outcome(0.2), (0.1, 0.3)),
              "flicker": CameraTerm(Outcome(0.05))},
        "b": {"warp_error": few, "flicker": few},
    }
    doc = build_results(RunRecord(
        rows=rows, metric_names=["psnr"], method="m", scene="s", pred_dir="p", gt_dir="g",
        settings={}, unscored_cameras=[], skipped=[], warnings=[], timing={"total_s": 1.0},
        version="0", temporal=temporal,
    ))
    assert [f.get("warp_error") for f in doc["frames"]] == [None, 0.1, 0.3, None]
    assert "warp_error" not in doc["frames"][0]  # the first frame has no previous frame
    assert doc["cameras"]["a"]["warp_error"] == pytest.approx(0.2)
    assert doc["cameras"]["b"]["warp_error"] is None
    assert doc["summary"]["warp_error"] == pytest.approx(0.2) and doc["counts"]["warp_error"] == 2
    assert doc["cameras"]["a"]["flicker"] == 0.05 and doc["cameras"]["b"]["flicker"] is None
    assert doc["summary"]["flicker"] == 0.05 and doc["counts"]["flicker"] == 1
    assert {"camera": "b", "metric": "flicker", "status": "undefined",
            "reason": "fewer than 2 frames"} in doc["warnings"]


def test_the_sides_of_a_temporal_term_reach_the_results():
    """Issue 41: the engine's signed / pred / gt means were computed and dropped; they are
    written per camera in ``temporal_parts``, terms without parts left out."""
    rows = [_row("a", i, psnr=20.0) for i in range(3)]
    parts = {"signed": -0.1, "pred": 0.2, "gt": 0.3}
    temporal = {"a": {"warp_error": CameraTerm(Outcome(0.2), (0.1, 0.3), parts=parts),
                      "tof": CameraTerm(Outcome(0.5), (0.5, 0.5))}}
    doc = build_results(RunRecord(
        rows=rows, metric_names=["psnr"], method="m", scene="s", pred_dir="p", gt_dir="g",
        settings={}, unscored_cameras=[], skipped=[], warnings=[], timing={"total_s": 1.0},
        version="0", temporal=temporal,
    ))
    assert doc["temporal_parts"] == {"a": {"warp_error": parts}}


def _no_box_regions(source: str, bundled: bool = False) -> dict:
    return {"source": source, "bundled_detector": bundled,
            "cameras": {"c": {"frames_with_boxes": 0, "n_frames": 3, "boxes": {"person": 0}}}}


@pytest.mark.parametrize(("source", "bundled", "who", "fix"), [
    ("detector", True, "the bundled synthetic-scene detector found none",
     "the bundled detector knows only dynaeval's synthetic scenes: for real footage fetch a COCO "
     "detector (dynaeval detector fetch retinanet, then --detector retinanet) or score with "
     "--focus motion"),
    ("detector", False, "the detector found none",
     "check --classes (the detector keeps: person) and that the footage is what the detector was "
     "trained on, or score with --focus motion"),
    ("boxes", False, "the boxes file lists none",
     "check that the file's keys are '<camera>/<frame>' of these frames (dynaeval detect GT -o "
     "boxes.json writes them)"),
    ("motion", False, "the motion masks hold no moving region",
     "motion boxes need a static camera and moving objects: score with --focus detector or "
     "--focus boxes:FILE"),
])
def test_the_no_box_headline_says_what_found_none_and_the_fix(source, bundled, who, fix):
    """The words of each source (issue 41 moved them from dicts keyed by name in core/outcome.py
    onto the source's class; these are the texts before the move)."""
    presence = "" if source == "motion" else " and presence value"
    got = no_regions_warning(_no_box_regions(source, bundled))
    assert got["status"] == "no-region" and got["reason"] == (
        f"no focus box in any of the 3 ground-truth frames: {who}, so every focused_* value"
        f"{presence} is null. Fix: {fix}")
    assert no_regions_warning(_no_box_regions("none")) is None


def test_a_new_focus_source_gets_the_no_box_headline_without_an_edit_elsewhere(monkeypatch):
    """A kind added in ``SOURCE_KINDS`` alone: its headline has its own words (the dicts keyed
    by source name raised KeyError for it)."""

    class ToyBoxes(sources.BoxesFileSource):
        name = spec = "toyboxes"
        none_found = "the toy file lists none"

    monkeypatch.setitem(sources.SOURCE_KINDS, "toyboxes", ToyBoxes())
    got = no_regions_warning(_no_box_regions("toyboxes"))
    assert "frames: the toy file lists none, so every" in got["reason"]
    assert got["reason"].endswith(f"Fix: {sources.BoxesFileSource.none_found_fix}")

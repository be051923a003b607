"""Results files of schema ``dynaeval/results/v1`` (before statuses, issue 31) are still read by
``load_results``, ``merge``, ``leaderboard`` and the tables, with the statuses this version
writes inferred once, at load (``dynaeval.report.results._upgrade_v1``).

The v1 files in ``data/v1`` were written by dynaeval at commit 033dc1f (main before issue 31's
statuses; each file's ``provenance`` has the command) on the scene ``_scene`` makes again here:
three cameras, a prediction frame equal to its ground truth (PSNR +inf), a missing frame
(``--allow-missing``), with motion masks, with an empty boxes file (no box in any frame) and
with neither boxes nor masks."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from dynaeval.cli import main
from dynaeval.core.outcome import Status
from dynaeval.errors import InputError
from dynaeval.regions.boxes_file import write_boxes_file
from dynaeval.report import load_results, schema_path
from dynaeval.report.leaderboard import build_leaderboard
from dynaeval.report.merge import merge_results
from dynaeval.report.results import SCHEMA, SCHEMA_V1
from dynaeval.report.table import summary_table

from ..helpers import three_camera_scene

V1 = Path(__file__).resolve().parents[1] / "data" / "v1"
RUNS = {"motion": ["--focus", "motion", "--no-presence"], "noboxes": ["--focus", "boxes:{boxes}"],
        "none": ["--focus", "none", "--no-masked"]}
NUMBERS = ("frames", "cameras", "summary", "counts", "metrics")


def _scene(root: Path) -> tuple[Path, Path, Path]:
    """The scene of the v1 files: (pred, gt, an empty boxes file)."""
    pred, gt = three_camera_scene(root)
    shutil.copy(gt / "cam1" / "0002.png", pred / "cam1" / "0002.png")  # PSNR +inf
    (pred / "cam2" / "0001.png").unlink()  # a missing frame
    boxes = root / "boxes.json"
    write_boxes_file(boxes, {f"{c}/{t:04d}": [] for c in ("cam0", "cam1", "cam2")
                             for t in range(4)}, {"kind": "test"})
    return pred, gt, boxes


def _score(tmp_path: Path, run: str, *extra: str) -> dict:
    pred, gt, boxes = _scene(tmp_path / "scene")
    out = tmp_path / f"{run}.json"
    opts = [o.format(boxes=boxes) for o in RUNS[run]]
    assert main(["score", str(pred), str(gt), "-o", str(out), "--no-lpips", "-q",
                 "--allow-missing", *opts, *extra]) == 0
    return json.loads(out.read_text())


def _where(doc: dict) -> list[tuple]:
    return [(w.get("camera"), w.get("frame"), w.get("metric"), w["status"], w["reason"])
            for w in doc["warnings"]]


def test_the_files_are_v1():
    for f in V1.glob("*.json"):
        doc = json.loads(f.read_text())
        assert doc["schema"] == SCHEMA_V1 and "summary_status" not in doc, f
        assert not any("status" in w for w in doc["warnings"]), f


@pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")
@pytest.mark.parametrize("run", sorted(RUNS))
def test_a_v1_file_gets_the_statuses_this_version_writes(tmp_path, run, capsys):
    """Every warning of the old file gets the status a run of this version gives it, and every
    null summary its ``summary_status``; numbers and texts are the file's."""
    old = load_results(V1 / f"v1-{run}-all.json")
    new = _score(tmp_path, run)
    assert old["schema"] == new["schema"] == SCHEMA
    assert old["summary_status"] == new["summary_status"]
    assert _where(old) == _where(new)
    assert old["summary"] == new["summary"] and old["counts"] == new["counts"]
    capsys.readouterr()


def test_the_statuses_code_acts_on_are_found(tmp_path):
    """Those that merge and ``restore_infinite`` need: the infinite frame, the null summaries,
    the missing frames, the no-box headline."""
    motion = load_results(V1 / "v1-motion-all.json")
    infinite = [w for w in motion["warnings"] if w["status"] == Status.INFINITE and "frame" in w]
    assert {(w["camera"], w["frame"]) for w in infinite} == {("cam1", "0002")}
    assert motion["summary_status"]["psnr"] == "infinite"
    assert [w["status"] for w in motion["warnings"] if "camera" not in w
            and "metric" not in w].count("missing-frames") == 1
    noboxes = load_results(V1 / "v1-noboxes-all.json")
    assert noboxes["warnings"][0]["status"] == "no-region" and "metric" not in noboxes["warnings"][0]
    assert noboxes["summary_status"]["focused_psnr"] == "no-region"


@pytest.mark.parametrize("run", sorted(RUNS))
def test_v1_shards_merge_into_the_unsharded_v1_run(run):
    """The shards' +inf restored (from the inferred status), their null-summary warnings, the
    no-box headline and the missing-frames warning made again: the unsharded file's document."""
    merged = merge_results([V1 / f"v1-{run}-part1.json", V1 / f"v1-{run}-part2.json"])
    whole = load_results(V1 / f"v1-{run}-all.json")
    for key in (*NUMBERS, "summary_status"):
        assert merged[key] == whole[key], key
    assert sorted(map(json.dumps, merged["warnings"])) == sorted(map(json.dumps, whole["warnings"]))


def test_v1_and_v2_files_share_a_leaderboard(tmp_path, capsys):
    new = tmp_path / "new.json"
    new.write_text(json.dumps({**_score(tmp_path, "motion"), "method": "new"}))
    board = build_leaderboard([V1 / "v1-motion-all.json", new])
    assert [r["method"] for r in board["rows"] if r["scene"] != "(all)"] == ["pred", "new"]
    rows = {r["method"]: r for r in board["rows"] if r["scene"] != "(all)"}
    assert rows["pred"]["values"]["ssim"]["mean"] == rows["new"]["values"]["ssim"]["mean"]
    capsys.readouterr()


def test_a_v1_file_prints_its_table():
    assert "ssim" in summary_table(load_results(V1 / "v1-noboxes-all.json"))


def test_a_v1_file_is_checked_against_the_v1_schema(tmp_path):
    """A v1 file is validated by the schema it was written to (v1 warnings have no status),
    and the upgraded document is a valid v2 one."""
    jsonschema = pytest.importorskip("jsonschema")
    doc = json.loads((V1 / "v1-motion-all.json").read_text())
    jsonschema.validate(doc, json.loads(schema_path(SCHEMA_V1).read_text()))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(doc, json.loads(schema_path().read_text()))
    jsonschema.validate(load_results(V1 / "v1-motion-all.json"),
                        json.loads(schema_path().read_text()))
    doc["warnings"][0]["reason"] = 3
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"'warnings\[0\]\.reason' must be a JSON string, got 3"):
        load_results(tmp_path / "bad.json")


def test_a_v2_file_without_statuses_is_refused(tmp_path):
    """A file that says v2 must have them (only v1 files are given statuses), each one of the
    statuses, with or without jsonschema (``check_results``)."""
    doc = json.loads((V1 / "v1-motion-all.json").read_text())
    doc["schema"] = SCHEMA
    (tmp_path / "r.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"no 'summary_status'"):
        load_results(tmp_path / "r.json")
    doc["summary_status"] = {}
    (tmp_path / "r.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"no 'warnings\[0\]\.status'"):
        load_results(tmp_path / "r.json")
    doc = load_results(V1 / "v1-motion-all.json")
    doc["warnings"][2]["status"] = "ok"
    (tmp_path / "r.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"'warnings\[2\]\.status' must be one of infinite, "):
        load_results(tmp_path / "r.json")
    doc["warnings"][2]["status"] = "infinite"
    doc["summary_status"]["psnr"] = "+inf"
    (tmp_path / "r.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"'summary_status\.psnr' must be one of infinite, "):
        load_results(tmp_path / "r.json")

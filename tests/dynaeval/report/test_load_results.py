"""Reading results files fed to leaderboard / merge: strict JSON, complete, readable (issue 16
items 4, 6, 7). Every refusal names the file, and the CLI turns it into exit 2."""

from __future__ import annotations

import json
import pathlib
import sys

import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.report import RunRecord, build_results, load_results, schema_path
from dynaeval.report.results_check import RESULTS_REQUIRED


def _doc():
    rows = [{"camera": "c", "frame": str(i), "index": i, "pred": "p", "gt": "g", "psnr": 30.0 + i}
            for i in range(3)]
    return build_results(RunRecord(
        rows=rows, metric_names=["psnr"], method="m", scene="s", pred_dir="p", gt_dir="g",
        settings={}, unscored_cameras=[], skipped=[], warnings=[], timing={"total_s": 1.0},
        version="0"))


def _write(path, doc):
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
def test_nan_or_infinity_token_refused_naming_file_and_key(tmp_path, token):
    text = json.dumps(_doc()).replace('"psnr": 31.0', f'"psnr": {token}', 1)
    assert token in text
    (tmp_path / "r.json").write_text(text)
    with pytest.raises(InputError, match=rf"r\.json: frames\[1\]\.psnr is {token}, which is "
                                         "not strict JSON"):
        load_results(tmp_path / "r.json")


def test_nan_in_summary_refused_through_leaderboard_and_merge(tmp_path, capsys):
    text = json.dumps(_doc()).replace('"summary": {"n_frames": 3, "psnr": 31.0',
                                      '"summary": {"n_frames": 3, "psnr": NaN')
    (tmp_path / "r.json").write_text(text)
    for argv in (["leaderboard", str(tmp_path / "r.json")],
                 ["merge", str(tmp_path / "r.json"), "-o", str(tmp_path / "m.json")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "r.json: summary.psnr is NaN" in err and "Traceback" not in err
    assert not (tmp_path / "m.json").exists()


@pytest.mark.parametrize("key", ["frames", "settings", "method"])
@pytest.mark.parametrize("with_jsonschema", [True, False])
def test_missing_key_refused_naming_it(tmp_path, monkeypatch, capsys, key, with_jsonschema):
    if not with_jsonschema:
        monkeypatch.setitem(sys.modules, "jsonschema", None)  # import jsonschema -> ImportError
    doc = _doc()
    del doc[key]
    path = _write(tmp_path / "r.json", doc)
    with pytest.raises(InputError, match=rf"r\.json: not a complete dynaeval results file: no "
                                         rf"'{key}'"):
        load_results(path)
    assert main(["leaderboard", str(path)]) == 2
    assert f"no '{key}'" in capsys.readouterr().err


@pytest.mark.parametrize("with_jsonschema", [True, False])
def test_wrong_types_refused(tmp_path, monkeypatch, with_jsonschema):
    if not with_jsonschema:
        monkeypatch.setitem(sys.modules, "jsonschema", None)
    doc = _doc()
    doc["frames"] = {"not": "a list"}
    with pytest.raises(InputError, match=r"r\.json: not a valid dynaeval results file: 'frames' "
                                         "must be a JSON array"):
        load_results(_write(tmp_path / "r.json", doc))
    doc = _doc()
    del doc["frames"][2]["camera"]
    with pytest.raises(InputError, match=r"no 'frames\[2\]\.camera'"):
        load_results(_write(tmp_path / "r.json", doc))
    doc = _doc()
    del doc["inputs"]["gt"]
    with pytest.raises(InputError, match=r"no 'inputs\.gt'"):
        load_results(_write(tmp_path / "r.json", doc))


def test_schema_violation_found_by_jsonschema_names_the_place(tmp_path):
    """What the field-by-field check leaves to the schema (an object record's own fields, which
    merge and the leaderboard do not read) is still refused where jsonschema is installed."""
    pytest.importorskip("jsonschema")
    doc = _doc()
    doc["frames"][1]["objects"] = [{"class": "person"}]
    with pytest.raises(InputError, match=r"r\.json: not a valid dynaeval results file: "
                                         r"frames\[1\]\.objects\[0\]: 'id' is a required"):
        load_results(_write(tmp_path / "r.json", doc))


def test_required_keys_are_the_schemas():
    schema = json.loads(schema_path().read_text())
    assert list(RESULTS_REQUIRED[""]) == schema["required"]
    assert list(RESULTS_REQUIRED["inputs"]) == schema["properties"]["inputs"]["required"]


def test_folder_refused(tmp_path, capsys):
    with pytest.raises(InputError, match=r"is a folder, not a results file"):
        load_results(tmp_path)
    assert main(["leaderboard", str(tmp_path)]) == 2
    assert f"{tmp_path}: is a folder, not a results file" in capsys.readouterr().err


def test_unreadable_file_refused(tmp_path, monkeypatch, capsys):
    """Root reads a 0000 file, so the permission error is simulated where the file is read."""
    path = _write(tmp_path / "r.json", _doc())
    real = pathlib.Path.read_text

    def denied(self, *args, **kwargs):
        if self == path:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(pathlib.Path, "read_text", denied)
    with pytest.raises(InputError, match=r"r\.json: results file is not readable"):
        load_results(path)
    assert main(["leaderboard", str(path)]) == 2
    assert "r.json: results file is not readable (permission denied)" in capsys.readouterr().err


def test_complete_file_still_loads(tmp_path):
    doc = _doc()
    assert load_results(_write(tmp_path / "r.json", doc))["summary"] == doc["summary"]

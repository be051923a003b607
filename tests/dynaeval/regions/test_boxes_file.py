"""Boxes files: both layouts read, strict validation, atomic writes."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.regions.boxes_file import (
    BOXES_SCHEMA,
    frame_key,
    read_boxes_file,
    records_to_boxes,
    write_boxes_file,
)

GEN = {
    "cam00/000000": [
        {"class": "person", "id": 3, "box": [10, 20, 42, 96], "visible": 0.8, "team": "home"},
        {"class": "ball", "id": 0, "box": [100, 50, 106, 56], "visible": 1.0},
    ],
    "cam00/000001": [],
}


def _write(tmp_path, data, name="b.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_bare_mapping_from_generator(tmp_path):
    bf = read_boxes_file(_write(tmp_path, GEN))
    assert bf.schema is None and bf.source is None
    assert bf.boxes == GEN  # extra fields ("team") kept, empty frames kept
    np.testing.assert_array_equal(records_to_boxes(bf.boxes["cam00/000000"], ["ball"]), [[100, 50, 106, 56]])
    assert records_to_boxes(bf.boxes["cam00/000001"]).shape == (0, 4)


def test_write_then_read_wrapper(tmp_path):
    src = {"kind": "detector", "model_sha256": "ab" * 32, "model": tmp_path / "m.onnx",
           "settings": {"score_threshold": np.float32(0.25), "classes": ("person", 37)}}
    recs = {"cam01/000007": [{"class": "person", "id": np.int64(0), "box": np.array([1, 2, 3, 4]), "score": 0.5}]}
    p = write_boxes_file(tmp_path / "sub" / "boxes.json", recs, src)
    raw = json.loads(p.read_text())
    assert raw["schema"] == BOXES_SCHEMA and set(raw) == {"schema", "source", "boxes"}
    bf = read_boxes_file(p)
    assert bf.boxes == {"cam01/000007": [{"class": "person", "id": 0, "box": [1, 2, 3, 4], "score": 0.5}]}
    assert bf.source["settings"] == {"score_threshold": 0.25, "classes": ["person", 37]}
    assert bf.source["model"] == str(tmp_path / "m.onnx")
    assert [f for f in os.listdir(p.parent) if f.endswith(".tmp")] == []


def test_failed_write_leaves_old_file(tmp_path):
    p = write_boxes_file(tmp_path / "boxes.json", GEN)
    before = p.read_bytes()
    with pytest.raises(InputError, match="x_max > x_min"):
        write_boxes_file(p, {"cam00/000000": [{"class": "person", "box": [5, 5, 5, 9]}]})
    with pytest.raises(ValueError, match="Out of range float values"):
        write_boxes_file(p, GEN, {"bad": float("nan")})
    assert p.read_bytes() == before
    assert [f for f in os.listdir(tmp_path) if f.endswith(".tmp")] == []


def test_frame_key():
    assert frame_key("cam00", "000012.png") == "cam00/000012"
    assert frame_key("cam00", "000012") == "cam00/000012"


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ([1, 2], "must hold a JSON object"),
        ({"cam00": []}, r"key 'cam00': expected '<camera>/<frame>'"),
        ({"cam00/": []}, "camera and frame must both be non-empty"),
        ({"cam00/000001.png": []}, r"without extension, e.g. 'cam00/000001'"),
        ({"cam00/1": {"class": "person"}}, "expected a list of records"),
        ({"cam00/1": ["person"]}, "record 0: expected an object"),
        ({"cam00/1": [{"box": [0, 0, 1, 1]}]}, "'class' must be a non-empty string"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, 1]}]}, r"'box' must be \[x_min"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, 1.5, 2]}]}, "must be integers"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, True, 2]}]}, "must be integers"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, 2.0, 2]}]}, r"integers \(whole pixels\).*round them outwards"),
        ({"cam00/1": [{"class": "person", "box": [4, 0, 2, 2]}]},
         r"frame 'cam00/1', record 0: inverted box \[4, 0, 2, 2\]: x_max must be >= x_min.*swap"),
        ({"cam00/1": [{"class": "person", "box": [0, 5, 2, 2]}]}, r"inverted box \[0, 5, 2, 2\]: y_max must be >= y_min"),
        ({"cam00/1": [{"class": "person", "box": [2, 0, 2, 2]}]}, r"record 0: 'box' \[2, 0, 2, 2\] is empty"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, 2, 2], "id": "p1"}]}, "'id' must be an integer"),
        ({"cam00/1": [{"class": "person", "box": [0, 0, 2, 2], "visible": 1.5}]}, r"'visible' must be a number in \[0, 1\]"),
        ({"schema": "dynaeval/boxes/v9", "boxes": {}}, "unknown boxes schema"),
        ({"schema": BOXES_SCHEMA}, "has no 'boxes' object"),
        ({"schema": BOXES_SCHEMA, "boxes": {}, "source": 3}, "'source' must be an object"),
        ({"schema": BOXES_SCHEMA, "boxes": []}, "boxes must be a JSON object"),
    ],
)
def test_invalid_files_name_file_and_key(tmp_path, data, match):
    p = _write(tmp_path, data)
    with pytest.raises(InputError, match=match) as exc:
        read_boxes_file(p)
    assert exc.value.path == str(p)


def test_nan_visible_rejected(tmp_path):
    p = tmp_path / "b.json"
    p.write_text('{"cam00/1": [{"class": "ball", "box": [0, 0, 2, 2], "visible": NaN}]}')
    with pytest.raises(InputError, match=r"cam00/1\[0\]\.visible is NaN, which is not strict JSON"):
        read_boxes_file(p)


def test_missing_and_not_json(tmp_path):
    with pytest.raises(InputError, match="boxes file not found"):
        read_boxes_file(tmp_path / "nope.json")
    p = tmp_path / "b.json"
    p.write_text("{not json")
    with pytest.raises(InputError, match="not valid JSON"):
        read_boxes_file(p)



def _deny_open(monkeypatch, path):
    """Opening ``path`` raises PermissionError (root reads a 0000 file, so it is simulated)."""
    import pathlib

    real = pathlib.Path.open

    def denied(self, *args, **kwargs):
        if self == path:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(pathlib.Path, "open", denied)


def test_folder_and_unreadable_boxes_file_name_the_file(tmp_path, monkeypatch):
    """Issue 16 item 6: a PermissionError traceback before."""
    with pytest.raises(InputError, match=r"is a folder, not a boxes file"):
        read_boxes_file(tmp_path)
    p = _write(tmp_path, GEN)
    _deny_open(monkeypatch, p)
    with pytest.raises(InputError, match=r"b\.json: boxes file is not readable \(permission denied\)"):
        read_boxes_file(p)


def test_unreadable_boxes_file_exit_2_before_scoring(tmp_path, monkeypatch, capsys):
    from dynaeval.cli import main

    from ..helpers import moving_square_scene

    gt, _ = moving_square_scene(tmp_path / "gt")
    p = _write(tmp_path, GEN)
    _deny_open(monkeypatch, p)
    code = main(["score", str(gt), str(gt), "--focus", f"boxes:{p}", "--no-lpips", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "b.json: boxes file is not readable" in err and "Traceback" not in err


def test_write_without_overwrite_is_exclusive(tmp_path):
    """Two ``dynaeval detect`` runs racing for one -o: the second finds the file and writes
    nothing (the final step of the write fails if the target exists)."""
    out = tmp_path / "b.json"
    write_boxes_file(out, {"cam/0000": [{"class": "ball", "box": [0, 0, 4, 4]}]}, overwrite=False)
    first = out.read_text()
    with pytest.raises(InputError, match="exists"):
        write_boxes_file(out, {"cam/0000": []}, overwrite=False)
    assert out.read_text() == first
    write_boxes_file(out, {"cam/0000": []})  # default: replace
    assert read_boxes_file(out).boxes == {"cam/0000": []}


@pytest.mark.parametrize(("box", "match"), [
    ([226, 54, 206, 104], r"boxes\.json: frame 'cam07/0003', record 0: inverted box \[226, 54, 206, 104\]: "
                          "x_max must be >= x_min"),
    ([206.4, 54, 226, 104.6], r"boxes\.json: frame 'cam07/0003', record 0: 'box' coordinates must be integers"),
])
def test_bad_box_in_sample_boxes_file_is_exit_2_before_scoring(tmp_path, capsys, box, match):
    """The sample scene's own boxes file with one box broken: exit 2 naming file, frame and box,
    before any frame is read (no results file), instead of a null metric later."""
    import re

    from dynaeval.cli import main, sample_dir

    root = sample_dir()
    data = json.loads((root / "boxes.json").read_text())
    data["cam07/0003"][0]["box"] = box
    p = _write(tmp_path, data, "boxes.json")
    out = tmp_path / "r.json"
    code = main(["score", str(root / "pred"), str(root / "gt"), "--focus", f"boxes:{p}",
                 "--no-lpips", "-q", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and re.search(match, err) and "Traceback" not in err
    assert not out.exists()


def test_files_the_generator_and_detect_write_still_load():
    """The golden sample's boxes.json (the scene generator's, integer boxes) reads unchanged."""
    from dynaeval.cli import sample_dir

    bf = read_boxes_file(sample_dir() / "boxes.json")
    raw = json.loads((sample_dir() / "boxes.json").read_text())
    assert bf.boxes == raw and all(isinstance(v, int) for recs in raw.values()
                                   for r in recs for v in r["box"])


_DEEP = "[" * 500_000 + "]" * 500_000  # 1 MB; Python's parser recursed into it (a traceback)


@pytest.mark.parametrize(("edit", "match"), [
    (lambda t: '{"deep": ' + _DEEP + ", " + t[1:],
     r"boxes\.json: nested deeper than 64 levels \(500001\)"),
    (lambda t: json.dumps({"schema": BOXES_SCHEMA, "source": {"settings": json.loads(
        "[" * 70 + "]" * 70)}, "boxes": json.loads(t)}),
     r"boxes\.json: nested deeper than 64 levels \(72\)"),
    (lambda t: t.replace("[206, 54, 226, 104]", "[206, 54, " + "9" * 5000 + ", 104]", 1),
     r"boxes\.json: cam07/0000\[0\]\.box\[2\] is 999999999999\.\.\.\(5000 characters\): out "
     "of range"),
    (lambda t: t.replace('"visible": 1.0', '"visible": 1e999', 1),
     r"boxes\.json: cam07/0000\[0\]\.visible is 1e999: out of range"),
    (lambda t: t.replace("[206, 54, 226, 104]", "[206, 54, 100000000000000000000000, 104]", 1),
     r"boxes\.json: frame 'cam07/0000', record 0: 'box' coordinates must be within "
     r"±2147483647 pixels"),
    (lambda t: t.replace('"class": "person"', '"class": "person\\udc00"', 1),
     r"boxes\.json: cam07/0000\[0\]\.class holds a lone UTF-16 surrogate"),
])
def test_damaged_boxes_file_is_exit_2_naming_it(tmp_path, capsys, edit, match):
    """Issue 34 item 3, as a boxes file: a deep or damaged file is exit 2 before scoring, naming
    the file (and the key), never a traceback; a coordinate too large for the int64 boxes is
    refused (it was wrapped around into an "inverted box" with other corners)."""
    import re

    from dynaeval.cli import main, sample_dir

    root = sample_dir()
    text = json.dumps(json.loads((root / "boxes.json").read_text()))
    p = tmp_path / "boxes.json"
    p.write_text(edit(text))
    with pytest.raises(InputError, match=match):
        read_boxes_file(p)
    out = tmp_path / "r.json"
    code = main(["score", str(root / "pred"), str(root / "gt"), "--focus", f"boxes:{p}",
                 "--no-lpips", "--no-temporal", "-q", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and re.search(match, err) and "Traceback" not in err, err
    assert not out.exists()

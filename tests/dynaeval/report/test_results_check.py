"""Hand-edited or damaged results files (issue 34 item 3): every field merge, the leaderboard and
the report read is checked field by field without jsonschema, and a bad one is exit 2 naming the
file and the key path, never a traceback, a misleading message or a number printed from a
boolean.

Each case is run through ``load_results`` with and without jsonschema importable, and through
``dynaeval leaderboard`` and ``dynaeval merge`` with jsonschema made unimportable (a plain
``pip install dynaeval`` has none). Before: ``"psnr": "31.5"`` or ``true`` in the summary, a
shard without ``count``, a warning without ``reason``, ``1e999``, a deep file: tracebacks,
"shards missing", ``true`` printed as 1.00, +inf taken for identical images.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import sys
import time

import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.report import RunRecord, build_results, load_results


def _shard(index: int, camera: str) -> dict:
    """A shard of a two-camera run, as ``score --shard I/2`` writes it (regions, warnings, a
    temporal section in the settings)."""
    rows = [{"camera": camera, "frame": f"{i:04d}", "index": i, "pred": f"p/{i}.png",
             "gt": f"g/{i}.png", "psnr": 30.0 + i + index, "focused_psnr": None if i == 1 else
             28.0 + i} for i in range(3)]
    regions = {"source": "motion", "bundled_detector": False, "cameras": {camera: {
        "source": "motion", "n_frames": 3, "frames_with_boxes": 2, "boxes": {"motion": 2},
        "mask_fraction": {"mean": 0.1, "max": 0.2}, "global_motion_px": 0.01}}}
    warnings = [{"camera": camera, "frame": "0001", "metric": "focused_psnr",
                 "status": "no-region", "reason": "no box in this frame"}]
    return build_results(RunRecord(
        rows=rows, metric_names=["psnr", "focused_psnr"], method="m", scene="s", pred_dir="p",
        gt_dir="g", settings={"temporal": {"tlp": True}, "ssim": {"win_size": 11}},
        unscored_cameras=[], skipped=[], warnings=warnings, timing={"total_s": 1.0, "psnr": 0.1},
        version="0", shard=(index, 2), regions=regions))


def _set(*keys, value):
    def edit(doc):
        *parents, last = keys
        for k in parents:
            doc = doc[k]
        doc[last] = value
    return edit


def _delete(*keys):
    def edit(doc):
        *parents, last = keys
        for k in parents:
            doc = doc[k]
        del doc[last]
    return edit


def _text(old, new, after=""):
    """Replace the first ``old`` after ``after`` in the file's text."""
    def edit(text):
        start = text.index(after)
        return text[:start] + text[start:].replace(old, new, 1)
    return edit


DEEP = "[" * 500_000 + "]" * 500_000  # 1 MB
"""A deeply nested value: Python's parser recursed into it (RecursionError, a traceback)."""

CASES = {
    "summary string": (_set("summary", "psnr", value="31.5"), None,
                       r"'summary\.psnr' must be a number or null, got \"31\.5\" \(a string\); "
                       "write the number without quotes"),
    "summary true": (_set("summary", "focused_psnr", value=True), None,
                     r"'summary\.focused_psnr' must be a number or null, got true \(a boolean\)"),
    "frame true": (_set("frames", 2, "psnr", value=True), None,
                   r"'frames\[2\]\.psnr' must be a number or null, got true"),
    "frame string": (_set("frames", 0, "psnr", value="high"), None,
                     r"'frames\[0\]\.psnr' must be a number or null, got \"high\""),
    "camera value": (_set("cameras", "cam0", "psnr", value=[30]), None,
                     r"'cameras\.cam0\.psnr' must be a number or null, got an array"),
    "shard without count": (_delete("inputs", "shard", "count"), None,
                            r"no 'inputs\.shard\.count'"),
    "shard string index": (_set("inputs", "shard", "index", value="1"), None,
                           r"'inputs\.shard\.index' must be a whole number >= 1, got \"1\""),
    "shard index beyond count": (_set("inputs", "shard", "index", value=3), None,
                                 r"'inputs\.shard\.index' must be at most inputs\.shard\.count "
                                 r"\(2\)"),
    "shard index 0": (_set("inputs", "shard", "index", value=0), None,
                      r"'inputs\.shard\.index' must be a whole number >= 1, got 0"),
    "warning without reason": (_delete("warnings", 0, "reason"), None,
                               r"no 'warnings\[0\]\.reason'"),
    "warning reason number": (_set("warnings", 0, "reason", value=3), None,
                              r"'warnings\[0\]\.reason' must be a JSON string, got 3"),
    "warning a string": (_set("warnings", 0, value="oops"), None,
                         r"'warnings\[0\]' must be a JSON object"),
    "1e999 in the summary": (None, _text('"psnr": 32.0', '"psnr": 1e999', after='"summary"'),
                             r"summary\.psnr is 1e999: out of range"),
    "-1e999 in a frame": (None, _text('"psnr": 32.0', '"psnr": -1e999'),
                          r"frames\[1\]\.psnr is -1e999: out of range"),
    "5000-digit integer": (None, _text('"n_frames": 3', '"n_frames": ' + "9" * 5000),
                           r"inputs\.n_frames is 999999999999\.\.\.\(5000 characters\): out of "
                           "range"),
    "1e308 value": (_set("frames", 0, "psnr", value=1e308), None,
                    r"'frames\[0\]\.psnr' is 1e\+308: out of range"),
    # the document, its settings, then the 500000 arrays:
    "deeply nested": (None, _text('"ssim": {', f'"deep": {DEEP}, "ssim": {{'),
                      r"nested deeper than 64 levels \(500002\)"),
    "n_frames string": (_set("summary", "n_frames", value="3"), None,
                        r"'summary\.n_frames' must be a whole number >= 0, got \"3\""),
    "frame index float": (_set("frames", 1, "index", value=1.5), None,
                          r"'frames\[1\]\.index' must be a whole number >= 0, got 1\.5"),
    "frame camera number": (_set("frames", 1, "camera", value=7), None,
                            r"'frames\[1\]\.camera' must be a JSON string, got 7"),
    "frame without index": (_delete("frames", 1, "index"), None, r"no 'frames\[1\]\.index'"),
    "count boolean": (_set("counts", "psnr", value=True), None,
                      r"'counts\.psnr' must be a whole number >= 0, got true"),
    "timing string": (_set("timing", "psnr", value="0.1"), None,
                      r"'timing\.psnr' must be a number, got \"0\.1\""),
    "negative time": (_set("timing", "total_s", value=-1.0), None,
                      r"'timing\.total_s' must be a number >= 0, got -1\.0"),
    "metric direction": (_set("metrics", "psnr", "higher_is_better", value="yes"), None,
                         r"'metrics\.psnr\.higher_is_better' must be true or false"),
    "metric without unit": (_delete("metrics", "psnr", "unit"), None,
                            r"no 'metrics\.psnr\.unit'"),
    "value of no listed metric": (_set("frames", 0, "sharpness", value=0.5), None,
                                  r"'frames\[0\]\.sharpness' holds a value \(0\.5\) of a metric "
                                  "that 'metrics' does not list"),
    "settings.temporal": (_set("settings", "temporal", value="on"), None,
                          r"'settings\.temporal' must be a JSON object"),
    "skipped frame": (_set("inputs", "skipped_frames", value=[{"camera": "cam0"}]), None,
                      r"no 'inputs\.skipped_frames\[0\]\.frame'"),
    "cameras of strings": (_set("inputs", "cameras", value=["cam0", 1]), None,
                           r"'inputs\.cameras\[1\]' must be a JSON string"),
    "temporal pairs": (_set("inputs", "temporal_pairs", value={"cam0": {"scored": 2}}), None,
                       r"no 'inputs\.temporal_pairs\.cam0\.expected'"),
    "regions source": (_set("regions", "source", value="magic"), None,
                       r"'regions\.source' must be one of detector, motion, boxes, none"),
    "regions boxes count": (_set("regions", "cameras", "cam0", "frames_with_boxes", value="2"),
                            None, r"'regions\.cameras\.cam0\.frames_with_boxes' must be a whole"),
    "lone surrogate": (None, _text('"method": "m"', '"method": "m\\ud800"'),
                       r"method holds a lone UTF-16 surrogate"),
}


def _write(tmp_path, name, doc, text_edit=None):
    text = json.dumps(doc, indent=1)
    if text_edit is not None:
        edited = text_edit(text)
        assert edited != text, "the text edit found nothing to change"
        text = edited
    path = tmp_path / name
    path.write_text(text)
    return path


def _damaged(tmp_path, case):
    edit, text_edit, _ = CASES[case]
    doc = _shard(1, "cam0")
    if edit is not None:
        edit(doc)
    return _write(tmp_path, "r1.json", doc, text_edit)


def _cli(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()) as out:
        code = main(argv)
    return code, err.getvalue(), out.getvalue()


@pytest.mark.parametrize("with_jsonschema", [False, True])
@pytest.mark.parametrize("case", sorted(CASES))
def test_damaged_results_file_is_refused_naming_the_key(tmp_path, monkeypatch, case,
                                                        with_jsonschema):
    if not with_jsonschema:
        monkeypatch.setitem(sys.modules, "jsonschema", None)  # import jsonschema -> ImportError
    path = _damaged(tmp_path, case)
    with pytest.raises(InputError, match=CASES[case][2]) as caught:
        load_results(path)
    assert caught.value.path == str(path)


@pytest.mark.parametrize("case", sorted(CASES))
def test_leaderboard_and_merge_of_a_damaged_file_are_exit_2_naming_it(tmp_path, monkeypatch,
                                                                      case):
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    path = _damaged(tmp_path, case)
    other = _write(tmp_path, "r2.json", _shard(2, "cam1"))
    merged = tmp_path / "merged.json"
    for argv in (["leaderboard", str(path)], ["merge", str(path), str(other), "-o", str(merged)]):
        code, err, out = _cli(argv)
        assert code == 2, (argv[0], err, out)
        assert "Traceback" not in err
        assert f"{path}: " in err, err
        assert len(err.strip().splitlines()) == 1 and re.search(CASES[case][2], err)
    assert not merged.exists()


def test_untouched_shards_still_merge_and_load(tmp_path, monkeypatch):
    """The control of the cases above: the same files, unedited, are read and merged."""
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    paths = [_write(tmp_path, f"r{i}.json", _shard(i, f"cam{i - 1}")) for i in (1, 2)]
    code, err, _ = _cli(["merge", *map(str, paths), "-o", str(tmp_path / "m.json")])
    assert code == 0, err
    merged = load_results(tmp_path / "m.json")
    assert merged["summary"]["n_frames"] == 6 and merged["counts"]["focused_psnr"] == 4
    code, err, out = _cli(["leaderboard", str(paths[0])])
    assert code == 0, err
    assert "31.00" in out


def test_unknown_keys_are_ignored(tmp_path, monkeypatch):
    """A newer writer may add fields (a status beside a null, in a warning, a new section):
    strings, arrays and objects under keys the check does not know are read and merged."""
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    docs = [_shard(i, f"cam{i - 1}") for i in (1, 2)]
    for doc in docs:
        doc["frames"][1]["focused_psnr_status"] = "undefined"
        doc["summary"]["status"] = {"psnr": "ok"}
        doc["warnings"][0]["status"] = "undefined"
        doc["inputs"]["new_field"] = [1, 2]
        doc["provenance"] = {"host": "x"}
    paths = [_write(tmp_path, f"r{i}.json", d) for i, d in enumerate(docs, 1)]
    assert load_results(paths[0])["frames"][1]["focused_psnr_status"] == "undefined"
    code, err, _ = _cli(["merge", *map(str, paths), "-o", str(tmp_path / "m.json")])
    assert code == 0, err


def test_true_is_not_printed_as_a_number(tmp_path, monkeypatch):
    """Before: ``"psnr": true`` in the summary was shown as 1.00 dB in the leaderboard."""
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    doc = _shard(1, "cam0")
    doc["summary"]["psnr"] = True
    code, err, out = _cli(["leaderboard", str(_write(tmp_path, "r.json", doc))])
    assert code == 2 and "1.00" not in out and "'summary.psnr'" in err


def test_1e999_is_not_taken_for_identical_images(tmp_path, monkeypatch):
    """Before: a frame's ``1e999`` was read as +inf and merge reported "identical images"."""
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    paths = [_damaged(tmp_path, "-1e999 in a frame")]
    text = paths[0].read_text().replace("-1e999", "1e999")
    paths[0].write_text(text)
    paths.append(_write(tmp_path, "r2.json", _shard(2, "cam1")))
    code, err, _ = _cli(["merge", *map(str, paths), "-o", str(tmp_path / "m.json")])
    assert code == 2 and "identical images" not in err
    assert "frames[1].psnr is 1e999: out of range" in err


def test_a_metric_this_dynaeval_does_not_know_is_named_by_merge(tmp_path, monkeypatch):
    """A metric listed in ``metrics`` but not in the registry (a plugin absent here, a renamed
    key): merge needs its direction and unit; before, a KeyError traceback."""
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    docs = [_shard(i, f"cam{i - 1}") for i in (1, 2)]
    for doc in docs:
        doc["metrics"]["sharpness"] = {"higher_is_better": True, "unit": ""}
        for row in doc["frames"]:
            row["sharpness"] = 0.5
    paths = [_write(tmp_path, f"r{i}.json", d) for i, d in enumerate(docs, 1)]
    code, err, _ = _cli(["merge", *map(str, paths), "-o", str(tmp_path / "m.json")])
    assert code == 2 and "Traceback" not in err
    assert f"{paths[0]}: metric 'sharpness' (in 'metrics') is not one this dynaeval knows" in err


def test_a_1_mb_deeply_nested_file_is_refused_fast(tmp_path):
    path = _damaged(tmp_path, "deeply nested")
    assert path.stat().st_size > 1_000_000
    start = time.perf_counter()
    with pytest.raises(InputError, match="nested deeper than 64 levels"):
        load_results(path)
    assert time.perf_counter() - start < 2.0  # measured: 0.06 to 0.2 s on a loaded 2-core machine


def test_the_region_sources_are_the_focus_sources():
    from dynaeval.regions.focus import FOCUS_SOURCES
    from dynaeval.report.results_check import REGION_SOURCES

    assert REGION_SOURCES == FOCUS_SOURCES

"""tools/compare_results.py: the before/after check of a refactor, across results schema v1 -> v2."""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "compare_results", Path(__file__).resolve().parents[1] / "tools" / "compare_results.py")
compare = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(compare)

V1 = {"schema": "dynaeval/results/v1", "created": "x", "summary": {"psnr": 30.5, "tlp": None},
      "metrics": {}, "counts": {"psnr": 2},
      "warnings": [{"metric": "tlp", "reason": "tLP disabled"}]}


def _v2(doc: dict) -> dict:
    out = copy.deepcopy(doc)
    out["schema"] = "dynaeval/results/v2"
    out["summary_status"] = {"tlp": "disabled"}
    out["warnings"][0]["status"] = "disabled"
    return out


def _run(tmp_path: Path, before: dict, after: dict) -> int:
    for side, doc in (("b", before), ("a", after)):
        (tmp_path / side).mkdir(exist_ok=True)
        (tmp_path / side / "r.json").write_text(json.dumps(doc))
    return compare.main(tmp_path / "b", tmp_path / "a")


def test_v1_against_v2_allows_only_the_status_fields(tmp_path, capsys):
    assert _run(tmp_path, V1, _v2(V1)) == 0
    assert "schema v1 -> v2: 2 status fields added" in capsys.readouterr().out


def test_a_changed_number_is_still_a_difference_across_versions(tmp_path, capsys):
    after = _v2(V1)
    after["summary"]["psnr"] = 30.500000000000004
    assert _run(tmp_path, V1, after) == 1
    assert "/summary/psnr" in capsys.readouterr().out


def test_a_status_added_between_two_v2_files_is_a_difference(tmp_path):
    before = _v2(V1)
    after = copy.deepcopy(before)
    after["warnings"][0]["detail"] = "x"
    assert _run(tmp_path, before, after) == 1
    del before["summary_status"]
    assert _run(tmp_path, before, _v2(V1)) == 1


def test_only_the_added_temporal_parts_may_be_new(tmp_path, capsys):
    """Issue 41 added ``temporal_parts``: present only after, it is named, not a difference;
    a difference inside it, or another new key, still is one."""
    before = _v2(V1)
    after = copy.deepcopy(before)
    after["temporal_parts"] = {"cam": {"warp_error": {"signed": 0.1, "pred": 0.2, "gt": 0.1}}}
    assert _run(tmp_path, before, after) == 0
    assert "same (added: /temporal_parts)" in capsys.readouterr().out
    after["extra"] = 1
    assert _run(tmp_path, before, after) == 1
    del after["extra"]
    changed = copy.deepcopy(after)
    changed["temporal_parts"]["cam"]["warp_error"]["pred"] = 0.3
    assert _run(tmp_path, after, changed) == 1

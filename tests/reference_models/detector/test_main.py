"""The command line end to end at ``--size tiny``: render, train, export, evaluate."""

import json

import pytest

from reference_models.detector.__main__ import main


@pytest.mark.slow  # ~1-2 min on a shared 2-core machine (30 steps + renders)
def test_tiny_train_export_evaluate(tmp_path):
    run, cache = tmp_path / "run", tmp_path / "cache"
    assert main(["train", "--out", str(run), "--size", "tiny", "--cache", str(cache)]) == 0
    info = json.loads((run / "train.json").read_text())
    assert info["config"]["steps"] == 30 and info["views"] > 0
    assert (run / "detector.onnx").stat().st_size < 3e6
    md = tmp_path / "eval.md"
    assert main(["evaluate", str(run / "detector.onnx"), "--size", "tiny", "--cache", str(cache),
                 "--out", str(md), "--json", str(tmp_path / "eval.json")]) == 0
    text = md.read_text()
    assert "| 64x36 | single-player-closeup | person |" in text
    rows = json.loads((tmp_path / "eval.json").read_text())["rows"]
    assert len(rows) == 6 and {r["class"] for r in rows} == {"person", "ball"}


def test_missing_model_is_exit_2(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path / "nope.onnx"), "--size", "tiny", "--cache", str(tmp_path)]) == 2
    assert "detector model not found" in capsys.readouterr().err

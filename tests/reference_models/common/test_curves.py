"""Curves and tables come from the logs as written."""

import json

import pytest

from dynaeval.errors import InputError
from reference_models.common.curves import main, markdown_table, run_summary, strip


def _run(path, evals):
    path.mkdir()
    recs = [{"step": 10 * (i + 1), "train_seconds": 30.0 * (i + 1), "eval_psnr": v} for i, v in enumerate(evals)]
    (path / "log.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    (path / "results.json").write_text(json.dumps({"summary": {"psnr": 21.5, "masked_psnr": 17.0}}))
    return path


def test_table_and_plot(tmp_path, capsys):
    a = _run(tmp_path / "a", [15.0, 18.0])
    row = run_summary(a)
    assert row["steps"] == 20 and row["train_min"] == pytest.approx(1.0) and row["eval_psnr"] == 18.0
    assert row["it_per_s"] == pytest.approx(20 / 60) and row["score_psnr"] == 21.5
    assert row["score_focused_psnr"] is None and row["ckpt_MB"] is None
    assert main([str(a), "--out", str(tmp_path / "img" / "c.png")]) == 0
    assert (tmp_path / "img" / "c.png").stat().st_size > 1000
    out = capsys.readouterr().out
    assert "| a | 20 | 1.00 | n/a | n/a | 0.33 | 18.00 |" in out  # no CPU time, no config logged
    assert markdown_table([{"x": 1}, {"y": 2.0}]).splitlines()[2:] == ["| 1 | n/a |", "| n/a | 2.00 |"]


def test_baseline_without_log_gets_score_columns(tmp_path):
    base = _run(tmp_path / "b", [])
    (base / "log.jsonl").unlink()
    assert run_summary(base)["score_psnr"] == 21.5 and "steps" not in run_summary(base)


def test_missing_log(tmp_path, capsys):
    with pytest.raises(InputError, match="no log.jsonl"):
        run_summary(tmp_path)
    assert main([str(tmp_path), "--out", str(tmp_path / "c.png")]) == 2
    assert "not a training run" in capsys.readouterr().err


def test_strip_of_one_view(tmp_path):
    import cv2
    import numpy as np

    for path in ("gt/cam/0001.png", "a/pred/cam/0001.png", "b/pred/cam/0001.png"):
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(tmp_path / path), np.zeros((10, 20, 3), np.uint8))
    out = tmp_path / "s.png"
    strip([tmp_path / "a", tmp_path / "b"], tmp_path / "gt", "cam/0001", out)
    assert cv2.imread(str(out)).shape == (10, 60, 3)
    with pytest.raises(InputError, match="no image for cam/0002"):
        strip([tmp_path / "a"], tmp_path / "gt", "cam/0002", out)
    strip([tmp_path / "a", tmp_path / "b"], tmp_path / "gt", "cam/0001", out, crop=(5, 2, 15, 8),
          scale=3)
    assert cv2.imread(str(out)).shape == (18, 90, 3)  # 10 x 6 crops, 3x, three tiles
    with pytest.raises(InputError, match="outside the image"):
        strip([tmp_path / "a"], tmp_path / "gt", "cam/0001", out, crop=(50, 50, 60, 60))

"""The command line: exit codes, messages naming the file, nothing half-written."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from dynaeval.cli import main


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_score_prints_table_and_writes_json(tmp_path, scene, capsys):
    pred, gt = scene
    out_file = tmp_path / "r.json"
    code, out, err = run(capsys, "score", pred, gt, "-o", out_file, "--no-lpips", "-q",
                         "--focus", "motion")
    assert code == 0, err
    assert "psnr ↑ (dB)" in out and "focused" in out and "masked" in out
    doc = json.loads(out_file.read_text())
    assert doc["schema"] == "dynaeval/results/v2" and doc["summary"]["n_frames"] == 8
    assert doc["settings"]["focus"]["source"] == "motion"


def test_existing_output_refused_before_scoring(tmp_path, scene, capsys):
    pred, gt = scene
    out_file = tmp_path / "r.json"
    out_file.write_text("keep me")
    code, _, err = run(capsys, "score", pred, gt, "-o", out_file, "--no-lpips", "-q")
    assert code == 2 and "r.json: results file exists; pass --overwrite" in err
    assert out_file.read_text() == "keep me"


def test_missing_folder_exit_2(tmp_path, capsys):
    code, _, err = run(capsys, "score", tmp_path / "nope", tmp_path, "--no-lpips")
    assert code == 2
    assert "nope: prediction folder not found" in err and "Traceback" not in err


def test_corrupt_frame_exit_2_and_no_results_file(tmp_path, scene, capsys):
    pred, gt = scene
    (pred / "cam01" / "0002.png").write_bytes(b"\x89PNG broken")
    out_file = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "-o", out_file, "--no-lpips", "-q",
                       "--focus", "none")
    assert code == 2 and "0002.png: cannot decode image" in err
    assert not out_file.exists() and list(tmp_path.glob(".r.json*")) == []


def test_missing_frames_and_allow_missing(tmp_path, scene, capsys):
    pred, gt = scene
    (pred / "cam00" / "0001.png").unlink()
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", "none")
    assert code == 2 and "ground-truth frames with no prediction: 0001" in err
    out_file = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", "none",
                       "--allow-missing", "-o", out_file)
    assert code == 0, err
    doc = json.loads(out_file.read_text())
    assert doc["inputs"]["skipped_frames"] == [{"camera": "cam00", "frame": "0001"}]
    # 4 frames, 0001 missing: the pair (0002, 0003) is still scored (issue 32 item 6)
    rows = {r["frame"]: r for r in doc["frames"] if r["camera"] == "cam00"}
    assert rows["0002"]["warp_error"] is None and rows["0003"]["warp_error"] is not None
    assert doc["cameras"]["cam00"]["warp_error"] == rows["0003"]["warp_error"]
    assert doc["inputs"]["temporal_pairs"] == {"cam00": {"scored": 1, "expected": 3}}
    assert "camera cam00: 0001; temporal pairs 1 of 3" in err
    assert doc["cameras"]["cam01"]["warp_error"] is not None


def test_nan_prediction_exit_2(tmp_path, scene, capsys):
    OpenEXR = pytest.importorskip("OpenEXR")
    pred, gt = scene
    img = np.zeros((48, 64, 3), np.float32)
    img[3, 4, 1] = np.inf
    (pred / "cam00" / "0003.png").unlink()
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(hdr, {"RGB": img}) as f:
        f.write(str(pred / "cam00" / "0003.exr"))
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", "none")
    assert code == 2 and "0003.exr: 1 pixel values are NaN or Inf" in err


def test_bad_focus_and_missing_detector(tmp_path, scene, capsys):
    pred, gt = scene
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "--focus", "boxes")
    assert code == 2 and "--focus must be detector, motion, none or boxes:FILE" in err
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "--focus", "detector",
                       "--detector", tmp_path / "none.onnx")
    assert code == 2 and "none.onnx: detector model not found" in err
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "--focus", f"boxes:{tmp_path}/x.json")
    assert code == 2 and "x.json" in err


def test_cache_mb_is_passed_and_checked(tmp_path, scene, capsys):
    pred, gt = scene
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--cache-mb", "-1")
    assert code == 2 and "cache_mb must be an integer >= 0" in err
    out = tmp_path / "r.json"
    code, _, _ = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--cache-mb", "0", "-o", out)
    assert code == 0 and out.is_file()


def test_usage_error_exit_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["score"])
    assert exc.value.code == 2


def test_unscored_cameras_reported(tmp_path, scene, capsys):
    pred, gt = scene
    import shutil

    shutil.rmtree(pred / "cam01")
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", "none")
    assert code == 0 and "1 ground-truth camera(s) without predictions not scored: cam01" in err


def test_demo_runs_on_bundled_sample(tmp_path, capsys):
    out_file = tmp_path / "demo.json"
    code, out, err = run(capsys, "demo", "-o", out_file, "-q", "--no-lpips")
    assert code == 0, err
    doc = json.loads(out_file.read_text())
    assert doc["summary"]["n_frames"] > 0 and doc["summary"]["focused_psnr"] is not None


def test_console_script_entry_point_runs():
    proc = subprocess.run([sys.executable, "-m", "dynaeval", "--version"], capture_output=True,
                          text=True, check=False)
    assert proc.returncode == 0 and proc.stdout.startswith("dynaeval ")


def test_detect_motion_boxes_then_score_with_them(tmp_path, scene, capsys):
    pred, gt = scene
    boxes = tmp_path / "boxes.json"
    code, out, err = run(capsys, "detect", gt, "-o", boxes, "--source", "motion", "-q")
    assert code == 0, err
    doc = json.loads(boxes.read_text())
    assert doc["source"]["kind"] == "motion" and len(doc["boxes"]) == 8
    # the moving square (rows 20..30) is inside a motion box on every frame
    for key, records in doc["boxes"].items():
        assert any(r["box"][1] <= 20 and r["box"][3] >= 30 for r in records), key
    code, _, err = run(capsys, "detect", gt, "-o", boxes, "--source", "motion", "-q")
    assert code == 2 and "boxes file exists" in err
    out_file = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus",
                       f"boxes:{boxes}", "-o", out_file)
    assert code == 0, err
    res = json.loads(out_file.read_text())
    assert res["settings"]["focus"]["boxes_file"]["sha256"]
    assert res["counts"]["focused_psnr"] == 8

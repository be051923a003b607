"""The command line with given masks: DyCheck's and NeRFBaselines' layouts read as they are
(exit 0), bad masks refused before scoring with the file and the problem (exit 2)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from dynaeval.cli import main
from tests.dynaeval.mask_layouts import dycheck_dataset, nerfbaselines_folder

pytest.importorskip("skimage")
FAST = ("--no-lpips", "--focus", "none", "--no-temporal", "-q")


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _mpsnr(pred_file, gt_file, mask_file):
    """Independent: DyCheck's to_quantized_float32 of the float render, cv2.imread of the 8-bit
    ground truth and mask, masked_mean of the squared error, float64."""
    p = cv2.imread(str(pred_file), cv2.IMREAD_UNCHANGED)[..., ::-1].astype(np.float64) / 65535
    p = (p * 255).clip(0, 255).astype(np.uint8) / 255.0
    g = cv2.imread(str(gt_file))[..., ::-1] / 255.0
    m = np.broadcast_to(cv2.imread(str(mask_file))[..., :1] / 255.0, g.shape)
    return -10 * np.log10(((p - g) ** 2 * m).sum() / max(m.sum(), 1e-6))


def test_dycheck_layout_scores_with_covisible_masks(tmp_path, capsys):
    pred, gt = dycheck_dataset(tmp_path)
    out = tmp_path / "r.json"
    code, table, err = run(capsys, "score", pred, gt, "--protocol", "dycheck", "-o", out, *FAST)
    assert code == 0, err
    doc = json.loads(out.read_text())
    cov = gt.parent.parent / "covisible" / "2x" / "val"
    for row in doc["frames"]:
        name = f"{row['frame']}.png"
        assert row["mpsnr"] == pytest.approx(_mpsnr(pred / name, gt / name, cov / name), abs=1e-6)
        assert row["masked_psnr"] == pytest.approx(row["mpsnr"], abs=1e-6)  # binary mask: equal
        assert row["mssim"] > row["masked_ssim"]  # DyCheck counts unmasked windows as 1
    s = doc["settings"]
    assert s["protocol"]["name"] == "dycheck" and s["masks"]["origin"] == "dycheck"
    assert "covisible" in s["regions"] and s["quantize"] == "truncate"
    assert doc["metrics"]["mssim"]["higher_is_better"] is True
    assert "mpsnr" in doc["summary"]


def test_dycheck_split_is_paired_and_a_missing_val_frame_is_an_error(tmp_path, capsys):
    pred, gt = dycheck_dataset(tmp_path)
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "-o", out, *FAST)  # train frames: not skipped
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert doc["summary"]["n_frames"] == 3 and not doc["inputs"]["skipped_frames"]
    (pred / "1_00001.png").unlink()
    out.unlink()
    code, _, err = run(capsys, "score", pred, gt, "-o", out, *FAST)
    assert code == 2 and "DyCheck split 'val'" in err and "1_00001" in err
    code, _, err = run(capsys, "score", pred, gt, "--allow-missing", "-o", out, *FAST)
    assert code == 0, err
    skipped = json.loads(out.read_text())["inputs"]["skipped_frames"]
    assert skipped == [{"camera": ".", "frame": "1_00001"}]


def test_dycheck_protocol_without_masks_warns(tmp_path, capsys):
    pred, gt = dycheck_dataset(tmp_path)
    plain = tmp_path / "plain_gt"
    plain.mkdir()
    for f in gt.glob("1_*.png"):
        (plain / f.name).write_bytes(f.read_bytes())
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, plain, "--protocol", "dycheck", "-o", out, *FAST)
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert "mpsnr" not in doc["summary"]
    assert any("no covisibility masks found" in w["reason"] for w in doc["warnings"])


@pytest.mark.parametrize("problem", ["size", "missing"])
def test_bad_mask_exit_2_naming_the_file(tmp_path, capsys, problem):
    pred, gt = dycheck_dataset(tmp_path)
    bad = gt.parent.parent / "covisible" / "2x" / "val" / "1_00001.png"
    if problem == "size":
        cv2.imwrite(str(bad), np.zeros((50, 60), np.uint8))
    masks = bad.parent
    if problem == "missing":
        bad.unlink()
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "--masks", masks, "-o", out, *FAST)
    assert code == 2 and not out.exists()
    assert "1_00001.png" in err
    assert ("mask is 60x50 px but its frame" in err if problem == "size" else "no mask for ground-truth frame" in err)
    assert "Traceback" not in err


def test_nerfbaselines_render_folder_with_mask(tmp_path, capsys):
    run_dir = nerfbaselines_folder(tmp_path / "run")
    out_nb, out_de = tmp_path / "nb.json", tmp_path / "de.json"
    code, _, err = run(capsys, "score", run_dir, "--protocol", "nerfbaselines", "-o", out_nb, *FAST)
    assert code == 0, err
    code, _, err = run(capsys, "score", run_dir, "-o", out_de, *FAST)
    assert code == 0, err
    nb, de = json.loads(out_nb.read_text()), json.loads(out_de.read_text())
    assert nb["summary"]["psnr"] > de["summary"]["psnr"] + 1.0  # zeros outside the mask count
    assert abs(nb["summary"]["masked_psnr"] - de["summary"]["masked_psnr"]) < 0.05  # 8-bit step


def test_masks_flag_with_a_plain_folder_and_unused_warning(tmp_path, capsys):
    run_dir = nerfbaselines_folder(tmp_path / "run")
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", run_dir / "color", run_dir / "gt-color", "-o", out, *FAST)
    assert code == 0 and "mask" in err and "is not used" in err  # printed on the console too
    out2 = tmp_path / "r2.json"
    code, _, err = run(capsys, "score", run_dir / "color", run_dir / "gt-color", "--masks",
                       run_dir / "mask", "-o", out2, *FAST)
    assert code == 0, err
    doc = json.loads(out2.read_text())
    assert doc["settings"]["masks"]["origin"] == "given" and doc["summary"]["masked_psnr"] is not None
    assert not any("is not used" in w["reason"] for w in doc["warnings"])


def test_nerfbaselines_refuses_a_16_bit_mask_before_scoring(tmp_path, capsys):
    run_dir = nerfbaselines_folder(tmp_path / "run")
    bad = run_dir / "mask" / "00002.png"
    m = cv2.imread(str(bad), cv2.IMREAD_UNCHANGED)
    cv2.imwrite(str(bad), m.astype(np.uint16) * 257)
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", run_dir, "--protocol", "nerfbaselines", "-o", out, *FAST)
    assert code == 2 and not out.exists()
    assert "00002.png" in err and "16-bit mask" in err
    code, _, err = run(capsys, "score", run_dir, "-o", out, *FAST)  # dynaeval reads it: v / 65535
    assert code == 0, err


def test_given_masks_are_the_regions_a_report_sees(tmp_path):
    """The regions passed to ``on_regions`` (what the HTML report outlines, and the temporal
    static region) hold the given masks, not the motion masks."""
    import dynaeval
    from dynaeval.regions.focus import FocusConfig

    pred, gt = dycheck_dataset(tmp_path)
    seen = {}
    dynaeval.score(pred, gt, metrics=("psnr",), temporal=False, progress=False,
                   focus=FocusConfig("none"),
                   on_regions=lambda cam, pairs, regs: seen.update(
                       {p.frame: r.mask for p, r in zip(pairs, regs, strict=True)}))
    cov = gt.parent.parent / "covisible" / "2x" / "val"
    for frame, mask in seen.items():
        assert np.array_equal(mask, cv2.imread(str(cov / f"{frame}.png"), 0) > 127)

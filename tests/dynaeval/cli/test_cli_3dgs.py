"""``dynaeval score MODEL`` on a 3DGS-family render folder, and ``--3dgs-json``."""

from __future__ import annotations

import json

import pytest

from dynaeval.cli import main

from ..io.test_layout_3dgs import _iteration


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


FAST = ("--no-lpips", "-q", "--focus", "none", "--no-masked", "--no-presence", "--no-temporal")


@pytest.fixture
def model(tmp_path):
    m = tmp_path / "bicycle"
    for n in (7000, 30000):
        _iteration(m, "test", n)
    return m


def test_score_model_exits_0_and_names_the_iteration(model, capsys):
    code, out, err = run(capsys, "score", model, "--protocol", "3dgs", *FAST)
    assert code == 0, err
    assert "3dgs render folder: scored" in err and "ours_30000" in err
    assert "also rendered: ours_7000" in err
    assert "the numbers of its own metrics.py are --protocol 3dgs" not in err
    code, _, err = run(capsys, "score", model, "--iteration", "7000", *FAST)
    assert code == 0, err
    assert "the numbers of its own metrics.py are --protocol 3dgs" in err


def test_bad_model_exits_2_with_a_clear_message(model, tmp_path, capsys):
    code, _, err = run(capsys, "score", model, "--iteration", "123", *FAST)
    assert code == 2 and "no iteration 123 rendered" in err and "7000, 30000" in err
    broken = tmp_path / "broken"
    (broken / "test" / "ours_1" / "renders").mkdir(parents=True)  # render.py stopped before gt/
    code, _, err = run(capsys, "score", broken, *FAST)
    assert code == 2 and "ours_1 has renders/ but no gt/" in err
    (tmp_path / "empty").mkdir()
    code, _, err = run(capsys, "score", tmp_path / "empty", *FAST)
    assert code == 2 and "holds no known render layout" in err and "3dgs: MODEL" in err
    assert "Traceback" not in err


def test_3dgs_json_shape_and_no_clobber(model, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    code, _, err = run(capsys, "score", model, "--protocol", "3dgs", "--3dgs-json", out,
                       "-o", tmp_path / "r.json", *FAST)
    assert code == 0, err
    results = json.loads((out / "results.json").read_text())
    per_view = json.loads((out / "per_view.json").read_text())
    doc = json.loads((tmp_path / "r.json").read_text())
    assert list(results) == ["ours_30000"] and list(results["ours_30000"]) == ["SSIM", "PSNR"]
    assert results["ours_30000"]["PSNR"] == pytest.approx(doc["summary"]["psnr"])
    assert list(per_view["ours_30000"]["PSNR"]) == ["00000.png", "00001.png", "00002.png"]
    assert per_view["ours_30000"]["SSIM"]["00001.png"] == pytest.approx(doc["frames"][1]["ssim"])
    before = (out / "results.json").read_text()
    code, _, err = run(capsys, "score", model, "--3dgs-json", out, *FAST)
    assert code == 2 and "3DGS results file exists" in err
    assert (out / "results.json").read_text() == before
    code, _, err = run(capsys, "score", model, "--3dgs-json", out, "--overwrite", *FAST)
    assert code == 0 and "not the 3DGS family's own" in err


@pytest.fixture
def model_4dgs(tmp_path):
    """A 4DGaussians MODEL (``test/ours_14000`` + the ``video_rgb.mp4`` its render.py leaves) of
    two 170 x 176 frames: large enough for pytorch_msssim's MS-SSIM (161 px)."""
    import cv2
    import numpy as np

    ours = tmp_path / "coffee_martini" / "test" / "ours_14000"
    rng = np.random.default_rng(5)
    for sub in ("renders", "gt"):
        (ours / sub).mkdir(parents=True)
    base = cv2.GaussianBlur(rng.integers(0, 255, (170, 176, 3), dtype=np.uint8), (7, 7), 2)
    for i in range(2):
        gt = np.roll(base, 3 * i, axis=1)
        noisy = np.clip(gt + rng.normal(0, 6, gt.shape), 0, 255).astype(np.uint8)
        cv2.imwrite(str(ours / "gt" / f"{i:05d}.png"), gt)
        cv2.imwrite(str(ours / "renders" / f"{i:05d}.png"), noisy)
    (ours / "video_rgb.mp4").write_bytes(b"")
    return ours.parent.parent


def test_4dgaussians_model_names_its_protocol_and_keeps_the_asked_one(model_4dgs, tmp_path, capsys):
    """The protocol is never picked from the folder (numbers must not change with the files
    beside the renders): the run says which one matches 4DGaussians' metrics.py."""
    code, _, err = run(capsys, "score", model_4dgs, "-o", tmp_path / "r.json", *FAST)
    assert code == 0, err
    assert "4DGaussians render folder scored under --protocol dynaeval" in err
    assert "own metrics.py are --protocol 4dgaussians" in err
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["settings"]["protocol"]["name"] == "dynaeval" and "msssim" not in doc["summary"]
    code, _, err = run(capsys, "score", model_4dgs, "--protocol", "3dgs", *FAST)
    assert code == 0 and "own metrics.py are --protocol 4dgaussians" in err
    code, _, err = run(capsys, "score", model_4dgs, "--protocol", "4dgaussians", *FAST)
    assert code == 0 and "own metrics.py" not in err


def test_4dgaussians_json_has_its_keys(model_4dgs, tmp_path, capsys, random_lpips):
    """``--protocol 4dgaussians --3dgs-json``: 4DGaussians' keys, LPIPS named by the backbone
    (``--lpips-net alex`` is allowed, as its metrics.py reports LPIPS-alex)."""
    pm = pytest.importorskip("pytorch_msssim")
    import torch

    from dynaeval.io.images import read_image

    out = tmp_path / "out"
    out.mkdir()
    fast = [a for a in FAST if a != "--no-lpips"]
    code, _, err = run(capsys, "score", model_4dgs, "--protocol", "4dgaussians", "--lpips-net",
                       "alex", "--3dgs-json", out, "-o", tmp_path / "r.json", *fast)
    assert code == 0, err
    assert "not the 3DGS family's own" not in err
    results = json.loads((out / "results.json").read_text())["ours_14000"]
    assert list(results) == ["SSIM", "PSNR", "LPIPS-alex", "MS-SSIM", "D-SSIM"]
    per_view = json.loads((out / "per_view.json").read_text())["ours_14000"]
    ours = model_4dgs / "test" / "ours_14000"
    p, g = (read_image(ours / d / "00001.png") for d in ("renders", "gt"))
    t = lambda a: torch.from_numpy(a.transpose(2, 0, 1).copy())[None].float()  # noqa: E731
    ref = float(pm.ms_ssim(t(p), t(g), data_range=1, size_average=True))
    assert per_view["MS-SSIM"]["00001.png"] == pytest.approx(ref, abs=2e-6)
    assert per_view["D-SSIM"]["00001.png"] == pytest.approx((1 - ref) / 2, abs=1e-6)
    doc = json.loads((tmp_path / "r.json").read_text())
    assert results["LPIPS-alex"] == pytest.approx(doc["summary"]["lpips"])
    assert doc["settings"]["lpips"]["net"] == "alex"
    code, _, err = run(capsys, "score", model_4dgs, "--protocol", "3dgs", "--lpips-net", "alex",
                       *fast)
    assert code == 2 and "reports LPIPS with the vgg backbone, not alex" in err


def test_3dgs_json_refused_by_the_results_leaves_no_results_file(tmp_path, capsys):
    """The sample's two cameras share image names, which per_view.json cannot hold: exit 2
    before anything is written (the -o file was written first, then the 3DGS files refused)."""
    from dynaeval.cli import main, sample_dir

    root, out = sample_dir(), tmp_path / "r.json"
    code = main(["score", str(root / "pred"), str(root / "gt"), "--metrics", "psnr",
                 "--focus", "none", "--no-temporal", "--no-presence", "-q", "-o", str(out),
                 "--3dgs-json", str(tmp_path / "gs")])
    assert code == 2 and "share a name" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "gs").exists()

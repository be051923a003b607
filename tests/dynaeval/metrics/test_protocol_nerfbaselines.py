"""``--protocol nerfbaselines`` with a render folder's ``mask/`` and 16-bit renders: equal to a
float64/float32 re-implementation of NeRFBaselines 1.2.12's evaluation (Pillow decoding, uint8
step, ``pred * mask``, ``gt * mask``, whole-frame metrics), and to NeRFBaselines itself when an
interpreter with it is given (``DYNAEVAL_NERFBASELINES_PYTHON``: its install pulls numpy 1.26
and opencv-python, so it lives in its own venv)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import dynaeval
from dynaeval.errors import InputError
from dynaeval.metrics.protocol_nerfbaselines import multiply_mask
from dynaeval.metrics.protocols import get_protocol
from dynaeval.regions.focus import FocusConfig
from tests.dynaeval.mask_layouts import nerfbaselines_folder

pytest.importorskip("skimage")
Image = pytest.importorskip("PIL.Image")
ROOT = Path(__file__).resolve().parents[3]
KW = dict(metrics=("psnr", "ssim"), temporal=False, progress=False, focus=FocusConfig("none"))


def _nb_inputs(folder: Path, i: int):
    """What NeRFBaselines' evaluate() scores for frame i: Pillow arrays, uint8 -> float32 / 255,
    the mask (Pillow, / 255) multiplied into both."""
    name = f"{i:05d}.png"
    pred = np.array(Image.open(folder / "color" / name)).astype(np.float32) / 255.0
    gt = np.array(Image.open(folder / "gt-color" / name)).astype(np.float32) / 255.0
    mask = (np.array(Image.open(folder / "mask" / name)).astype(np.float32) / 255.0)[..., None]
    return pred * mask, gt * mask, pred, gt, mask[..., 0]


@pytest.fixture
def nb_folder(tmp_path):
    return nerfbaselines_folder(tmp_path / "run")


def test_masked_psnr_equals_nerfbaselines_reimplementation(nb_folder):
    res = dynaeval.score(nb_folder, protocol="nerfbaselines", **KW)
    for i, row in enumerate(res["frames"]):
        pm, gm, pred, gt, m = _nb_inputs(nb_folder, i)
        ref = -10 * np.log10(np.mean((np.clip(pm, 0, 1) - np.clip(gm, 0, 1)) ** 2, dtype=np.float32))
        assert row["psnr"] == pytest.approx(float(ref), abs=1e-4)
        # dynaeval's masked_psnr divides by the mask's pixels: lower, and what dynaeval reports
        err = (pred.astype(np.float64) - gt) ** 2
        assert row["masked_psnr"] == pytest.approx(-10 * np.log10(err[m > 0.5].mean()), abs=1e-4)
        assert row["psnr"] > row["masked_psnr"] + 1.0
    s = res["settings"]
    assert s["protocol"]["masks"] == "multiply" and s["protocol"]["decode"] == "pil"
    assert s["masks"]["origin"] == "nerfbaselines" and s["masks"]["folder"].endswith("mask")


def test_multiply_mask_and_protocol():
    rng = np.random.default_rng(0)
    a, b = rng.random((20, 23, 3)), rng.random((20, 23, 3))
    w = (rng.random((20, 23)) > 0.3).astype(np.float32)
    pa, pb = multiply_mask(a, b, w)
    assert pa.dtype == np.float32 and np.all(pa[w == 0] == 0) and np.all(pb[w == 0] == 0)
    proto = get_protocol("nerfbaselines")
    assert proto.whole_psnr(a, b, weights=w) == pytest.approx(proto.whole_psnr(pa, pb), abs=1e-9)
    assert proto.whole_ssim(a, b, weights=w) == pytest.approx(proto.whole_ssim(pa, pb), abs=1e-12)
    with pytest.raises(InputError, match="mask must have the image's size"):
        multiply_mask(a, b, w[:5])
    with pytest.raises(InputError, match="does not score the whole frame with a mask"):
        get_protocol("dynaeval").whole_psnr(a, b, weights=w)


def test_dynaeval_protocol_uses_the_mask_as_masked_region_only(nb_folder):
    res = dynaeval.score(nb_folder, **KW)
    plain = dynaeval.score(nb_folder / "color", nb_folder / "gt-color", **KW)  # mask/ unused
    for a, b in zip(res["frames"], plain["frames"], strict=True):
        assert a["psnr"] == b["psnr"]  # the whole frame is the whole frame
    assert "masks" in res["settings"] and "masks" not in plain["settings"]
    assert any("mask folder" in w["reason"] and "not used" in w["reason"] for w in plain["warnings"])


NB_PY = os.environ.get("DYNAEVAL_NERFBASELINES_PYTHON")


@pytest.mark.skipif(not NB_PY, reason="set DYNAEVAL_NERFBASELINES_PYTHON to an interpreter with "
                    "nerfbaselines==1.2.12 to compare with it")
def test_equals_nerfbaselines_itself(nb_folder, tmp_path):
    (nb_folder / "info.json").write_text(json.dumps({
        "evaluation_protocol": "default", "render_dataset_metadata": {"color_space": "srgb"}}))
    out = tmp_path / "nb.json"
    subprocess.run([NB_PY, str(ROOT / "tools/protocol_sources/nerfbaselines_eval.py"),
                    str(nb_folder), str(out)], check=True, capture_output=True)
    ref = json.loads(out.read_text())["per_image"]
    res = dynaeval.score(nb_folder, protocol="nerfbaselines", **KW)
    for row, r in zip(res["frames"], ref, strict=True):
        assert row["psnr"] == pytest.approx(r["psnr"], abs=1e-4)
        assert row["ssim"] == pytest.approx(r["ssim"], abs=1e-6)


def test_metrics_nerfbaselines_lacks_are_not_masked(nb_folder):
    """FLIP is not a NeRFBaselines metric: its whole-frame value ignores the mask (only the
    metrics with the protocol's masked variants get the mask's weights)."""
    pytest.importorskip("flip_evaluator")
    from dynaeval.metrics.flip import flip

    res = dynaeval.score(nb_folder, protocol="nerfbaselines", **{**KW, "metrics": ("psnr", "flip")})
    for i, row in enumerate(res["frames"]):
        _, _, pred, gt, _ = _nb_inputs(nb_folder, i)
        assert row["flip"] == pytest.approx(flip(pred, gt), abs=1e-6)

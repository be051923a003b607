"""Protocols: each evaluator's whole-frame PSNR/SSIM and 8-bit step against independent values."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scipy.signal import convolve2d

import dynaeval
from dynaeval.errors import InputError
from dynaeval.metrics import psnr, ssim
from dynaeval.metrics.protocols import (
    get_protocol,
    psnr_float32,
    resolve_quantize,
    ssim_variant,
)
from dynaeval.regions.focus import FocusConfig


def _pair(rng, h=40, w=48):
    gt = cv2.resize(rng.uniform(0, 1, (h // 4, w // 4, 3)).astype(np.float32), (w, h))
    pred = np.clip(gt + rng.normal(0, 0.05, gt.shape), 0, 1).astype(np.float32)
    return pred, np.clip(gt, 0, 1)


def _dmpix_reference(a: np.ndarray, b: np.ndarray) -> float:
    """dm_pix's SSIM written out in float64 from its definition (Gaussian 11/1.5, 'valid'
    convolution, variances clamped at eps_f32^2, covariance at +-sqrt(var_a var_b))."""
    x = np.arange(11) - 5
    f = np.exp(-0.5 * (x / 1.5) ** 2)
    f /= f.sum()
    k2 = np.outer(f, f)
    vals = []
    for c in range(a.shape[2]):
        x_, y_ = a[..., c].astype(np.float64), b[..., c].astype(np.float64)
        conv = lambda z: convolve2d(z, k2, mode="valid")  # noqa: E731
        m0, m1 = conv(x_), conv(y_)
        s00 = np.maximum(np.finfo(np.float32).eps ** 2, conv(x_ * x_) - m0 * m0)
        s11 = np.maximum(np.finfo(np.float32).eps ** 2, conv(y_ * y_) - m1 * m1)
        s01 = conv(x_ * y_) - m0 * m1
        s01 = np.sign(s01) * np.minimum(np.sqrt(s00 * s11), np.abs(s01))
        c1, c2 = 0.01**2, 0.03**2
        vals.append(((2 * m0 * m1 + c1) * (2 * s01 + c2)) / ((m0**2 + m1**2 + c1) * (s00 + s11 + c2)))
    return float(np.mean(vals))


def test_nerfstudio_matches_torchmetrics(rng):
    torch = pytest.importorskip("torch")
    tm = pytest.importorskip("torchmetrics.functional.image")
    proto = get_protocol("nerfstudio")
    for _ in range(3):
        pred, gt = _pair(rng)
        tp = torch.from_numpy(pred).permute(2, 0, 1)[None]
        tg = torch.from_numpy(gt).permute(2, 0, 1)[None]
        # as nerfacto calls it: no data_range (the images' own range)
        ref_ssim = float(tm.structural_similarity_index_measure(tp, tg))
        ref_psnr = float(tm.peak_signal_noise_ratio(tp, tg, data_range=1.0))
        assert proto.whole_ssim(pred, gt) == pytest.approx(ref_ssim, abs=2e-6)
        assert proto.whole_psnr(pred, gt) == pytest.approx(ref_psnr, abs=1e-4)


def test_nerfbaselines_ssim_matches_dmpix_definition(rng):
    proto = get_protocol("nerfbaselines")
    for _ in range(3):
        pred, gt = _pair(rng)
        assert proto.whole_ssim(pred, gt) == pytest.approx(_dmpix_reference(pred, gt), abs=1e-9)
    # constant patches: the clamp is what keeps the statistics valid; still equal to the reference
    flat = np.full((24, 24, 3), 0.5, np.float32)
    assert proto.whole_ssim(flat, flat) == pytest.approx(_dmpix_reference(flat, flat), abs=1e-9)


def test_nerfbaselines_psnr_is_float32_mse_of_clipped_images(rng):
    pred, gt = _pair(rng)
    pred[0, 0] = 1.3  # outside [0, 1]: clipped by NeRFBaselines before the metric
    p32, g32 = np.clip(pred, 0, 1).astype(np.float32), gt.astype(np.float32)
    mse = np.float32(np.mean((p32 - g32) ** 2, dtype=np.float32))
    assert psnr_float32(pred, gt, clip=True) == pytest.approx(float(-10 * np.log10(mse)), abs=1e-5)
    assert psnr_float32(gt, gt) == math.inf


def test_valid_border_unclamped_is_dynaeval_ssim_and_reflect_border_differs(rng):
    pred, gt = _pair(rng)
    p64, g64 = pred.astype(np.float64), gt.astype(np.float64)
    # dynaeval's fast path filters float32 (held to its float64 reference by its own tests)
    assert ssim_variant(p64, g64, precision="float64") == pytest.approx(ssim(p64, g64), abs=1e-6)
    assert ssim_variant(pred, gt) == pytest.approx(ssim(pred, gt), abs=1e-5)
    # the reflected border windows are what separates nerfstudio's SSIM from the others
    assert abs(ssim_variant(pred, gt, border="reflect") - ssim(pred, gt)) > 1e-3
    assert psnr_float32(pred, gt) == pytest.approx(psnr(pred, gt), abs=1e-3)


def _write16(path, img):
    cv2.imwrite(str(path), np.round(img[..., ::-1] * 65535).astype(np.uint16))


@pytest.fixture
def scene16(tmp_path, rng):
    """One camera of 16-bit PNGs: the 8-bit truncation of NeRFBaselines then changes numbers."""
    (tmp_path / "gt" / "c").mkdir(parents=True)
    (tmp_path / "pred" / "c").mkdir(parents=True)
    pairs = []
    for i in range(2):
        pred, gt = _pair(rng)
        _write16(tmp_path / "gt" / "c" / f"{i}.png", gt)
        _write16(tmp_path / "pred" / "c" / f"{i}.png", pred)
        pairs.append((np.round(pred * 65535) / 65535, np.round(gt * 65535) / 65535))
    return tmp_path, pairs


def test_score_with_nerfbaselines_protocol_truncates_to_8_bit(scene16):
    root, pairs = scene16
    kw = dict(metrics=("psnr", "ssim"), temporal=False, progress=False, focus=FocusConfig("none"))
    res = dynaeval.score(root / "pred", root / "gt", protocol="nerfbaselines", **kw)
    from PIL import Image

    expected = []
    for i in range(len(pairs)):  # independent: NeRFBaselines reads with Pillow (16-bit RGB ->
        # its high byte), image_to_srgb keeps the uint8, then /255 and a float32 MSE
        p8, g8 = (np.array(Image.open(root / d / "c" / f"{i}.png")).astype(np.float32) / 255.0
                  for d in ("pred", "gt"))
        expected.append(-10 * np.log10(np.mean((p8 - g8) ** 2, dtype=np.float32)))
    assert res["summary"]["psnr"] == pytest.approx(float(np.mean(expected)), abs=1e-4)
    assert res["settings"]["protocol"]["name"] == "nerfbaselines"
    assert res["settings"]["quantize"] == "truncate"
    assert res["settings"]["protocol"]["decode"] == "pil"
    plain = dynaeval.score(root / "pred", root / "gt", **kw)
    assert abs(plain["summary"]["psnr"] - res["summary"]["psnr"]) > 1e-3  # the step matters
    assert plain["settings"]["protocol"]["name"] == "dynaeval"


def test_protocol_errors():
    with pytest.raises(InputError, match="protocol must be one of dynaeval, nerfbaselines"):
        get_protocol("colmap")
    with pytest.raises(InputError, match="protocol nerfbaselines uses quantize=truncate, not round"):
        resolve_quantize(get_protocol("nerfbaselines"), "round")
    assert resolve_quantize(get_protocol("nerfbaselines"), "none") == "truncate"
    assert resolve_quantize(get_protocol("dynaeval"), "round") == "round"
    with pytest.raises(InputError, match="reports LPIPS with the alex backbone, not vgg"):
        dynaeval.score(".", ".", protocol="nerfstudio", lpips_net="vgg")
    with pytest.raises(InputError, match="precision must be one of float32, float64"):
        ssim_variant(np.zeros((12, 12)), np.zeros((12, 12)), precision="float16")
    with pytest.raises(InputError, match="border must be one of valid, reflect, zero"):
        ssim_variant(np.zeros((12, 12)), np.zeros((12, 12)), border="mirror")
    with pytest.raises(InputError, match="clamp must be one of none, zero, dm_pix"):
        ssim_variant(np.zeros((12, 12)), np.zeros((12, 12)), clamp="yes")
    with pytest.raises(InputError, match="protocol nerfbaselines clips images to \\[0, 1\\], so it needs data_range=1"):
        get_protocol("nerfbaselines").whole_ssim(np.zeros((12, 12)), np.zeros((12, 12)), data_range=255.0)
    with pytest.raises(InputError, match="SSIM needs images of at least 11x11"):
        ssim_variant(np.zeros((8, 8)), np.zeros((8, 8)))

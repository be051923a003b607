"""DyCheck's mPSNR / mSSIM / mLPIPS against a float64 re-implementation of its jax code, on
scikit-image photos at odd sizes with a covisibility-like mask; and against DyCheck's own jax
functions when an interpreter with jax is given (``DYNAEVAL_JAX_PYTHON`` + ``DYCHECK_SRC``).

The re-implementation follows ``dycheck/core/metrics/image.py`` line by line with
``scipy.signal.convolve2d(mode="valid")`` (what ``jax.scipy.signal.convolve2d`` computes), not
dynaeval's OpenCV filtering; ``masked_mean`` as in ``dycheck/nn/functional/common.py``.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import convolve2d

from dynaeval.errors import InputError
from dynaeval.metrics import psnr
from dynaeval.metrics.protocol_dycheck import (
    dycheck_lpips,
    dycheck_psnr,
    dycheck_ssim,
    masked_mean,
)
from dynaeval.metrics.protocols import get_protocol

skdata = pytest.importorskip("skimage.data")
ROOT = Path(__file__).resolve().parents[3]


def _ref_masked_mean(x, mask):
    if mask is None:
        return x.mean()
    mask = np.broadcast_to(mask, x.shape)
    return (x * mask).sum() / np.clip(mask.sum(), 1e-6, None)


def _ref_psnr(img0, img1, mask=None):
    img0, img1 = img0.astype(np.float64), img1.astype(np.float64)
    mask = None if mask is None else mask.astype(np.float64)
    return -10.0 / np.log(10.0) * np.log(_ref_masked_mean((img0 - img1) ** 2, mask))


def _ref_ssim(img0, img1, mask=None, max_val=1.0, filter_size=11, filter_sigma=1.5, k1=0.01, k2=0.03):
    img0, img1 = img0.astype(np.float64), img1.astype(np.float64)
    mask = np.ones_like(img0[..., :1]) if mask is None else mask.astype(np.float64)
    mask = mask[..., 0]
    hw = filter_size // 2
    shift = (2 * hw - filter_size + 1) / 2
    filt = np.exp(-0.5 * ((np.arange(filter_size) - hw + shift) / filter_sigma) ** 2)
    filt /= filt.sum()

    def conv(z, m, f):
        z_ = convolve2d(z * m, f, mode="valid")
        m_ = convolve2d(m, np.ones_like(f), mode="valid")
        return np.where(m_ != 0, z_ * np.ones_like(f).sum() / np.where(m_ != 0, m_, 1), 0), (m_ != 0).astype(float)

    def filt_fn(z, m):  # filt_fn1(*filt_fn2(z, m)), vmapped over channels with a shared mask
        outs, mask_out = [], None
        for c in range(z.shape[2]):
            z2, m2 = conv(z[..., c], m, filt[None, :])
            z1, mask_out = conv(z2, m2, filt[:, None])
            outs.append(z1)
        return np.stack(outs, axis=2), mask_out

    mu0, mu1 = filt_fn(img0, mask)[0], filt_fn(img1, mask)[0]
    s00 = np.maximum(0.0, filt_fn(img0**2, mask)[0] - mu0 * mu0)
    s11 = np.maximum(0.0, filt_fn(img1**2, mask)[0] - mu1 * mu1)
    s01 = filt_fn(img0 * img1, mask)[0] - mu0 * mu1
    s01 = np.sign(s01) * np.minimum(np.sqrt(s00 * s11), np.abs(s01))
    c1, c2 = (k1 * max_val) ** 2, (k2 * max_val) ** 2
    ssim_map = ((2 * mu0 * mu1 + c1) * (2 * s01 + c2)) / ((mu0**2 + mu1**2 + c1) * (s00 + s11 + c2))
    return ssim_map.mean()


def _to_quantized(x):
    return (x * 255).clip(0, 255).astype(np.uint8).astype(np.float32) / 255


def covisible_mask(h, w):
    """A covisibility-like mask: a large blob (the seen region) with a ragged edge and a hole."""
    yy, xx = np.mgrid[:h, :w]
    m = (xx - w * 0.42) ** 2 / (w * 0.34) ** 2 + (yy - h * 0.5) ** 2 / (h * 0.38) ** 2 < 1
    m &= ~((np.abs(xx - w * 0.45) < w * 0.06) & (np.abs(yy - h * 0.45) < h * 0.08))
    m |= (xx > w * 0.85) & (yy > h * 0.7)
    m &= (xx + 3 * np.sin(yy / 4.0)) > 8  # ragged left border
    return m[..., None].astype(np.float32)


PHOTOS = {"astronaut": (301, 257), "coffee": (211, 333), "chelsea": (187, 251)}


@pytest.fixture(params=list(PHOTOS))
def case(request):
    h, w = PHOTOS[request.param]
    img = getattr(skdata, request.param)()[:h, :w]
    rng = np.random.default_rng(3)
    gt = img.astype(np.float32) / 255
    pred = _to_quantized(np.clip(gt + rng.normal(0, 0.04, gt.shape).astype(np.float32) * (gt + 0.2), 0, 1))
    return pred, gt, covisible_mask(h, w)


def test_mpsnr_and_mssim_equal_dycheck_reimplementation(case):
    pred, gt, m = case
    assert dycheck_psnr(pred, gt, weights=m) == pytest.approx(_ref_psnr(gt, pred, m), abs=1e-9)
    assert dycheck_ssim(pred, gt, weights=m) == pytest.approx(_ref_ssim(gt, pred, m), abs=1e-9)
    assert dycheck_psnr(pred, gt) == pytest.approx(_ref_psnr(gt, pred), abs=1e-9)
    assert dycheck_ssim(pred, gt) == pytest.approx(_ref_ssim(gt, pred), abs=1e-9)


def test_soft_and_odd_masks_equal_reimplementation(case):
    pred, gt, m = case
    soft = (m * np.linspace(0.2, 1.0, m.shape[1])[None, :, None]).astype(np.float32)
    assert dycheck_ssim(pred, gt, weights=soft) == pytest.approx(_ref_ssim(gt, pred, soft), abs=1e-9)
    speck = np.zeros_like(m)
    speck[40, 50] = 1.0  # one pixel: most windows see none (SSIM 1 there)
    assert dycheck_ssim(pred, gt, weights=speck) == pytest.approx(_ref_ssim(gt, pred, speck), abs=1e-9)


def test_mpsnr_is_the_unbiased_masked_psnr_but_mssim_is_not(case):
    """DyCheck's mPSNR divides by the mask (as dynaeval's masked_psnr); its mSSIM counts every
    window outside the mask as 1, so it sits above dynaeval's masked SSIM."""
    from dynaeval.metrics import ssim

    pred, gt, m = case
    b = m[..., 0] > 0.5
    assert dycheck_psnr(pred, gt, weights=m) == pytest.approx(psnr(pred, gt, mask=b), abs=1e-5)
    assert dycheck_ssim(pred, gt, weights=m) > ssim(pred, gt, mask=b) + 0.02


def test_properties():
    rng = np.random.default_rng(0)
    a = rng.random((40, 37, 3)).astype(np.float32)
    m = np.zeros((40, 37, 1), np.float32)
    assert dycheck_psnr(a, a) == math.inf
    assert dycheck_ssim(a, a) == pytest.approx(1.0, abs=1e-12)
    assert dycheck_ssim(a, a ** 2, weights=m) == pytest.approx(1.0)  # no window sees the mask
    assert masked_mean(np.ones((4, 4, 3)), np.zeros((4, 4, 1))) == 0.0  # the 1e-6 floor
    ones = np.ones((40, 37, 1), np.float32)
    b = rng.random((40, 37, 3)).astype(np.float32)
    assert dycheck_ssim(a, b, weights=ones) == pytest.approx(dycheck_ssim(a, b), abs=1e-12)
    with pytest.raises(InputError, match="weights must have the image's shape"):
        dycheck_psnr(a, b, weights=np.ones((5, 5)))
    with pytest.raises(InputError, match="at least 11x11"):
        dycheck_ssim(a[:9], b[:9])
    with pytest.raises(InputError, match="data_range=1"):
        dycheck_psnr(a, b, data_range=255.0)


def test_protocol_routes_weights_to_dycheck(case):
    pred, gt, m = case
    proto = get_protocol("dycheck")
    assert proto.whole_psnr(pred, gt, weights=m[..., 0]) == pytest.approx(_ref_psnr(gt, pred, m), abs=1e-9)
    assert proto.whole_ssim(pred, gt, weights=m[..., 0]) == pytest.approx(_ref_ssim(gt, pred, m), abs=1e-9)
    d = proto.describe()
    assert d["masks"] == "covisible" and d["lpips_reduce"] == "spatial-mean" and d["quantize"] == "truncate"


def test_mlpips_equals_the_lpips_package_on_masked_images(case):
    """DyCheck: ``lpips.LPIPS(net="alex", spatial=True)`` on ``im2tensor(img * mask)``, then
    ``masked_mean(map, mask)``; here with the package's module on a random backbone."""
    lpips_pkg = pytest.importorskip("lpips")
    torch = pytest.importorskip("torch")
    from dynaeval.metrics.perceptual import load_lpips, lpips_map

    pred, gt, m = case
    model = load_lpips("alex", spatial=True, pretrained_backbone=False)
    with torch.no_grad():
        t0 = lpips_pkg.im2tensor(np.array(gt * m), factor=1 / 2)
        t1 = lpips_pkg.im2tensor(np.array(pred * m), factor=1 / 2)
        ref_map = model(t0, t1).cpu().numpy()[0, 0, ..., None].astype(np.float64)
    ref = _ref_masked_mean(ref_map, m)
    got = dycheck_lpips(lambda p, g: lpips_map(p, g, pretrained_backbone=False), pred, gt, weights=m)
    assert got == pytest.approx(ref, abs=1e-6)
    whole = dycheck_lpips(lambda p, g: lpips_map(p, g, pretrained_backbone=False), pred, gt)
    assert whole != pytest.approx(got, abs=1e-4)  # the masked images change the number


JAX_PY, DYCHECK_SRC = os.environ.get("DYNAEVAL_JAX_PYTHON"), os.environ.get("DYCHECK_SRC")


@pytest.mark.skipif(not (JAX_PY and DYCHECK_SRC), reason="set DYNAEVAL_JAX_PYTHON (an interpreter "
                    "with jax) and DYCHECK_SRC (a KAIR-BAIR/dycheck checkout) to compare with DyCheck")
def test_equals_dycheck_jax_itself(tmp_path):
    """DyCheck's own jax functions, float32: agreement to float32 rounding."""
    cases = {}
    for name, (h, w) in PHOTOS.items():
        img = getattr(skdata, name)()[:h, :w]
        gt = img.astype(np.float32) / 255
        pred = _to_quantized(np.clip(gt + np.random.default_rng(5).normal(0, 0.04, gt.shape), 0, 1))
        cases.update({f"{name}/gt": gt, f"{name}/pred": pred, f"{name}/mask": covisible_mask(h, w)})
    np.savez(tmp_path / "cases.npz", **cases)
    subprocess.run([JAX_PY, str(ROOT / "tools/protocol_sources/dycheck_jax.py"), DYCHECK_SRC,
                    str(tmp_path / "cases.npz"), str(tmp_path / "out.json")], check=True)
    ref = json.loads((tmp_path / "out.json").read_text())
    for name, r in ref.items():
        p, g, m = (cases[f"{name}/{k}"] for k in ("pred", "gt", "mask"))
        assert dycheck_psnr(p, g) == pytest.approx(r["psnr"], abs=1e-5)
        assert dycheck_psnr(p, g, weights=m) == pytest.approx(r["mpsnr"], abs=1e-5)
        assert dycheck_ssim(p, g) == pytest.approx(r["ssim"], abs=5e-5)
        assert dycheck_ssim(p, g, weights=m) == pytest.approx(r["mssim"], abs=5e-5)
    assert sys.executable != JAX_PY


def test_score_dycheck_layout_lpips_and_psnr(tmp_path, random_lpips):
    """``score`` on a DyCheck dataset (covisible masks found beside ``rgb/2x``): ``mlpips`` and
    ``lpips`` as DyCheck computes them, from the files (random-weight backbone)."""
    import cv2

    import dynaeval
    from dynaeval.metrics.perceptual import lpips_map
    from dynaeval.regions.focus import FocusConfig
    from tests.dynaeval.mask_layouts import dycheck_dataset

    pred_dir, gt_dir = dycheck_dataset(tmp_path)
    res = dynaeval.score(pred_dir, gt_dir, protocol="dycheck", metrics=("psnr", "lpips"),
                         temporal=False, progress=False, focus=FocusConfig("none"))
    cov = gt_dir.parent.parent / "covisible" / "2x" / "val"
    smap = lambda p, g: lpips_map(p, g, pretrained_backbone=False)  # noqa: E731
    for row in res["frames"]:
        name = f"{row['frame']}.png"
        p = _to_quantized(cv2.imread(str(pred_dir / name), cv2.IMREAD_UNCHANGED)[..., ::-1] / 65535)
        g = cv2.imread(str(gt_dir / name))[..., ::-1].astype(np.float32) / 255
        m = cv2.imread(str(cov / name))[..., :1].astype(np.float32) / 255
        assert row["mpsnr"] == pytest.approx(_ref_psnr(g, p, m), abs=1e-6)
        assert row["psnr"] == pytest.approx(_ref_psnr(g, p), abs=1e-6)
        assert row["lpips"] == pytest.approx(float(smap(p, g).mean()), abs=1e-6)
        with_masks = _ref_masked_mean(smap(p * m, g * m)[..., None].astype(np.float64), m)
        assert row["mlpips"] == pytest.approx(with_masks, abs=1e-6)
        assert row["masked_lpips"] != pytest.approx(row["mlpips"], abs=1e-4)
    assert res["settings"]["protocol"]["lpips_reduce"] == "spatial-mean"

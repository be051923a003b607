"""ImageMetrics: the training-loop class gives dynaeval score's numbers on the same frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dynaeval
from dynaeval import metrics as M
from dynaeval.cli import sample_dir
from dynaeval.errors import InputError
from dynaeval.io import read_image
from dynaeval.metrics.accumulate import ImageMetrics
from dynaeval.regions.focus import FocusConfig

torch = pytest.importorskip("torch")


@pytest.fixture(autouse=True)
def one_torch_thread():
    """On the shared 2-core machine torch's thread pool thrashes (LPIPS 10x slower); the numbers
    do not depend on it."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _sample_batches(cams):
    root = sample_dir()
    out = []
    for cam in cams:
        files = sorted((root / "gt" / cam).glob("*.png"))
        gts = np.stack([read_image(f) for f in files])
        preds = np.stack([read_image(root / "pred" / cam / f.name) for f in files])
        out.append((torch.from_numpy(preds).permute(0, 3, 1, 2), torch.from_numpy(gts).permute(0, 3, 1, 2)))
    return out


@pytest.mark.parametrize("protocol,names,cams", [
    ("dynaeval", ("psnr", "ssim", "lpips"), ("cam07",)),  # LPIPS on CPU is slow: one camera
    ("nerfbaselines", ("psnr", "ssim"), ("cam07", "eval00")),
])
def test_same_numbers_as_score_on_the_sample_frames(random_lpips, protocol, names, cams):
    root = sample_dir()
    sub = cams[0] if len(cams) == 1 else ""
    res = dynaeval.score(root / "pred" / sub, root / "gt" / sub, temporal=False, progress=False,
                         protocol=protocol, metrics=names, focus=FocusConfig(source="none", masked=False))
    acc = ImageMetrics(names, protocol=protocol)
    for pred, gt in _sample_batches(cams):  # one batch of 8 (B, 3, H, W) tensors per camera
        acc.update(pred, gt)
    out = acc.compute()
    assert len(acc) == res["summary"]["n_frames"] == 8 * len(cams)
    for name in names:
        assert out[name] == pytest.approx(res["summary"][name], rel=1e-12, abs=1e-12), name
        assert acc.values[name] == pytest.approx([f[name] for f in res["frames"]], rel=1e-12)


def test_numpy_channel_last_equals_torch_channel_first(rng):
    gt = rng.uniform(0, 1, (2, 24, 32, 3)).astype(np.float32)
    pred = np.clip(gt + rng.normal(0, 0.1, gt.shape), 0, 1).astype(np.float32)
    a, b = ImageMetrics(("psnr", "ssim")), ImageMetrics(("psnr", "ssim"))
    a.update(pred, gt)
    b.update(torch.from_numpy(pred).permute(0, 3, 1, 2), torch.from_numpy(gt).permute(0, 3, 1, 2))
    assert a.compute() == b.compute()
    assert a.compute()["psnr"] == pytest.approx(np.mean([M.psnr(p, g) for p, g in zip(pred, gt, strict=True)]))


def test_mean_of_per_image_values_not_pooled_error(rng):
    gt = np.full((2, 16, 16, 3), 0.5, np.float32)
    pred = gt + np.stack([np.full((16, 16, 3), 0.01), np.full((16, 16, 3), 0.2)]).astype(np.float32)
    acc = ImageMetrics(("psnr",))
    batch = acc.update(pred, gt)
    pooled = 10 * math.log10(1 / np.mean((pred - gt).astype(np.float64) ** 2))
    assert acc.compute()["psnr"] == pytest.approx(np.mean(batch["psnr"]))
    assert abs(acc.compute()["psnr"] - pooled) > 5  # the pooled number is not what is reported


def test_reset_single_image_and_errors(rng):
    acc = ImageMetrics(("psnr",))
    with pytest.raises(InputError, match="no image scored yet"):
        acc.compute()
    img = rng.uniform(0, 1, (3, 16, 16)).astype(np.float32)
    acc.update(torch.from_numpy(img), torch.from_numpy(img * 0.9))  # (C, H, W)
    assert len(acc) == 1
    acc.reset()
    assert len(acc) == 0
    with pytest.raises(InputError, match=r"C = 1 or 3, got shape \(1, 16, 16, 3\).*permute"):
        acc.update(torch.zeros(1, 16, 16, 3), torch.zeros(1, 16, 16, 3))
    with pytest.raises(InputError, match="pred has 2 images but gt has 1"):
        acc.update(np.zeros((2, 16, 16, 3)), np.zeros((1, 16, 16, 3)))
    with pytest.raises(InputError, match="numpy images must be"):
        acc.update(np.zeros(5), np.zeros(5))
    with pytest.raises(InputError, match="non-empty subset of psnr, ssim, lpips"):
        ImageMetrics(("psnr", "fid"))
    with pytest.raises(InputError, match="lpips_net must be alex or vgg"):
        ImageMetrics(lpips_net="squeeze")
    with pytest.raises(InputError, match="reports LPIPS with the alex backbone"):
        ImageMetrics(protocol="nerfstudio", lpips_net="vgg")
    with pytest.raises(InputError, match="LPIPS expects pred in"):
        ImageMetrics(("lpips",), pretrained_backbone=False).update(np.full((32, 32, 3), 2.0), np.zeros((32, 32, 3)))
    assert len(acc) == 0  # nothing kept from batches that raised

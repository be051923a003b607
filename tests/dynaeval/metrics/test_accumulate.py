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
        ImageMetrics(("lpips",), data_range=2.0, pretrained_backbone=False).update(
            np.full((32, 32, 3), 2.0), np.zeros((32, 32, 3)))
    assert len(acc) == 0  # nothing kept from batches that raised


@pytest.mark.parametrize("protocol", ["dycheck", "nerfbaselines", "dynaeval"])
def test_masked_image_metrics_equal_score_with_masks(tmp_path, random_lpips, protocol):
    """``masked=True``: masked_* and the protocol's masked numbers (DyCheck's m*, NeRFBaselines'
    mask-multiplied whole frame) equal ``dynaeval score`` with the same masks, frame by frame."""
    from dynaeval.io.masks import read_mask
    from dynaeval.metrics.protocols import get_protocol
    from tests.dynaeval.mask_layouts import dycheck_dataset, nerfbaselines_folder

    if protocol == "dycheck":
        pred_dir, gt_dir = dycheck_dataset(tmp_path)
        mask_dir = gt_dir.parent.parent / "covisible" / "2x" / "val"
    else:
        run = nerfbaselines_folder(tmp_path / "run")
        pred_dir, gt_dir, mask_dir = run / "color", run / "gt-color", run / "mask"
    decode = get_protocol(protocol).decode
    res = dynaeval.score(pred_dir, gt_dir, protocol=protocol, masks=str(mask_dir),
                         metrics=("psnr", "ssim", "lpips"), temporal=False, progress=False,
                         focus=FocusConfig("none"))
    im = ImageMetrics(("psnr", "ssim", "lpips"), protocol=protocol, masked=True,
                      pretrained_backbone=False)
    for row in res["frames"]:
        name = f"{row['frame']}.png"
        p, g = (read_image(d / name, decode=decode) for d in (pred_dir, gt_dir))
        got = im.update(p, g, read_mask(mask_dir / name, decode))
        for key, values in got.items():
            assert values[0] == pytest.approx(row[key], abs=1e-9), key
    assert sorted(im.compute()) == sorted(k for k in res["summary"]
                                          if k in {key for key, _, _ in im.keys})
    expected = {"dycheck": {"mpsnr", "mssim", "mlpips"}, "nerfbaselines": set(), "dynaeval": set()}
    assert {k for k, _, _ in im.keys} == {"psnr", "ssim", "lpips", "masked_psnr", "masked_ssim",
                                          "masked_lpips"} | expected[protocol]
    for key, mean in im.compute().items():
        assert mean == pytest.approx(res["summary"][key], abs=1e-9), key


def test_masked_image_metrics_need_masks_of_the_images_size():
    rng = np.random.default_rng(0)
    p, g = rng.random((2, 20, 30, 3)), rng.random((2, 20, 30, 3))  # numpy: channel last
    im = ImageMetrics(("psnr",), masked=True)
    with pytest.raises(InputError, match="needs a mask per image"):
        im.update(p, g)
    with pytest.raises(InputError, match=r"expected 2 mask\(s\) .* got shape \(20, 31\)"):
        im.update(p, g, np.ones((20, 31)))
    with pytest.raises(InputError, match=r"mask: float values must be in \[0, 1\], got values in \[255, 255\]"):
        im.update(p, g, np.full((2, 20, 30), 255, np.uint8))
    with pytest.raises(InputError, match="without masked=True"):
        ImageMetrics(("psnr",)).update(p, g, np.ones((2, 20, 30), bool))
    assert len(im) == 0  # nothing kept from the batches that raised
    m = np.zeros((2, 1, 20, 30), bool)
    m[0, :, 5:15, 5:25] = True  # the second image's mask is empty: no masked value there
    tp, tg = (torch.from_numpy(x).permute(0, 3, 1, 2) for x in (p, g))  # torch: channel first
    got = im.update(tp, tg, torch.from_numpy(m))
    assert got["masked_psnr"][1] is None and got["masked_psnr"][0] == pytest.approx(
        M.psnr(p[0], g[0], mask=m[0, 0]), abs=1e-6)
    assert im.compute()["masked_psnr"] == got["masked_psnr"][0] and len(im) == 2


def _u8_batch(rng, n=2, shape=(24, 28, 3)):
    a = rng.integers(0, 256, (n, *shape)).astype(np.uint8)
    return a, np.clip(a.astype(int) + rng.integers(-20, 21, a.shape), 0, 255).astype(np.uint8)


def test_0_255_batches_are_refused_at_data_range_1(rng):
    """Issue 32: ImageMetrics(("psnr", "ssim")) fed uint8 or float x 255 gave psnr -16.2, ssim
    0.61; nothing is kept from the batch."""
    a, b = _u8_batch(rng)
    acc = ImageMetrics(("psnr", "ssim"))
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255, or pred / 255"):
        acc.update(a, b)  # numpy (B, H, W, C)
    ta, tb = torch.from_numpy(a).permute(0, 3, 1, 2), torch.from_numpy(b).permute(0, 3, 1, 2)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255"):
        acc.update(ta, tb)  # torch (B, C, H, W) uint8: not read as float 0..255 either
    with pytest.raises(InputError, match=r"pred holds values in \[0, 255\].* data_range=255"):
        acc.update(ta.float(), tb.float())
    with pytest.raises(InputError, match=r"gt holds values in \[0, 255\]"):
        acc.update(ta.float() / 255, tb.float())  # the second image of a pair too
    assert len(acc) == 0
    acc255, acc1 = ImageMetrics(("psnr", "ssim"), data_range=255), ImageMetrics(("psnr", "ssim"))
    acc255.update(ta, tb)
    acc1.update(ta.float() / 255, tb.float() / 255)
    for key, value in acc255.compute().items():
        assert value == pytest.approx(acc1.compute()[key], abs=1e-6)


def test_channel_first_numpy_batch_is_refused_with_the_moveaxis(rng):
    a, b = _u8_batch(rng)
    with pytest.raises(InputError, match=r"pred: numpy batches are channel-last \(B, H, W, C\), "
                                         r"got shape \(2, 3, 24, 28\), which looks channel-first"
                                         r".* np\.moveaxis\(x, 1, -1\)"):
        ImageMetrics(("psnr",)).update(a.transpose(0, 3, 1, 2) / 255, b.transpose(0, 3, 1, 2) / 255)
    with pytest.raises(InputError, match=r"pred looks channel-first: shape \(3, 24, 28\)"):
        ImageMetrics(("psnr",)).update(a[0].transpose(2, 0, 1) / 255, b[0].transpose(2, 0, 1) / 255)


def test_a_protocol_that_clips_takes_overshooting_floats_but_not_uint8(rng):
    a, b = _u8_batch(rng)
    over = a[0] / 250.0  # up to 1.02: NeRFBaselines clips it, as its own code does
    acc = ImageMetrics(("psnr",), protocol="nerfbaselines")
    got = acc.update(over, b[0] / 255)["psnr"][0]
    assert got == pytest.approx(ImageMetrics(("psnr",), protocol="nerfbaselines").update(
        np.clip(over, 0, 1), b[0] / 255)["psnr"][0], abs=1e-9)
    with pytest.raises(InputError, match=r"pred holds values in \[0, 1\.02\]"):
        ImageMetrics(("psnr",)).update(over, b[0] / 255)  # dynaeval's protocol does not clip
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255"):
        acc.update(a, b)
    for protocol in ("nerfbaselines", "kplanes", "dycheck"):  # 0..255 floats: white, silently
        with pytest.raises(InputError, match=r"pred holds values in \[0, 25\d\].*data_range=255"):
            ImageMetrics(("psnr",), protocol=protocol).update(a * 1.0, b / 255)


def test_without_lpips_weights_the_library_says_so_at_construction_with_its_own_fix(tmp_path,
                                                                                   monkeypatch):
    """Issue 43 item 5: the README's `ImageMetrics()` failed at the first update() without the
    AlexNet weights, naming the CLI's --no-lpips."""
    pytest.importorskip("lpips")
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "empty"))
    with pytest.raises(InputError) as err:
        ImageMetrics()
    text = str(err.value)
    assert "LPIPS cannot run here" in text and "ImageMetrics(metrics=('psnr', 'ssim'))" in text
    assert "--no-lpips" not in text
    assert ImageMetrics(metrics=("psnr", "ssim")).metrics == ("psnr", "ssim")

"""``--protocol 3dgs`` and the nerfstudio families against their sources, on real photographs.

Oracles: float64 re-implementations of the sources' torch code written here from reading it
(gaussian-splatting / 4DGaussians ``utils/loss_utils.ssim``, ``utils/image_utils.psnr``,
``lpipsPyTorch``), the same code in float32 as they run it, and the real packages where they
install (torchmetrics 1.9, pytorch_msssim, lpips). Tolerances come from float32 rounding:
SSIM's variances E[x^2] - E[x]^2 are biased by (sum of the window - 1) * E[x]^2, and one float32
ulp in a tap (torch's exp against numpy's) or another order of the float32 sums moves SSIM of
8-bit photos by up to ~2e-5 (measured in docs/protocols.md). So each source is checked twice:
in float64 with its own taps (the formula: 1e-9 .. 2e-6) and against its float32 code (3e-5).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dynaeval.errors import UndefinedMetricError
from dynaeval.metrics.protocols import get_protocol, ssim_variant

torch = pytest.importorskip("torch")
F = torch.nn.functional

CROPS = {"astronaut": (101, 131), "chelsea": (97, 143), "coffee": (121, 89), "rocket": (77, 163)}


def photo_pairs(crops: dict = CROPS, seed: int = 3, dim: bool = True):
    """(name, pred, gt): real photos cut to ``crops`` (odd sizes), ``gt`` 8-bit as 3DGS' PNGs,
    ``pred`` the same with noise (8 bit), and (``dim``) a dim render whose values span 0.6 (a
    range < 1)."""
    data = pytest.importorskip("skimage.data")
    rng = np.random.default_rng(seed)
    out = []
    for name, (h, w) in crops.items():
        gt8 = getattr(data, name)()[:h, :w, :3]
        pred8 = np.clip(gt8 + rng.normal(0, 8, gt8.shape), 0, 255).astype(np.uint8)
        gt, pred = gt8.astype(np.float32) / 255, pred8.astype(np.float32) / 255
        out.append((name, pred, gt))
        if dim:
            dim_gt = (np.float32(0.2) + np.float32(0.6) * gt).astype(np.float32)
            dim_pred = np.clip(dim_gt + rng.normal(0, 0.04, gt.shape), 0.2, 0.8).astype(np.float32)
            out.append((name + "-dim", dim_pred, dim_gt))
    return out


PAIRS = photo_pairs()
IDS = [p[0] for p in PAIRS]


def nchw(a: np.ndarray, dtype=torch.float32):
    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None].to(dtype)


def gs_taps():
    """3DGS' gaussian(11, 1.5): taps from math.exp in a float32 tensor, normalised in float32."""
    g = torch.tensor([math.exp(-(x - 5) ** 2 / float(2 * 1.5**2)) for x in range(11)],
                     dtype=torch.float32)
    return g / g.sum()


def gs_window(dtype):
    """3DGS' create_window(11, 3): the taps' outer product in float32, one per channel, cast to
    ``dtype``."""
    g = gs_taps()[:, None]
    return (g @ g.t()).float().expand(3, 1, 11, 11).contiguous().to(dtype)


def gs_ssim(a, b, dtype):
    """utils/loss_utils._ssim in ``dtype``: conv2d with padding 5 (zeros), mean of the map."""
    w = gs_window(dtype)
    x, y = nchw(a, dtype), nchw(b, dtype)
    conv = lambda z: F.conv2d(z, w, padding=5, groups=3)  # noqa: E731
    mx, my = conv(x), conv(y)
    sxx, syy, sxy = conv(x * x) - mx**2, conv(y * y) - my**2, conv(x * y) - mx * my
    c1, c2 = 0.01**2, 0.03**2
    m = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx**2 + my**2 + c1) * (sxx + syy + c2))
    return float(m.mean())


def gs_psnr(a, b, dtype):
    """utils/image_utils.psnr in ``dtype``: 20 log10(1 / sqrt(mean squared error))."""
    mse = ((nchw(a, dtype) - nchw(b, dtype)) ** 2).reshape(1, -1).mean(1, keepdim=True)
    return float(20 * torch.log10(1.0 / torch.sqrt(mse)))


@pytest.mark.parametrize("name,pred,gt", PAIRS, ids=IDS)
def test_3dgs_ssim_and_psnr_match_their_torch_code(name, pred, gt):
    proto = get_protocol("3dgs")
    s, p = proto.whole_ssim(pred, gt), proto.whole_psnr(pred, gt)
    assert s == pytest.approx(gs_ssim(pred, gt, torch.float64), abs=3e-5)
    assert s == pytest.approx(gs_ssim(pred, gt, torch.float32), abs=3e-5)
    assert p == pytest.approx(gs_psnr(pred, gt, torch.float64), abs=2e-5)
    assert p == pytest.approx(gs_psnr(pred, gt, torch.float32), abs=1e-5)
    # the zero-padded border windows count: not the valid-window SSIM of the other tools
    assert abs(s - ssim_variant(pred, gt, border="valid")) > 1e-4


def test_3dgs_float64_form_of_the_filter_equals_their_conv2d():
    """The zero border of the separable filter equals conv2d(padding=5) exactly in float64 (so
    only float32 rounding separates dynaeval from their code)."""
    _, pred, gt = PAIRS[0]
    ours = ssim_variant(pred, gt, border="zero", precision="float64",
                        window=gs_taps().double().numpy())
    assert ours == pytest.approx(gs_ssim(pred, gt, torch.float64), abs=2e-6)


def test_3dgs_psnr_identical_is_inf():
    _, _, gt = PAIRS[0]
    assert get_protocol("3dgs").whole_psnr(gt, gt) == math.inf
    assert get_protocol("3dgs").whole_ssim(gt, gt) == pytest.approx(1.0, abs=1e-6)


def test_3dgs_reads_pngs_as_pil_to_tensor(tmp_path):
    """metrics.py: PIL.Image.open -> to_tensor (v / 255 in float32) -> [:3]; dynaeval's reader
    gives the same float32 values for all 256 levels."""
    tf = pytest.importorskip("torchvision.transforms.functional")
    image = pytest.importorskip("PIL.Image")
    import cv2

    from dynaeval.io.images import read_image

    levels = np.arange(256, dtype=np.uint8).reshape(16, 16)
    rgb = np.stack([levels, levels[::-1], levels.T], -1)
    cv2.imwrite(str(tmp_path / "a.png"), rgb[..., ::-1])
    theirs = tf.to_tensor(image.open(tmp_path / "a.png"))[:3].permute(1, 2, 0).numpy()
    np.testing.assert_array_equal(read_image(tmp_path / "a.png").astype(np.float32), theirs)


# --- LPIPS: lpipsPyTorch (3DGS) against the lpips package -------------------------------------

VGG_FILE = Path("/work/golden/torch/hub/checkpoints/vgg16-397923af.pth")


@pytest.fixture
def random_vgg(monkeypatch):
    """TORCH_HOME with a random-weight VGG16 checkpoint under torchvision's file name, so the
    'pretrained' backbone of every implementation is the same random one (no download)."""
    import os

    home = Path(os.environ.get("RANDOM_BACKBONE_CACHE", VGG_FILE.parents[2]))
    if not (home / "hub" / "checkpoints" / VGG_FILE.name).is_file():
        pytest.skip("no random-weight vgg16 checkpoint (set RANDOM_BACKBONE_CACHE)")
    monkeypatch.setenv("TORCH_HOME", str(home))
    return home / "hub" / "checkpoints" / VGG_FILE.name


LPIPSPYTORCH_TARGETS = {"alex": (2, 5, 8, 10, 12), "vgg": (4, 9, 16, 23, 30)}
"""lpipsPyTorch's ``target_layers``: 1-based module numbers of ``features`` whose outputs count
(alex: relu1..relu5; vgg: relu1_2, relu2_2, relu3_3, relu4_3, relu5_3)."""


class LpipsPyTorch(torch.nn.Module):
    """lpipsPyTorch's ``LPIPS(net_type, '0.1')`` re-written from its source (gaussian-splatting's
    and 4DGaussians' ``lpipsPyTorch/modules/{lpips,networks,utils}.py`` are the same), in float64:
    torchvision ``alexnet``/``vgg16`` ``features`` with the given weights, z-score with shift
    (-0.030, -0.088, -0.188) / scale (0.458, 0.448, 0.450), the outputs of
    ``LPIPSPYTORCH_TARGETS[net]`` (enumeration from 1, stopping after the last), each divided by
    (its channel norm + 1e-10), squared differences through the v0.1 1x1 linear layers
    (``richzhang/PerceptualSimilarity`` ``lpips/weights/v0.1/<net>.pth``, keys renamed), spatial
    mean, summed. No input scaling: it is given [0, 1] tensors as they are."""

    def __init__(self, net: str, features: dict):
        import lpips
        import torchvision

        super().__init__()
        build = {"alex": torchvision.models.alexnet, "vgg": torchvision.models.vgg16}[net]
        self.layers = build(weights=None).features.eval()
        self.layers.load_state_dict(features)
        self.layers.double().requires_grad_(False)
        self.targets = LPIPSPYTORCH_TARGETS[net]
        f64 = torch.float64
        self.mean = torch.tensor([-0.030, -0.088, -0.188], dtype=f64)[None, :, None, None]
        self.std = torch.tensor([0.458, 0.448, 0.450], dtype=f64)[None, :, None, None]
        lin = torch.load(Path(lpips.__file__).parent / "weights" / "v0.1" / f"{net}.pth",
                         map_location="cpu", weights_only=True)
        self.lins = [lin[f"lin{i}.model.1.weight"].double() for i in range(5)]

    def forward(self, x, y):
        fx, fy = self._features(x.double()), self._features(y.double())
        res = [F.conv2d((a - b) ** 2, w).mean((2, 3), True) for a, b, w in zip(fx, fy, self.lins, strict=True)]
        return torch.sum(torch.cat(res, 0), 0, True)

    def _features(self, x):
        x = (x - self.mean) / self.std
        out = []
        for i, layer in enumerate(self.layers, 1):
            x = layer(x)
            if i in self.targets:
                out.append(x / (torch.sqrt(torch.sum(x**2, dim=1, keepdim=True)) + 1e-10))
            if len(out) == len(self.targets):
                break
        return out


def checkpoint_features(path: Path) -> dict:
    """``features.*`` of a torchvision checkpoint, keyed as ``features``' own state dict."""
    state = torch.load(path, map_location="cpu", weights_only=True)
    return {k.split(".", 1)[1]: v for k, v in state.items() if k.startswith("features.")}


def package_features(model) -> dict:
    """The backbone of an ``lpips.LPIPS`` (``net.sliceK.N.*``) keyed as torchvision's
    ``features`` (``N.*``): the slices keep torchvision's module numbers."""
    return {k.split(".", 1)[1]: v for k, v in model.net.state_dict().items()}


def test_lpipspytorch_vgg_is_the_lpips_package_vgg_fed_unit_images(random_vgg):
    import lpips as lpips_pkg

    from dynaeval.metrics.protocol_3dgs import lpips_unit_input

    theirs = LpipsPyTorch("vgg", checkpoint_features(random_vgg))
    package = lpips_pkg.LPIPS(net="vgg", pnet_rand=True, verbose=False).eval()
    package.net.load_state_dict(_sliced(random_vgg, package.net.state_dict()), strict=True)
    for _, pred, gt in PAIRS[:4]:
        x, y = nchw(pred), nchw(gt)
        with torch.no_grad():
            ref = float(theirs(x, y))
            # same network: the package on the same [0, 1] tensors, and on [-1, 1] ones
            assert float(package(x, y)) == pytest.approx(ref, rel=1e-5, abs=1e-7)
            assert float(theirs(2 * x - 1, 2 * y - 1)) == pytest.approx(
                float(package(x, y, normalize=True)), rel=1e-5, abs=1e-7)
            signed = float(package(x, y, normalize=True))
        assert lpips_unit_input(pred, gt, net="vgg") == pytest.approx(ref, rel=1e-5, abs=1e-7)
        assert abs(signed - ref) > 1e-3 * max(ref, signed)  # the unscaled input matters


def _sliced(backbone: Path, keys) -> dict:
    """torchvision's ``features.N.*`` tensors under the lpips package's ``sliceK.N.*`` keys."""
    state = torch.load(backbone, map_location="cpu", weights_only=True)
    return {k: state["features." + k.split(".", 1)[1]] for k in keys}


# --- nerfstudio: nerfacto (torchmetrics, no data_range) and splatfacto (pytorch_msssim) --------

@pytest.mark.parametrize("name,pred,gt", PAIRS, ids=IDS)
def test_nerfstudio_ssim_is_torchmetrics_without_data_range(name, pred, gt):
    tm = pytest.importorskip("torchmetrics.functional.image")
    ours = get_protocol("nerfstudio").whole_ssim(pred, gt)
    # nerfacto.py: self.ssim(gt_rgb, predicted_rgb), no data_range
    ref = float(tm.structural_similarity_index_measure(nchw(gt), nchw(pred)))
    assert ours == pytest.approx(ref, abs=3e-5)
    # the formula, in float64 (torchmetrics' taps are the float64 Gaussian's within 1e-16 there)
    from dynaeval.metrics.protocol_nerfstudio import image_data_range

    f64 = ssim_variant(pred, gt, data_range=image_data_range(pred, gt), border="reflect",
                       clamp="zero", precision="float64")
    ref64 = float(tm.structural_similarity_index_measure(nchw(gt, torch.float64),
                                                         nchw(pred, torch.float64)))
    assert f64 == pytest.approx(ref64, abs=1e-6)
    fixed = float(tm.structural_similarity_index_measure(nchw(gt), nchw(pred), data_range=1.0))
    if name.endswith("-dim"):  # range 0.6: the per-image constants change SSIM clearly
        assert abs(ours - fixed) > 1e-3
    psnr_ref = float(tm.peak_signal_noise_ratio(nchw(gt), nchw(pred), data_range=1.0))
    assert get_protocol("nerfstudio").whole_psnr(pred, gt) == pytest.approx(psnr_ref, abs=1e-4)


@pytest.mark.parametrize("name,pred,gt", PAIRS, ids=IDS)
def test_splatfacto_ssim_is_pytorch_msssim(name, pred, gt):
    pm = pytest.importorskip("pytorch_msssim")
    ours = get_protocol("nerfstudio-splatfacto").whole_ssim(pred, gt)
    module = pm.SSIM(data_range=1.0, size_average=True, channel=3)  # splatfacto.py
    assert ours == pytest.approx(float(module(nchw(gt), nchw(pred))), abs=1e-6)
    # the same float32 taps, and the formula in float64 with them
    from pytorch_msssim.ssim import _fspecial_gauss_1d

    from dynaeval.metrics.protocol_nerfstudio import msssim_window

    taps = _fspecial_gauss_1d(11, 1.5).reshape(-1).double().numpy()
    np.testing.assert_array_equal(msssim_window(), taps.astype(np.float32))
    f64 = ssim_variant(pred, gt, border="valid", precision="float64", window=taps)
    ref64 = float(pm.ssim(nchw(gt, torch.float64), nchw(pred, torch.float64), data_range=1.0))
    assert f64 == pytest.approx(ref64, abs=1e-9)


def test_nerfstudio_constant_images_are_undefined():
    flat = np.full((20, 20, 3), 0.5, np.float32)
    with pytest.raises(UndefinedMetricError, match="both images are constant"):
        get_protocol("nerfstudio").whole_ssim(flat, flat)
    assert get_protocol("nerfstudio-splatfacto").whole_ssim(flat, flat) == pytest.approx(1.0)


def test_protocols_record_their_choices():
    d3 = get_protocol("3dgs").describe()
    assert (d3["ssim"], d3["psnr"], d3["lpips_net"], d3["lpips_input"]) == ("3dgs", "3dgs", "vgg", "unit")
    ns = get_protocol("nerfstudio").describe()
    assert ns["ssim_data_range"] == "image" and "nerfacto" in ns["family"]
    sp = get_protocol("nerfstudio-splatfacto").describe()
    assert sp["ssim"] == "pytorch_msssim" and sp["family"] == "splatfacto"
    assert "ssim_data_range" not in sp and "lpips_input" not in sp  # the defaults
    assert set(get_protocol("dynaeval").describe()) == {
        "name", "quantize", "psnr", "ssim", "clip", "lpips_net", "reference"}


def test_3dgs_run_uses_vgg_and_the_unscaled_whole_frame_lpips(tmp_path, random_lpips):
    import dynaeval
    from dynaeval.errors import InputError
    from dynaeval.io.images import read_image
    from dynaeval.metrics import perceptual
    from dynaeval.metrics.accumulate import ImageMetrics
    from dynaeval.metrics.protocol_3dgs import lpips_unit_input
    from dynaeval.regions.focus import FocusConfig

    from ..io.test_layout_3dgs import _iteration

    assert dynaeval.ScoreConfig(protocol="3dgs").resolved_lpips_net() == "vgg"
    assert dynaeval.ScoreConfig().resolved_lpips_net() == "alex"
    with pytest.raises(InputError, match="reports LPIPS with the vgg backbone, not alex"):
        dynaeval.ScoreConfig(protocol="3dgs", lpips_net="alex")
    assert ImageMetrics(protocol="3dgs").lpips_net == "vgg"
    ours = _iteration(tmp_path / "m", "test", 100, frames=2)
    res = dynaeval.score(tmp_path / "m", protocol="3dgs", metrics=("lpips",), temporal=False,
                         focus=FocusConfig(source="none", masked=False), progress=False)
    assert res["settings"]["lpips"]["net"] == "vgg"
    for row in res["frames"]:
        p, g = read_image(row["pred"]), read_image(row["gt"])
        assert row["pred"].startswith(str(ours))
        assert row["lpips"] == pytest.approx(lpips_unit_input(p, g), rel=1e-6)
        assert abs(row["lpips"] - perceptual.lpips(p, g, net="vgg")) > 1e-4


def test_3dgs_lpips_onnxruntime_backend_equals_torch(random_lpips):
    pytest.importorskip("onnxruntime")
    from dynaeval.metrics.protocol_3dgs import lpips_unit_input

    _, pred, gt = PAIRS[2]
    ref = lpips_unit_input(pred, gt, net="vgg")
    assert lpips_unit_input(pred, gt, net="vgg", backend="onnxruntime") == pytest.approx(
        ref, rel=1e-5, abs=1e-7)


# --- 4DGaussians: MS-SSIM / D-SSIM of pytorch_msssim, LPIPS-alex of lpipsPyTorch ----------------

BIG_CROPS = {"astronaut": (181, 203), "chelsea": (300, 451), "coffee": (201, 161),
             "rocket": (178, 240)}
"""At least 161 px (pytorch_msssim's MS-SSIM), odd and even sides (its zero-padded pooling)."""


BIG_PAIRS = photo_pairs(BIG_CROPS, seed=4, dim=False)


@pytest.mark.parametrize("name,pred,gt", BIG_PAIRS, ids=[p[0] for p in BIG_PAIRS])
def test_4dgaussians_msssim_is_pytorch_msssim(name, pred, gt):
    """metrics.py: ``ms_ssim(renders[idx], gts[idx], data_range=1, size_average=True)``, and
    ``(1 - that) / 2``. Against their float32 run: 2e-6 (measured <= 6e-7, their own float32
    rounding; dynaeval's float32 variant: <= 8e-7 here, 3e-6 on smooth images); the formula
    against pytorch_msssim on float64 tensors: 1e-12 (measured 4e-16)."""
    pm = pytest.importorskip("pytorch_msssim")
    from dynaeval.metrics.multiscale import ms_ssim as torchmetrics_msssim
    from dynaeval.metrics.protocol_3dgs import dssim_4dgaussians, msssim_4dgaussians

    ref = float(pm.ms_ssim(nchw(pred), nchw(gt), data_range=1, size_average=True))
    ours = msssim_4dgaussians(pred, gt)
    assert ours == pytest.approx(ref, abs=2e-6)
    assert dssim_4dgaussians(pred, gt) == pytest.approx((1 - ref) / 2, abs=1e-6)
    f64 = pm.ms_ssim(nchw(pred, torch.float64), nchw(gt, torch.float64), data_range=1)
    assert ours == pytest.approx(float(f64), abs=1e-12)
    assert msssim_4dgaussians(pred, gt, precision="float32") == pytest.approx(ref, abs=2e-6)
    # not the torchmetrics MS-SSIM of --protocol kplanes / --msssim (measured 2e-4 .. 2e-3)
    if min(pred.shape[:2]) >= 176:
        assert abs(ours - torchmetrics_msssim(pred, gt)) > 1e-4


def test_4dgaussians_msssim_below_161_px_is_undefined():
    from dynaeval.metrics.protocol_3dgs import msssim_4dgaussians

    _, pred, gt = BIG_PAIRS[2]  # 201 x 161: the smallest that works
    msssim_4dgaussians(pred, gt)
    with pytest.raises(UndefinedMetricError, match=r"at least 161 px .* got 201x160"):
        msssim_4dgaussians(pred[:, :160], gt[:, :160])


def test_4dgaussians_msssim_refuses_0_255_input_as_ms_ssim_does():
    """Issue 32 item 1: the library's MS-SSIM entry points refuse values outside [0, data_range]."""
    from dynaeval.errors import InputError
    from dynaeval.metrics.protocol_3dgs import dssim_4dgaussians, msssim_4dgaussians

    _, pred, gt = BIG_PAIRS[2]
    p255, g255 = np.asarray(pred, np.float64) * 255, np.asarray(gt, np.float64) * 255
    with pytest.raises(InputError, match=r"pred holds values in .* data_range=255"):
        msssim_4dgaussians(p255, g255)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255"):
        dssim_4dgaussians(p255.astype(np.uint8), g255.astype(np.uint8))
    assert msssim_4dgaussians(p255, g255, data_range=255) == pytest.approx(
        msssim_4dgaussians(pred, gt), abs=1e-9)


def test_4dgaussians_protocol_is_3dgs_plus_its_msssim_and_alex():
    from dynaeval.errors import InputError
    from dynaeval.metrics.protocols import PROTOCOL_NAMES, run_metrics
    from dynaeval.run.config import ScoreConfig

    g4, g3 = get_protocol("4dgaussians"), get_protocol("3dgs")
    assert "4dgaussians" in PROTOCOL_NAMES
    _, pred, gt = BIG_PAIRS[0]
    assert g4.whole_ssim(pred, gt) == g3.whole_ssim(pred, gt)
    assert g4.whole_psnr(pred, gt) == g3.whole_psnr(pred, gt)
    assert run_metrics(g4, ("psnr",)) == ("psnr", "msssim", "dssim")
    d = g4.describe()
    assert (d["msssim"], d["lpips_nets"], d["lpips_net"], d["lpips_input"]) == (
        "pytorch_msssim", ["alex"], "vgg", "unit")
    assert ScoreConfig(protocol="4dgaussians").resolved_lpips_net() == "vgg"
    assert ScoreConfig(protocol="4dgaussians", lpips_net="alex").resolved_lpips_net() == "alex"
    with pytest.raises(InputError, match="reports LPIPS with the vgg backbone, not alex"):
        ScoreConfig(protocol="3dgs", lpips_net="alex")


def test_4dgaussians_run_records_pytorch_msssim(tmp_path):
    """``score(protocol="4dgaussians")`` adds msssim/dssim as pytorch_msssim computes them."""
    import cv2

    import dynaeval
    from dynaeval.regions.focus import FocusConfig

    for sub in ("pred", "gt"):
        (tmp_path / sub).mkdir()
    for i, (_, pred, gt) in enumerate(BIG_PAIRS[:1] * 2):
        for sub, im in (("pred", pred), ("gt", gt)):
            png = np.round(im * 255)[..., ::-1].astype(np.uint8)
            cv2.imwrite(str(tmp_path / sub / f"{i:05d}.png"), png)
    res = dynaeval.score(tmp_path / "pred", tmp_path / "gt", protocol="4dgaussians",
                         metrics=("psnr",), temporal=False, progress=False,
                         focus=FocusConfig(source="none", masked=False))
    pm = pytest.importorskip("pytorch_msssim")
    from dynaeval.io.images import read_image

    row = res["frames"][0]
    p, g = read_image(row["pred"]), read_image(row["gt"])
    ref = float(pm.ms_ssim(nchw(p), nchw(g), data_range=1, size_average=True))
    assert row["msssim"] == pytest.approx(ref, abs=2e-6)
    assert row["dssim"] == pytest.approx((1 - ref) / 2, abs=1e-6)
    assert res["settings"]["msssim"]["variant"].startswith("pytorch_msssim 1.0 ms_ssim")
    assert res["settings"]["protocol"]["lpips_net"] == "vgg"  # the protocol's own
    alex = dynaeval.score(tmp_path / "pred", tmp_path / "gt", protocol="4dgaussians",
                          lpips_net="alex", metrics=("psnr",), temporal=False, progress=False,
                          focus=FocusConfig(source="none", masked=False))
    # issue 43: the protocol block said "vgg" when the run used alex: one truth
    assert alex["settings"]["protocol"]["lpips_net"] == "alex"


def test_4dgaussians_lpips_alex_is_lpipspytorch_alex(random_lpips):
    """metrics.py: ``lpips(render, gt, net_type='alex')`` of lpipsPyTorch on [0, 1] tensors,
    against the float64 re-implementation on the same random-weight AlexNet (rel 1e-5: float32);
    the package's usual [-1, 1] value differs."""
    from dynaeval.metrics import perceptual
    from dynaeval.metrics.protocol_3dgs import lpips_unit_input

    package = perceptual.load_lpips("alex")  # the fixture's random backbone, real linear layers
    theirs = LpipsPyTorch("alex", package_features(package))
    for _, pred, gt in PAIRS[:4]:
        with torch.no_grad():
            ref = float(theirs(nchw(pred), nchw(gt)))
        ours = lpips_unit_input(pred, gt, net="alex", pretrained_backbone=False)
        assert ours == pytest.approx(ref, rel=1e-5, abs=1e-7)
        assert abs(perceptual.lpips(pred, gt, net="alex") - ref) > 1e-3 * ref

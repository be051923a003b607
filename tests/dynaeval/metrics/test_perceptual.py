"""LPIPS: equal to the lpips package on the same network (random backbone, real linear layers).

Oracle: ``lpips.LPIPS(pretrained=True, net=..., pnet_rand=True)`` built after
``torch.manual_seed(0)``, fed [-1, 1] NCHW tensors; tolerance atol 1e-6.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

torch = pytest.importorskip("torch")
lpips_pkg = pytest.importorskip("lpips")

from dynaeval.errors import EmptyRegionError, InputError, WeightsUnavailableError  # noqa: E402
from dynaeval.metrics import (  # noqa: E402
    backbone_weights_file,
    load_lpips,
    lpips,
    lpips_map,
    perceptual,
)

ATOL = 1e-6
RANDOM = {"pretrained_backbone": False, "seed": 0}


def _package(net: str, spatial: bool = False):
    with torch.random.fork_rng(devices=[]), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.manual_seed(0)
        return lpips_pkg.LPIPS(pretrained=True, net=net, pnet_rand=True, spatial=spatial, verbose=False)


def _nchw(a: np.ndarray):
    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)[None], dtype=np.float32)) * 2 - 1


@pytest.fixture(scope="module")
def pair():
    rng = np.random.default_rng(1)
    a = rng.random((48, 64, 3)).astype(np.float32)
    return a, np.clip(a + 0.1 * rng.standard_normal(a.shape), 0, 1).astype(np.float32)


@pytest.fixture(scope="module")
def package_alex():
    return _package("alex")


@pytest.mark.parametrize("net", ["alex", pytest.param("vgg", marks=pytest.mark.slow)])
def test_lpips_equals_package_on_the_same_network(pair, package_alex, net):
    """VGG16 is marked slow: building its random 138M-parameter network takes ~10 s here."""
    a, b = pair
    ref = package_alex if net == "alex" else _package(net)
    with torch.no_grad():
        expected = ref(_nchw(a), _nchw(b)).item()
    assert lpips(a, b, net=net, **RANDOM) == pytest.approx(expected, abs=ATOL)
    ours = load_lpips(net, **RANDOM)
    for (k1, v1), (k2, v2) in zip(ours.state_dict().items(), ref.state_dict().items(), strict=True):
        assert k1 == k2 and torch.equal(v1, v2)


def test_feature_split_is_the_package_forward_bit_for_bit(pair, package_alex):
    """LpipsFeatures: backbone per image, distance per pair = the package's forward exactly (the
    same operations), on several sizes; features of different sizes are refused."""
    rng = np.random.default_rng(3)
    split = perceptual.LpipsFeatures("alex", **RANDOM)
    for shape in [pair[0].shape, (131, 97, 3), (40, 33, 3)]:
        a, b = rng.random(shape).astype(np.float32), rng.random(shape).astype(np.float32)
        with torch.no_grad():
            expected = float(package_alex(_nchw(a), _nchw(b)).double().item())
        fa, fb = split.features(a), split.features(b)
        assert split.distance(fa, fb) == expected == split(a, b) == lpips(a, b, **RANDOM)
        assert split.distance(fa, fa) == 0.0
    assert split.features_bytes(fa) == sum(f.numel() * 4 for f in fa)
    with pytest.raises(InputError, match="different sizes"):
        split.distance(split.features(pair[0]), fa)
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        split.features(pair[0] * 2)


def test_lpips_map_equals_package_spatial(pair):
    a, b = pair
    with torch.no_grad():
        expected = _package("alex", spatial=True)(_nchw(a), _nchw(b))[0, 0].numpy()
    np.testing.assert_allclose(lpips_map(a, b, **RANDOM), expected, rtol=0, atol=ATOL)


def test_identical_is_zero_and_symmetric(pair):
    a, b = pair
    assert lpips(a, a, **RANDOM) == 0.0
    assert lpips(a, b, **RANDOM) == pytest.approx(lpips(b, a, **RANDOM), abs=ATOL)
    assert lpips(a, b, **RANDOM) > 0


def test_more_noise_is_worse(pair):
    a, _ = pair
    noise = 0.05 * np.random.default_rng(2).standard_normal(a.shape)
    assert lpips(np.clip(a + 2 * noise, 0, 1), a, **RANDOM) > lpips(np.clip(a + noise, 0, 1), a, **RANDOM)


def test_float64_torch_and_grayscale_inputs(pair):
    a, b = pair
    v = lpips(a, b, **RANDOM)
    assert lpips(a.astype(np.float64), b.astype(np.float64), **RANDOM) == pytest.approx(v, abs=ATOL)
    assert lpips(torch.from_numpy(a), torch.from_numpy(b), **RANDOM) == v
    g1, g2 = a[..., 0], b[..., 0]
    rgb = lpips(np.repeat(g1[..., None], 3, 2), np.repeat(g2[..., None], 3, 2), **RANDOM)
    assert lpips(g1, g2, **RANDOM) == pytest.approx(rgb, abs=ATOL)


def test_masked_lpips_is_the_spatial_map_mean(pair):
    a, b = pair
    mask = np.zeros(a.shape[:2], bool)
    mask[10:30, 5:40] = True
    expected = lpips_map(a, b, **RANDOM)[mask].mean(dtype=np.float64)
    assert lpips(a, b, mask=mask, **RANDOM) == pytest.approx(expected, abs=1e-12)


def test_crop_mode_is_area_weighted_package_value_of_each_crop(pair, package_alex):
    a, b = pair
    ref = package_alex
    boxes = np.array([[0, 0, 32, 32], [30, 10, 62, 42], [5, 35, 45, 48], [50, 40, 55, 44]])
    # boxes below 31 px are grown with their real neighbours and shifted inside the image:
    # 40x13 at y 35..48 -> y 26..57 -> 17..48; 5x4 at (50, 40) -> x 37..68 -> 33..64, y 17..48
    crops = [(0, 0, 32, 32), (30, 10, 62, 42), (5, 17, 45, 48), (33, 17, 64, 48)]
    areas = [32 * 32, 32 * 32, 40 * 13, 5 * 4]
    with torch.no_grad():
        vals = [ref(_nchw(a[y0:y1, x0:x1]), _nchw(b[y0:y1, x0:x1])).item() for x0, y0, x1, y1 in crops]
    expected = np.average(vals, weights=areas)
    assert lpips(a, b, boxes=boxes, **RANDOM) == pytest.approx(expected, abs=ATOL)


def test_crop_mode_ignores_differences_outside_the_boxes(pair):
    a, b = pair
    box = np.array([[10, 5, 50, 40]])
    pred = b.copy()
    pred[5:40, 10:50] = a[5:40, 10:50]
    assert lpips(pred, a, boxes=box, **RANDOM) == 0.0
    assert lpips(pred, a, boxes=box, region_mode="map", **RANDOM) > 0.0  # receptive field leaks


def test_model_is_cached_in_eval_mode_and_eval_is_restored(pair):
    a, b = pair
    m1 = load_lpips("alex", **RANDOM)
    assert m1 is load_lpips("alex", **RANDOM)
    assert m1 is not load_lpips("alex", spatial=True, **RANDOM)
    assert not any(m.training for m in m1.modules())
    v = lpips(a, b, **RANDOM)
    m1.train()  # dropout on: would change the value
    assert lpips(a, b, **RANDOM) == v
    assert not m1.training
    assert not any(p.requires_grad for p in m1.parameters())


def test_missing_backbone_weights_name_the_file_and_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TORCH_HOME", str(tmp_path))
    monkeypatch.setattr(perceptual, "_MODELS", {})
    path = backbone_weights_file("alex")
    assert path == tmp_path / "hub" / "checkpoints" / "alexnet-owt-7be5be79.pth"
    assert backbone_weights_file("vgg").name == "vgg16-397923af.pth"
    msg = r"place alexnet-owt-7be5be79\.pth .* in " + str(tmp_path / "hub" / "checkpoints")
    with pytest.raises(WeightsUnavailableError, match=msg):
        lpips(np.zeros((32, 32, 3)), np.zeros((32, 32, 3)))


def test_pretrained_backbone_is_loaded_from_the_cache_file(tmp_path, monkeypatch):
    from torchvision.models import alexnet

    monkeypatch.setenv("TORCH_HOME", str(tmp_path))
    monkeypatch.setattr(perceptual, "_MODELS", {})
    torch.manual_seed(123)
    state = alexnet(weights=None).state_dict()
    path = backbone_weights_file("alex")
    path.parent.mkdir(parents=True)
    torch.save(state, path)
    model = load_lpips("alex")
    for key, value in model.net.state_dict().items():
        assert torch.equal(value, state["features." + key.split(".", 1)[1]])
    random_model = load_lpips("alex", **RANDOM)
    assert not torch.equal(model.net.slice1[0].weight, random_model.net.slice1[0].weight)


@pytest.mark.parametrize(
    ("pred", "kwargs", "match"),
    [
        (np.full((32, 32, 3), -0.5), {}, r"LPIPS expects pred in \[0, 1\].*\(x \+ 1\) / 2"),
        (np.full((32, 32, 3), 255, dtype=np.uint8), {}, r"divide by 255"),
        (np.zeros((30, 40, 3)), {}, r"at least 31x31 pixels .* got 30x40"),
        (np.zeros((32, 32, 4)), {}, "4 channels"),
        (np.zeros((32, 32, 3)), {"net": "squeeze"}, "net must be one of alex, vgg"),
        (np.zeros((32, 32, 3)), {"region_mode": "x"}, "region_mode must be one of"),
        (np.zeros((32, 32, 3)), {"region_mode": "crop", "mask": np.ones((32, 32), bool)}, "needs boxes"),
    ],
)
def test_lpips_input_errors(pred, kwargs, match):
    with pytest.raises(InputError, match=match):
        lpips(pred, np.zeros(pred.shape, dtype=pred.dtype), **RANDOM, **kwargs)


def test_lpips_empty_region():
    z = np.zeros((32, 32, 3))
    with pytest.raises(EmptyRegionError, match="no box"):
        lpips(z, z, boxes=[[40, 40, 50, 50]], **RANDOM)


# ---- fast path: the same network through onnxruntime, devices ---------------------------------


ort = pytest.importorskip("onnxruntime")
ONNX = {**RANDOM, "backend": "onnxruntime"}


def test_onnx_backend_equals_the_package(pair, package_alex):
    a, b = pair
    with torch.no_grad():
        expected = package_alex(_nchw(a), _nchw(b)).item()
    assert lpips(a, b, **ONNX) == pytest.approx(expected, abs=ATOL)
    assert lpips(a, b, **ONNX) == pytest.approx(lpips(a, b, **RANDOM), abs=ATOL)


def test_onnx_backend_map_crops_and_mask_equal_torch(pair):
    a, b = pair
    np.testing.assert_allclose(lpips_map(a, b, **ONNX), lpips_map(a, b, **RANDOM), rtol=0, atol=ATOL)
    boxes = np.array([[0, 0, 40, 40], [20, 5, 60, 45], [3, 10, 14, 20]])  # two equal sizes: a batch
    assert lpips(a, b, boxes=boxes, **ONNX) == pytest.approx(lpips(a, b, boxes=boxes, **RANDOM), abs=ATOL)
    mask = np.zeros(a.shape[:2], bool)
    mask[10:30, 20:50] = True
    assert lpips(a, b, mask=mask, **ONNX) == pytest.approx(lpips(a, b, mask=mask, **RANDOM), abs=ATOL)


def test_onnx_session_is_cached_and_other_sizes_run(pair):
    from dynaeval.metrics import load_lpips_onnx

    s1 = load_lpips_onnx("alex", **RANDOM)
    assert s1 is load_lpips_onnx("alex", **RANDOM)
    rng = np.random.default_rng(3)
    c, d = rng.random((40, 33, 3)), rng.random((40, 33, 3))  # dynamic height and width
    assert lpips(c, d, **ONNX) == pytest.approx(lpips(c, d, **RANDOM), abs=ATOL)


def test_export_refuses_a_model_in_training_mode_and_keeps_eval():
    """Dropout in training mode would move LPIPS by up to 1e-3: the export must see eval mode."""
    model = _package("alex")
    model.train()
    with pytest.raises(RuntimeError, match="training mode"):
        perceptual.export_lpips_onnx(model)
    model.eval()
    data = perceptual.export_lpips_onnx(model)
    assert not any(m.training for m in model.modules())
    onnx = pytest.importorskip("onnx")
    ops = {n.op_type for n in onnx.load_from_string(data).graph.node}
    assert "Dropout" not in ops and "Conv" in ops


def test_backend_and_device_errors(pair, monkeypatch):
    a, b = pair
    with pytest.raises(InputError, match="backend must be one of torch, onnxruntime"):
        lpips(a, b, backend="tensorrt", **RANDOM)
    monkeypatch.setattr(ort, "get_available_providers", lambda: ["CPUExecutionProvider"])
    with pytest.raises(InputError, match="no CUDAExecutionProvider.*onnxruntime-gpu"):
        lpips(a, b, device="cuda", **ONNX)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
def test_cuda_equals_cpu(pair):
    a, b = pair
    cpu = lpips(a, b, **RANDOM)
    assert lpips(a, b, device="cuda", **RANDOM) == pytest.approx(cpu, abs=1e-4)
    assert lpips(a, b, device="auto", **RANDOM) == pytest.approx(cpu, abs=1e-4)
    if "CUDAExecutionProvider" in ort.get_available_providers():
        assert lpips(a, b, device="cuda", **ONNX) == pytest.approx(cpu, abs=1e-4)


def test_the_backbone_urls_and_the_hub_folder_are_torchvisions_own_without_loading_it(
        tmp_path, monkeypatch):
    """Issue 43 item 5: whether LPIPS can run was found by importing torch and torchvision (4-25 s
    before a requested LPIPS was refused). The URLs and the hub folder are now known without
    them, and equal torchvision's enum and ``torch.hub.get_dir()``."""
    import subprocess
    import sys

    from dynaeval.metrics import perceptual

    models = pytest.importorskip("torchvision.models")
    assert perceptual.BACKBONE_URLS == {"alex": models.AlexNet_Weights.IMAGENET1K_V1.url,
                                        "vgg": models.VGG16_Weights.IMAGENET1K_V1.url}
    code = ("import os, sys; from dynaeval.metrics.perceptual import backbone_weights_file; "
            "p = backbone_weights_file('alex'); assert 'torch' not in sys.modules, 'torch loaded'; "
            "import torch; assert str(p.parent) == os.path.join(torch.hub.get_dir(), 'checkpoints'), p; "
            "print(p)")
    for env in ({"TORCH_HOME": str(tmp_path / "th")}, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, {}):
        base = {k: v for k, v in __import__("os").environ.items()
                if k not in ("TORCH_HOME", "XDG_CACHE_HOME")}
        run = subprocess.run([sys.executable, "-c", code], env={**base, **env},
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stderr

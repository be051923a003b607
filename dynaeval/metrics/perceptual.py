"""LPIPS (Zhang et al. 2018) through the ``lpips`` package: whole image, masked (spatial map), focused (crops).

The network is the package's own ``lpips.LPIPS`` (its calibrated linear layers, shipped inside the
package) on a torchvision AlexNet/VGG16 backbone whose ImageNet weights come from torchvision's
cache directory (``$TORCH_HOME/hub/checkpoints``, default ``~/.cache/torch/hub/checkpoints``).
Nothing is downloaded: when the file is absent, ``WeightsUnavailableError`` names the file and
the directory. Torch is imported only inside these functions; models are built on first use and
cached per (net, device, spatial, backbone), in eval mode, and run under ``torch.no_grad``.
"""

from __future__ import annotations

import os
import sys
import threading
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.boxes import grow_box
from dynaeval.core.deps import load, missing
from dynaeval.core.errors import InputError, UndefinedMetricError, WeightsUnavailableError
from dynaeval.core.runtime import new_session, onnx_providers, resolve_device, torch_device
from dynaeval.core.validation import check_pair, grey_to_rgb
from dynaeval.metrics._common import clipped_boxes, region_mask

LPIPS_NETS = ("alex", "vgg")
MIN_SIZE = {"alex": 31, "vgg": 16}
"""Smallest image side (pixels) each backbone accepts: AlexNet's strided conv + two max-pools need
31 px before conv3; VGG16's four 2x2 pools before conv5 need 16 px. Smaller crops are grown."""
REGION_MODES = ("crop", "map")
LPIPS_BACKENDS = ("torch", "onnxruntime")
"""``torch``: the package's module itself (the reference). ``onnxruntime``: the very same module
exported to ONNX and run by onnxruntime (same numbers within 1e-6, tested; its speed against the
package is measured in docs/benchmarks.md)."""

_MODELS: dict[tuple[Any, ...], Any] = {}
_SESSIONS: dict[tuple[Any, ...], Any] = {}
_LOCK = threading.Lock()


def _check_net(net: str) -> None:
    if net not in LPIPS_NETS:
        raise InputError(f"LPIPS net must be one of {', '.join(LPIPS_NETS)}, got {net!r}")


BACKBONE_URLS = {"alex": "https://download.pytorch.org/models/alexnet-owt-7be5be79.pth",
                 "vgg": "https://download.pytorch.org/models/vgg16-397923af.pth"}
"""Download URL of each backbone's ImageNet weights: torchvision's weights enum
(``AlexNet_Weights.IMAGENET1K_V1``, ``VGG16_Weights.IMAGENET1K_V1``; a test holds them equal),
written here so finding whether the weights are on the machine loads neither torch nor
torchvision (a requested LPIPS that cannot run was refused only after 4-25 s of loading them)."""


def _backbone_url(net: str) -> str:
    """Download URL of ``net``'s ImageNet weights (``BACKBONE_URLS``)."""
    return BACKBONE_URLS[net]


def _hub_dir() -> Path:
    """``torch.hub.get_dir()`` without importing torch: ``$TORCH_HOME/hub``, else
    ``$XDG_CACHE_HOME/torch/hub`` (``~/.cache`` by default); torch's own answer once it is
    imported (``torch.hub.set_dir`` may have changed it)."""
    if "torch" in sys.modules:
        return Path(load("torch").hub.get_dir())
    home = os.environ.get("TORCH_HOME") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "torch")
    return Path(os.path.expanduser(home)) / "hub"


def backbone_weights_file(net: str = "alex") -> Path:
    """Path where torchvision keeps the pretrained backbone of ``net`` (may not exist).

    The file name comes from torchvision's weights enum (``AlexNet_Weights.IMAGENET1K_V1``,
    ``VGG16_Weights.IMAGENET1K_V1``); the directory is ``torch.hub.get_dir()/checkpoints``, which
    honours ``TORCH_HOME``.
    """
    _check_net(net)
    return _hub_dir() / "checkpoints" / _backbone_url(net).rsplit("/", 1)[-1]


def _weights_absent(net: str) -> str | None:
    """Why ``net``'s pretrained backbone cannot be loaded (where to place it), or None."""
    path = backbone_weights_file(net)
    if path.is_file():
        return None
    return (f"LPIPS ({net}) needs torchvision's pretrained {net} backbone, which is not on this "
            f"machine: place {path.name} (from {_backbone_url(net)}) in {path.parent} "
            "(set TORCH_HOME to use another cache directory)")  # how to do without: the caller's


def missing_package(ctx: Any) -> str | None:
    """Why LPIPS cannot run on this machine (the install line, or where to place the backbone
    of ``ctx.lpips_net``), or None: the registry's ``requires``, found without building the
    network (torch is imported only when its package is there, to find the weights file)."""
    absent = missing("torch", "torchvision", "lpips")
    if absent:
        return (f"LPIPS needs the torch, torchvision and lpips packages ({', '.join(absent)} "
                f"not installed): pip install 'dynaeval[lpips]'")
    return _weights_absent(ctx.lpips_net) if ctx.pretrained_backbone else None


def _build(net: str, spatial: bool, pretrained_backbone: bool, seed: int) -> Any:
    lpips_pkg = load("lpips")
    torch = load("torch")

    path = backbone_weights_file(net)
    missing = _weights_absent(net) if pretrained_backbone else None
    if missing:
        raise WeightsUnavailableError(missing)
    # The package builds its backbone through torchvision's deprecated ``pretrained=`` argument;
    # pnet_rand=True makes torchvision build it without weights (no download is ever tried).
    with torch.random.fork_rng(devices=[]), warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=UserWarning, module="torchvision")
        torch.manual_seed(seed)
        model = lpips_pkg.LPIPS(
            pretrained=True, net=net, pnet_rand=True, spatial=spatial, verbose=False
        )
    if pretrained_backbone:
        state = torch.load(path, map_location="cpu", weights_only=True)
        # the package slices torchvision's ``features`` into slice1..5 keeping the layer index:
        # ``slice2.3.weight`` is ``features.3.weight``
        mapped = {
            key: state["features." + key.split(".", 1)[1]] for key in model.net.state_dict()
        }
        model.net.load_state_dict(mapped, strict=True)
    model.eval()
    for p in model.parameters():
        p.requires_grad_(False)
    if any(m.training for m in model.modules()):
        raise RuntimeError("LPIPS model is not in eval mode: its dropout would change results")
    return model


def load_lpips(
    net: str = "alex",
    *,
    device: object = None,
    spatial: bool = False,
    pretrained_backbone: bool = True,
    seed: int = 0,
) -> Any:
    """The ``lpips.LPIPS`` network, built once per argument set and cached (never at import time).

    Args:
        net: ``"alex"`` (default, what NeRF papers report) or ``"vgg"``.
        device: torch device or string (``auto``: see ``dynaeval.core.runtime``); None means CPU.
        spatial: True gives the per-pixel map (the package's ``spatial=True``), False the mean.
        pretrained_backbone: True loads torchvision's ImageNet backbone from its cache
            (WeightsUnavailableError when absent); False keeps a randomly initialised backbone
            drawn with ``seed`` (for tests; equals ``lpips.LPIPS(pretrained=True, net=net,
            pnet_rand=True)`` built after ``torch.manual_seed(seed)``).
        seed: seed of the random backbone (ignored when ``pretrained_backbone``).

    Returns:
        The ``torch.nn.Module`` in eval mode, parameters frozen, on ``device``.
    """
    _check_net(net)
    dev = torch_device(device)
    key = (net, str(dev), bool(spatial), bool(pretrained_backbone), None if pretrained_backbone else int(seed))
    with _LOCK:
        model = _MODELS.get(key)
        if model is None:
            model = _build(net, spatial, pretrained_backbone, seed).to(dev)
            _MODELS[key] = model
    if model.training:  # someone called .train() on the cached model
        model.eval()
    return model


def export_lpips_onnx(model: Any) -> bytes:
    """The ``lpips.LPIPS`` module ``model`` as ONNX bytes (inputs ``pred``, ``gt``: (B, 3, H, W)
    float32 in [-1, 1], any B, H, W; output ``d``: (B, 1, 1, 1), or (B, 1, H, W) if spatial).

    Exported in eval mode (dropout is the identity and leaves the graph); raises RuntimeError if
    the module is in training mode before or after the export, since the package's dropout would
    move results by up to 1e-3.
    """
    import io

    torch = load("torch")

    if any(m.training for m in model.modules()):
        raise RuntimeError("LPIPS model is in training mode: call .eval() before exporting it")
    x = torch.zeros(1, 3, 64, 64)
    buf = io.BytesIO()
    axes = {0: "batch", 2: "height", 3: "width"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            model,
            (x, x.clone()),
            buf,
            dynamo=False,
            training=torch.onnx.TrainingMode.EVAL,
            input_names=["pred", "gt"],
            output_names=["d"],
            dynamic_axes={"pred": axes, "gt": axes, "d": axes},
            opset_version=17,
        )
    if any(m.training for m in model.modules()):
        raise RuntimeError("LPIPS model left in training mode by the ONNX export")
    return buf.getvalue()


def load_lpips_onnx(
    net: str = "alex",
    *,
    device: object = None,
    spatial: bool = False,
    pretrained_backbone: bool = True,
    seed: int = 0,
    threads: int = 1,
) -> Any:
    """An onnxruntime session running exactly ``load_lpips(net, ...)``'s network, cached.

    Args:
        net, spatial, pretrained_backbone, seed: see ``load_lpips`` (the weights are the same).
        device: ``cpu`` (default), ``cuda[:i]`` (CUDA execution provider, needs
            onnxruntime-gpu) or ``auto``.
        threads: onnxruntime intra-op threads; spinning is off, so a thread that waits for a busy
            core sleeps instead of burning it (on a shared machine spinning threads made torch's
            LPIPS ~2x slower per thread added, docs/benchmarks.md).

    Returns:
        ``onnxruntime.InferenceSession`` with inputs ``pred``, ``gt`` and output ``d``.
    """
    _check_net(net)
    providers = onnx_providers(device)
    key = (net, tuple(providers), bool(spatial), bool(pretrained_backbone),
           None if pretrained_backbone else int(seed), int(threads))
    with _LOCK:
        session = _SESSIONS.get(key)
    if session is not None:
        return session
    model = load_lpips(net, spatial=spatial, pretrained_backbone=pretrained_backbone, seed=seed)
    data = export_lpips_onnx(model)
    session = new_session(data, providers, threads=threads)
    with _LOCK:
        return _SESSIONS.setdefault(key, session)


def _check_backend(backend: str) -> None:
    if backend not in LPIPS_BACKENDS:
        raise InputError(f"LPIPS backend must be one of {', '.join(LPIPS_BACKENDS)}, got {backend!r}")


def _network(net: str, spatial: bool, backend: str, kw: dict[str, Any]):  # noqa: ANN202
    """``run(preds, gts) -> (B, ...) float64 numpy`` for lists of (h, w, 3) arrays in [0, 1]."""
    if backend == "onnxruntime":
        session = load_lpips_onnx(net, spatial=spatial, **kw)

        def run_onnx(ps: list[np.ndarray], gs: list[np.ndarray]) -> np.ndarray:
            out = session.run(["d"], {"pred": _to_nchw(ps), "gt": _to_nchw(gs)})[0]
            return out.astype(np.float64)

        return run_onnx
    torch = load("torch")

    kw = {k: v for k, v in kw.items() if k != "threads"}
    kw["device"] = resolve_device(kw.get("device"))
    model = load_lpips(net, spatial=spatial, **kw)
    dev = next(model.parameters()).device

    def run_torch(ps: list[np.ndarray], gs: list[np.ndarray]) -> np.ndarray:
        with torch.no_grad():
            out = model(_to_tensor(ps, dev), _to_tensor(gs, dev))
        return out.double().cpu().numpy()

    return run_torch


def _check_lpips_image(p: np.ndarray, name: str) -> np.ndarray:
    lo, hi = float(p.min()), float(p.max())
    if lo < 0.0 or hi > 1.0:
        raise InputError(
            f"LPIPS expects {name} in [0, 1] (dynaeval scales it to the network's [-1, 1] itself); "
            f"got values in [{lo:.4g}, {hi:.4g}]. Images already in [-1, 1]: pass (x + 1) / 2; "
            "uint8: divide by 255"
        )
    return grey_to_rgb(p, name, "LPIPS")


def _to_tensor(batch: list[np.ndarray], device: Any) -> Any:
    """List of (h, w, 3) arrays in [0, 1] -> (B, 3, h, w) float32 tensor in [-1, 1]."""
    torch = load("torch")

    arr = np.stack(batch).astype(np.float32, copy=False).transpose(0, 3, 1, 2)
    t = torch.from_numpy(np.ascontiguousarray(arr)).to(device)
    return t * 2.0 - 1.0


def _to_nchw(batch: list[np.ndarray]) -> np.ndarray:
    """List of (h, w, 3) arrays in [0, 1] -> (B, 3, h, w) float32 numpy in [-1, 1] (as _to_tensor)."""
    arr = np.stack(batch).astype(np.float32, copy=False).transpose(0, 3, 1, 2)
    out = np.ascontiguousarray(arr)
    out *= np.float32(2.0)
    out -= np.float32(1.0)
    return out


def _prepare(pred: object, gt: object, net: str) -> tuple[np.ndarray, np.ndarray]:
    _check_net(net)
    p, g = check_pair(pred, gt)
    p = _check_lpips_image(p, "pred")
    g = _check_lpips_image(g, "gt")
    h, w = p.shape[:2]
    if min(h, w) < MIN_SIZE[net]:
        raise UndefinedMetricError(
            f"LPIPS ({net}) needs images of at least {MIN_SIZE[net]}x{MIN_SIZE[net]} pixels "
            f"(the backbone's pooling), got {h}x{w}; score larger images or skip LPIPS"
        )
    return p, g


def lpips_map(
    pred: object,
    gt: object,
    *,
    net: str = "alex",
    device: object = None,
    pretrained_backbone: bool = True,
    seed: int = 0,
    backend: str = "torch",
    threads: int = 1,
) -> np.ndarray:
    """Spatial LPIPS map: (H, W) float32, >= 0, lower is better (the package's ``spatial=True``).

    Args:
        pred, gt: (H, W, 3) or (H, W) arrays/tensors in [0, 1], H, W >= MIN_SIZE[net].
        net, pretrained_backbone, seed: see ``load_lpips``.
        device: ``None``/``"cpu"``, ``"cuda[:i]"`` or ``"auto"`` (GPU when torch sees one).
        backend: ``"torch"`` (the package's module) or ``"onnxruntime"`` (the same network
            exported; ``load_lpips_onnx``).
        threads: onnxruntime intra-op threads (the torch backend uses torch's own setting).
    """
    _check_backend(backend)
    p, g = _prepare(pred, gt, net)
    kw = {"device": device, "pretrained_backbone": pretrained_backbone, "seed": seed, "threads": threads}
    out = _network(net, True, backend, kw)([p], [g])
    return out[0, 0].astype(np.float32)


def lpips(
    pred: object,
    gt: object,
    *,
    net: str = "alex",
    mask: object = None,
    boxes: object = None,
    region_mode: str | None = None,
    device: object = None,
    pretrained_backbone: bool = True,
    seed: int = 0,
    backend: str = "torch",
    threads: int = 1,
) -> float:
    """Learned perceptual image patch similarity (LPIPS v0.1), whole image or region; lower is better.

    Args:
        pred, gt: (H, W, 3) RGB or (H, W) grayscale (replicated to RGB) numpy arrays/tensors in
            [0, 1] (checked: values outside raise InputError), H, W >= MIN_SIZE[net].
        net: ``"alex"`` (default) or ``"vgg"``.
        mask: optional bool (H, W): mean of the spatial LPIPS map over the masked pixels.
        boxes: optional (N, 4) ``[x_min, y_min, x_max, y_max]`` max exclusive.
        region_mode: ``"crop"``: each box is cropped and scored by the network as an image of its
            own (crops of equal size are batched), a box below MIN_SIZE[net] in a dimension is
            grown to it with its real neighbours; the frame value is the box-area-weighted mean.
            ``"map"``: mean of the whole frame's spatial map over the region's pixels (the map
            sees pixels outside the region through the receptive field). Default None:
            ``"crop"`` for boxes, ``"map"`` for a mask.
        device: ``None``/``"cpu"``, ``"cuda[:i]"`` or ``"auto"`` (GPU when torch sees one).
        pretrained_backbone, seed: see ``load_lpips``.
        backend: ``"torch"`` (default: the package's module, the reference) or ``"onnxruntime"``
            (the same network exported to ONNX; same numbers within 1e-6, tested).
        threads: onnxruntime intra-op threads (the torch backend uses torch's own setting).

    Returns:
        LPIPS as a float >= 0 (0 for identical images).

    Raises:
        InputError: shapes, range, channels, NaN/Inf, bad mask/boxes/mode/net/backend.
        UndefinedMetricError: (an InputError) the image is smaller than MIN_SIZE[net].
        EmptyRegionError: the region holds no pixel.
        WeightsUnavailableError: the pretrained backbone is not in torchvision's cache.
    """
    if region_mode is not None and region_mode not in REGION_MODES:
        raise InputError(f"region_mode must be one of {REGION_MODES} or None, got {region_mode!r}")
    if mask is not None and region_mode == "crop":
        raise InputError("region_mode='crop' needs boxes; a mask is scored with region_mode='map'")
    _check_backend(backend)
    p, g = _prepare(pred, gt, net)
    h, w = p.shape[:2]
    m = region_mask(mask, boxes, h, w)
    kw = {"device": device, "pretrained_backbone": pretrained_backbone, "seed": seed, "threads": threads}
    if m is not None and (mask is not None or region_mode == "map"):
        smap = _network(net, True, backend, kw)([p], [g])[0, 0]
        return float(smap[m].mean(dtype=np.float64))
    run = _network(net, False, backend, kw)
    if m is None:
        return float(run([p], [g]).reshape(-1)[0])
    # crop mode: group equal-sized crops into one batch each
    groups: dict[tuple[int, int], list[tuple[int, np.ndarray]]] = {}
    for box in clipped_boxes(boxes, h, w):
        area = int((box[2] - box[0]) * (box[3] - box[1]))
        x0, y0, x1, y1 = grow_box(box, MIN_SIZE[net], MIN_SIZE[net], h, w)
        groups.setdefault((y1 - y0, x1 - x0), []).append((area, np.array([x0, y0, x1, y1])))
    total = 0.0
    weight = 0
    for items in groups.values():
        crops_p = [p[b[1] : b[3], b[0] : b[2]] for _, b in items]
        crops_g = [g[b[1] : b[3], b[0] : b[2]] for _, b in items]
        vals = run(crops_p, crops_g).reshape(-1)
        for (area, _), v in zip(items, vals, strict=True):
            total += area * float(v)
            weight += area
    return total / weight


class LpipsFeatures:
    """LPIPS split in two, for sequences: ``features(x)`` once per image, ``distance(fa, fb)`` per
    pair; ``self(a, b)`` is ``lpips(a, b)`` (torch backend) bit for bit.

    The package's forward runs the backbone on each image separately and compares the normalised
    features of both; doing the two halves apart gives the very same operations, so tLP, which
    compares every frame with its predecessor and its successor, computes each frame's
    features once instead of twice (tested bit-identical to the package).

    Args:
        net, device, pretrained_backbone, seed: see ``load_lpips`` (``device`` may be ``auto``).

    Memory: one image's features are the backbone's five activations, float32: 86 MB at
    1920x1080 for AlexNet (``features_bytes``). Thread-safe (the module runs under no_grad).
    """

    def __init__(self, net: str = "alex", *, device: object = None,
                 pretrained_backbone: bool = True, seed: int = 0) -> None:
        _check_net(net)
        self.net = net
        self._kw = {"device": resolve_device(device), "pretrained_backbone": pretrained_backbone,
                    "seed": seed}

    def _model(self) -> Any:
        return load_lpips(self.net, spatial=False, **self._kw)

    def features(self, image: object) -> tuple[Any, ...]:
        """Normalised backbone features of one ``(H, W, 3)`` / ``(H, W)`` image in [0, 1]: a tuple of
        ``(1, C_k, h_k, w_k)`` float32 tensors (the package's ``normalize_tensor`` of each layer)."""
        lpips_pkg = load("lpips")
        torch = load("torch")

        x, _ = _prepare(image, image, self.net)
        model = self._model()
        dev = next(model.parameters()).device
        with torch.no_grad():
            outs = model.net.forward(model.scaling_layer(_to_tensor([x], dev)))
            return tuple(lpips_pkg.normalize_tensor(o) for o in outs)

    def distance(self, fa: tuple[Any, ...], fb: tuple[Any, ...]) -> float:
        """LPIPS between two images given their ``features``: float >= 0."""
        lpips_pkg = load("lpips")
        torch = load("torch")

        if len(fa) != len(fb) or any(a.shape != b.shape for a, b in zip(fa, fb, strict=True)):
            raise InputError("LPIPS features of images of different sizes cannot be compared")
        model = self._model()
        with torch.no_grad():
            val = 0
            for kk in range(model.L):
                val += lpips_pkg.spatial_average(model.lins[kk]((fa[kk] - fb[kk]) ** 2),
                                                 keepdim=True)
        return float(val.double().cpu().numpy().reshape(-1)[0])

    @staticmethod
    def features_bytes(features: tuple[Any, ...]) -> int:
        """Bytes held by one image's ``features``."""
        return sum(f.numel() * f.element_size() for f in features)

    def __call__(self, a: object, b: object) -> float:
        return self.distance(self.features(a), self.features(b))


def lpips_unit_input(pred: object, gt: object, *, net: str = "vgg", device: object = None,
                     backend: str = "torch", pretrained_backbone: bool = True) -> float:
    """LPIPS of [0, 1] images fed to the network unscaled, as 3DGS' ``metrics.py`` does.

    The network is ``dynaeval.metrics.perceptual``'s (the ``lpips`` package's v0.1 module, or its
    ONNX export); only the input differs: the package's ``forward`` expects [-1, 1] and 3DGS
    gives it ``to_tensor``'s [0, 1].

    Args:
        pred, gt: (H, W, 3) or (H, W) arrays/tensors in [0, 1], H, W >= ``MIN_SIZE[net]``.
        net: ``vgg`` (3DGS) or ``alex``.
        device, backend, pretrained_backbone: as ``dynaeval.metrics.perceptual.lpips``.

    Returns:
        LPIPS, a float >= 0 (0 for identical images).
    """
    _check_backend(backend)
    p, g = _prepare(pred, gt, net)
    a, b = (np.ascontiguousarray(x.astype(np.float32)[None].transpose(0, 3, 1, 2)) for x in (p, g))
    if backend == "onnxruntime":
        session = load_lpips_onnx(net, device=device, pretrained_backbone=pretrained_backbone)
        return float(session.run(["d"], {"pred": a, "gt": b})[0].reshape(-1)[0])
    torch = load("torch")

    model = load_lpips(net, device=resolve_device(device), pretrained_backbone=pretrained_backbone)
    dev = next(model.parameters()).device
    with torch.no_grad():
        out = model(torch.from_numpy(a).to(dev), torch.from_numpy(b).to(dev))
    return float(out.double().cpu().reshape(-1)[0])


def build_lpips(ctx: Any) -> Any:
    """The registry's LPIPS for a run (``dynaeval.metrics.registry.FrameContext``): loads the
    network once now, so missing weights (``WeightsUnavailableError``) or packages
    (``ImportError``) are known before the first frame; the whole frame (and a given mask's
    weights) as the protocol scores it (``Protocol.whole_lpips``), a region as ``lpips``."""
    net, device, backend = ctx.lpips_net, ctx.device, ctx.lpips_backend
    pretrained = ctx.pretrained_backbone
    loader = load_lpips_onnx if backend == "onnxruntime" else load_lpips
    loader(net, device=device, pretrained_backbone=pretrained)

    kw = {"net": net, "device": device, "backend": backend, "pretrained_backbone": pretrained}
    protocol = ctx.whole()

    def fn(pred: np.ndarray, gt: np.ndarray, region: dict[str, Any]) -> float:
        if not region or "weights" in region:
            return protocol.whole_lpips(pred, gt, score=lambda p, g: lpips(p, g, **kw),
                                        score_map=lambda p, g: lpips_map(p, g, **kw),
                                        score_unit=lambda p, g: lpips_unit_input(p, g, **kw),
                                        weights=region.get("weights"))
        return lpips(pred, gt, **kw, **region)

    return fn


def lpips_settings(ctx: Any, enabled: bool, unavailable: str | None) -> dict[str, Any]:
    """What the results record of LPIPS: whether it ran, the backbone, and where it ran."""
    out: dict[str, Any] = {"enabled": enabled, "net": ctx.lpips_net}
    if unavailable is not None:
        out["unavailable"] = unavailable
    if enabled:
        out.update(device=ctx.device, backend=ctx.lpips_backend)
    return out

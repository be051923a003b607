"""The 3DGS family's own metrics (``--protocol 3dgs``): gaussian-splatting, 4DGaussians, Deformable-3DGS.

All three evaluate with the same ``metrics.py`` (read, not copied; docs/protocols.md cites the
files): each ``renders/NNNNN.png`` and ``gt/NNNNN.png`` is read with PIL, turned into a float32
tensor by ``torchvision.transforms.functional.to_tensor`` (``v / 255``) and cut to RGB
(``[:, :3]``, no compositing), then

* PSNR: ``utils/image_utils.psnr`` = ``20 log10(1 / sqrt(MSE))``, float32, per image
  (``psnr_3dgs``);
* SSIM: ``utils/loss_utils.ssim``: an 11-tap Gaussian (sigma 1.5), ``conv2d(padding=5)`` — zero
  padding, so the map has the image's size and the border windows count — float32,
  ``C1 = 0.01^2``, ``C2 = 0.03^2``, mean over the map (``ssim_variant(border="zero")`` in
  ``dynaeval.metrics.protocols``);
* LPIPS: ``lpipsPyTorch.lpips(..., net_type="vgg")`` (gaussian-splatting, 4DGaussians) or
  ``lpips.LPIPS(net="vgg")`` (Deformable-3DGS), both v0.1 VGG16 with the same linear layers, the
  same shift/scale layer and the same five ReLU outputs — the same network. Both are given the
  [0, 1] tensors *as they are*, where the network expects [-1, 1] (``lpips_unit_input``).

The summary is the mean of the per-image values (``torch.tensor(values).mean()``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dynaeval.validation import check_data_range, check_pair


def psnr_3dgs(pred: object, gt: object, *, data_range: float = 1.0) -> float:
    """PSNR in dB as 3DGS' ``utils/image_utils.psnr``: ``20 log10(L / sqrt(MSE))`` in float32.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range].
        data_range: L (3DGS: 1.0).

    Returns:
        The float32 value as a Python float; ``math.inf`` for identical images.
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    d = p.astype(np.float32) - g.astype(np.float32)
    mse = np.mean(d * d, dtype=np.float32)
    if mse == 0:
        return math.inf
    one = np.float32(data_range)
    return float(np.float32(20) * np.log10(one / np.sqrt(mse)))


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
    from dynaeval.metrics import perceptual
    from dynaeval.runtime import resolve_device

    perceptual._check_backend(backend)
    p, g = perceptual._prepare(pred, gt, net)
    a, b = (np.ascontiguousarray(x.astype(np.float32)[None].transpose(0, 3, 1, 2)) for x in (p, g))
    if backend == "onnxruntime":
        session = perceptual.load_lpips_onnx(net, device=device,
                                             pretrained_backbone=pretrained_backbone)
        return float(session.run(["d"], {"pred": a, "gt": b})[0].reshape(-1)[0])
    import torch

    model = perceptual.load_lpips(net, device=resolve_device(device),
                                  pretrained_backbone=pretrained_backbone)
    dev = next(model.parameters()).device
    with torch.no_grad():
        out = model(torch.from_numpy(a).to(dev), torch.from_numpy(b).to(dev))
    return float(out.double().cpu().reshape(-1)[0])


def whole_lpips(ctx: Any) -> Any:
    """The protocol's whole-frame LPIPS for the registry's ``build_lpips``, or None when the
    protocol feeds the network the package's way (``lpips_input == "signed"``)."""
    if getattr(ctx.whole(), "lpips_input", "signed") != "unit":
        return None

    def fn(pred: np.ndarray, gt: np.ndarray) -> float:
        return lpips_unit_input(pred, gt, net=ctx.lpips_net, device=ctx.device,
                                backend=ctx.lpips_backend,
                                pretrained_backbone=ctx.pretrained_backbone)

    return fn

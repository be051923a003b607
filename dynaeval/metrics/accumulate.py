"""``ImageMetrics``: accumulate per-frame metrics over batches in a training or eval loop.

A thin stateful layer over the registry's per-frame metrics (``dynaeval.metrics.registry``:
PSNR, SSIM, LPIPS and any metric registered later, with a protocol's whole-frame variants):
``update`` scores every image of a batch and keeps the per-image values, ``compute`` returns their
means — the same numbers ``dynaeval score`` writes for the same frames and settings (summaries are
means of per-image values, never of a pooled error).

    metrics = ImageMetrics(device="cuda")
    for batch in loader:
        metrics.update(render(batch), batch["image"])   # (B, 3, H, W) tensors in [0, 1]
    print(metrics.compute())                             # {"psnr": ..., "ssim": ..., "lpips": ...}
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dynaeval.errors import InputError
from dynaeval.metrics.registry import FrameContext, FrameFn, default_frame_metrics, frame_specs
from dynaeval.validation import is_torch_tensor

SUPPORTED = tuple(s.name for s in frame_specs())
"""Names ``ImageMetrics`` accepts: every per-frame metric of the registry."""


def _images(x: Any, name: str) -> list[np.ndarray]:
    """A batch as a list of (H, W, C) float arrays.

    Torch tensors: (B, C, H, W) or (C, H, W), channel first, C in {1, 3}; numpy arrays:
    (B, H, W, C), (H, W, C) or (H, W), channel last.
    """
    if is_torch_tensor(x):
        shape = tuple(x.shape)
        if len(shape) == 3:
            x = x[None]
        if x.ndim != 4 or x.shape[1] not in (1, 3):
            raise InputError(
                f"{name}: torch tensors must be (B, C, H, W) or (C, H, W) with C = 1 or 3, got shape "
                f"{shape}; a channel-last (B, H, W, C) tensor needs .permute(0, 3, 1, 2)"
            )
        arr = x.detach().float().cpu().numpy().transpose(0, 2, 3, 1)
        return list(arr)
    arr = np.asarray(x)
    if arr.ndim in (2, 3):
        return [arr]
    if arr.ndim == 4:
        return list(arr)
    raise InputError(f"{name}: numpy images must be (B, H, W, C), (H, W, C) or (H, W), got shape "
                     f"{arr.shape}")


class ImageMetrics:
    """Per-image values of per-frame metrics over many ``update`` calls; ``compute`` gives means.

    Args:
        metrics: registry names (default: those ``dynaeval score`` runs by default, ``psnr``,
            ``ssim``, ``lpips``, plus the protocol's own: ``msssim``, ``dssim`` for ``kplanes``).
        data_range: peak value of the images (1.0 for [0, 1]); LPIPS needs [0, 1].
        lpips_net: ``alex`` or ``vgg``; default None: the protocol's (``alex``; ``vgg`` for
            ``3dgs``).
        device: torch device for LPIPS; None: the device of the first tensor given (CPU for numpy).
        protocol: ``dynaeval`` (default) or another of ``PROTOCOL_NAMES``: whose whole-frame
            PSNR/SSIM and 8-bit step to use (``dynaeval.metrics.protocols``).
        pretrained_backbone: False only in tests (LPIPS with a random backbone, see ``load_lpips``).

    Raises:
        InputError: unknown metric, net or protocol, or a protocol/net mismatch.
    """

    def __init__(
        self,
        metrics: Sequence[str] | None = None,
        data_range: float = 1.0,
        lpips_net: str | None = None,
        device: Any = None,
        protocol: str = "dynaeval",
        pretrained_backbone: bool = True,
    ) -> None:
        from dynaeval.metrics.protocols import check_lpips_net, get_protocol, run_metrics
        from dynaeval.validation import check_data_range

        metrics = (run_metrics(get_protocol(protocol), default_frame_metrics()) if metrics is None
                   else tuple(metrics))
        unknown = [m for m in metrics if m not in SUPPORTED]
        if unknown or not metrics:
            raise InputError(f"metrics must be a non-empty subset of {', '.join(SUPPORTED)}, "
                             f"got {list(metrics)}")
        if lpips_net not in ("alex", "vgg", None):
            raise InputError(f"lpips_net must be alex or vgg, got {lpips_net!r}")
        self.metrics = tuple(metrics)
        self.data_range = check_data_range(data_range)
        self.device = device
        self.protocol = get_protocol(protocol)
        self.lpips_net = lpips_net or self.protocol.lpips_net
        check_lpips_net(self.protocol, self.lpips_net)
        self.pretrained_backbone = pretrained_backbone
        self._fns: dict[str, FrameFn] | None = None
        self._values: dict[str, list[float]] = {m: [] for m in self.metrics}

    def reset(self) -> None:
        """Forget every value seen so far."""
        self._values = {m: [] for m in self.metrics}

    def __len__(self) -> int:
        """Number of images scored since the last ``reset``."""
        return len(self._values[self.metrics[0]])

    @property
    def values(self) -> dict[str, list[float]]:
        """Per-image values so far, per metric (copies)."""
        return {m: list(v) for m, v in self._values.items()}

    def _functions(self, device: Any) -> dict[str, FrameFn]:
        """The registry's functions, built on first use (LPIPS needs the device of the data)."""
        if self._fns is None:
            from dynaeval.runtime import resolve_device

            ctx = FrameContext(data_range=self.data_range, protocol=self.protocol,
                               device=resolve_device(device), lpips_net=self.lpips_net,
                               pretrained_backbone=self.pretrained_backbone)
            self._fns = {s.name: s.load("build")(ctx) for s in frame_specs(self.metrics)}
        return self._fns

    def update(self, pred: Any, gt: Any) -> dict[str, list[float]]:
        """Score every image of a batch and keep the values.

        Args:
            pred, gt: torch tensors (B, C, H, W) / (C, H, W) on any device, or numpy arrays
                (B, H, W, C) / (H, W, C) / (H, W); float in [0, data_range]; equal shapes.

        Returns:
            This batch's per-image values, per metric.

        Raises:
            InputError: shapes differ or are not images, NaN/Inf pixels, LPIPS input outside
                [0, 1]. Nothing is kept from a batch that raised.
            WeightsUnavailableError: LPIPS asked for and its backbone weights are absent.
        """
        from dynaeval.metrics.pixel import quantize

        preds, gts = _images(pred, "pred"), _images(gt, "gt")
        if len(preds) != len(gts):
            raise InputError(f"pred has {len(preds)} images but gt has {len(gts)}")
        device = self.device
        if device is None and is_torch_tensor(pred):
            device = pred.device
        fns = self._functions(device)
        batch: dict[str, list[float]] = {m: [] for m in self.metrics}
        for p, g in zip(preds, gts, strict=True):
            if self.protocol.quantize != "none":
                p, g = quantize(p, self.protocol.quantize), quantize(g, self.protocol.quantize)
            for m in self.metrics:
                batch[m].append(float(fns[m](p, g, {})))
        for m, vals in batch.items():
            self._values[m].extend(vals)
        return batch

    def compute(self) -> dict[str, float]:
        """Mean of the per-image values of each metric (``math.inf`` for PSNR when an image
        equals its ground truth, as the mean is then infinite).

        Raises:
            InputError: ``update`` was never called (since the last ``reset``).
        """
        if len(self) == 0:
            raise InputError("no image scored yet: call update(pred, gt) before compute()")
        return {m: math.fsum(v) / len(v) for m, v in self._values.items()}

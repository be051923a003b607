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

With ``masked=True`` every ``update`` takes one mask per image and the means gain the keys
``dynaeval score --masks`` writes: ``masked_*`` and the protocol's own masked numbers (DyCheck's
``mpsnr``, ``mssim``, ``mlpips``; NeRFBaselines' whole-frame metrics of the masked images).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dynaeval.core.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.core.runtime import resolve_device
from dynaeval.core.validation import (
    channel_first_hint,
    check_data_range,
    check_finite_image,
    check_pair,
    check_unit_range,
    is_torch_tensor,
    to_numpy,
    values_known_in,
)
from dynaeval.io.masks import THRESHOLD
from dynaeval.metrics.protocols import get_protocol
from dynaeval.metrics.registry import (
    FrameContext,
    FrameFn,
    call_hook,
    cannot_run,
    default_frame_metrics,
    frame_specs,
    region_argument,
    spec,
)

SUPPORTED = tuple(s.name for s in frame_specs())
"""Names ``ImageMetrics`` accepts: every per-frame metric of the registry."""


def _images(x: Any, name: str) -> list[np.ndarray]:
    """A batch as a list of (H, W, C) float arrays.

    Torch tensors: (B, C, H, W) or (C, H, W), channel first, C in {1, 3}; numpy arrays:
    (B, H, W, C), (H, W, C) or (H, W), channel last. Dtypes are kept (floats as float32) for
    ``check_pair``'s range rule: integers are never read as [0, 1].
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
        t = x.detach()
        arr = (t.float() if t.is_floating_point() else t).cpu().numpy().transpose(0, 2, 3, 1)
        return list(arr)
    arr = np.asarray(x)
    if arr.ndim in (2, 3):
        return [arr]
    if arr.ndim == 4 and channel_first_hint(arr.shape) is not None:
        raise InputError(f"{name}: numpy batches are channel-last (B, H, W, C), got shape "
                         f"{arr.shape}, which looks channel-first (B, C, H, W): pass "
                         "np.moveaxis(x, 1, -1), or a torch tensor (taken as (B, C, H, W))")
    if arr.ndim == 4:
        return list(arr)
    raise InputError(f"{name}: numpy images must be (B, H, W, C), (H, W, C) or (H, W), got shape "
                     f"{arr.shape}")


def _masks(x: Any, n: int, shape: tuple[int, int]) -> list[np.ndarray]:
    """A batch's masks as ``n`` (H, W) float32 weights in [0, 1]: (B, H, W), (B, 1, H, W),
    (H, W) or (1, H, W), bool, integer 0/1 or float, numpy or torch.

    Raises:
        InputError: another shape, size or count, NaN, or values outside [0, 1].
    """
    if x is None:
        raise InputError("masked=True: update(pred, gt, mask) needs a mask per image")
    arr = np.asarray(x.detach().cpu().numpy() if is_torch_tensor(x) else x)
    arr = (arr if arr.dtype == bool else to_numpy(arr, "mask")).astype(np.float32)
    if arr.ndim == 4 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[0] != n or arr.shape[1:] != shape:
        raise InputError(f"mask: expected {n} mask(s) of the images' size (B, H, W) = "
                         f"({n}, {shape[0]}, {shape[1]}), got shape {np.shape(x)}")
    check_finite_image(arr, "mask")
    check_unit_range(arr, "mask")
    return list(arr)


class _Regions:
    """One image's regions for ``region_argument``: the mask's weights and, from them,
    dynaeval's masked region (weight > ``dynaeval.io.masks.THRESHOLD``)."""

    boxes = None

    def __init__(self, weights: np.ndarray | None) -> None:
        self.weights = weights
        self.mask = None if weights is None else weights > THRESHOLD


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
        masked: every ``update`` takes a mask per image (weights in [0, 1]), and the keys
            ``dynaeval score --masks`` adds are kept: ``masked_<metric>`` over the pixels of
            weight > 0.5, and the protocol's: ``m<metric>`` under ``dycheck`` (its covisible
            reduction over the weights), the whole-frame keys of the mask-multiplied images
            under ``nerfbaselines``. An image whose mask holds no pixel above 0.5 has no
            ``masked_*`` value (left out of the mean, as ``dynaeval score`` does).

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
        masked: bool = False,
    ) -> None:
        metrics = (get_protocol(protocol).run_metrics(default_frame_metrics()) if metrics is None
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
        self.lpips_net = self.protocol.resolve_lpips_net(lpips_net)
        self.protocol.check_lpips_net(self.lpips_net)
        self.pretrained_backbone = pretrained_backbone
        self.masked = bool(masked)
        regions = (("whole", "masked", *self.protocol.mask_regions()) if self.masked
                   else ("whole",))
        self.keys: tuple[tuple[str, str, str], ...] = tuple(
            (spec(m).key(r), m, r) for r in regions for m in self.metrics if r in spec(m).regions)
        """(result key, metric, region variant) of every value kept, in report order."""
        self._fns: dict[str, FrameFn] | None = None
        self._values: dict[str, list[float | None]] = {k: [] for k, _, _ in self.keys}
        self._count = 0
        if pretrained_backbone:
            self._check_available()

    def _check_available(self) -> None:
        """Refuse, at construction, a metric that cannot run on this machine (LPIPS without its
        backbone weights): it failed at the first ``update``, naming the CLI's ``--no-lpips``.
        The message gives the library's fix, the metrics without it."""
        ctx = FrameContext(data_range=self.data_range, protocol=self.protocol, device="cpu",
                           lpips_net=self.lpips_net, pretrained_backbone=True)
        for s in frame_specs(self.metrics):
            why = cannot_run(s, ctx)
            if why:
                keep = tuple(m for m in self.metrics if m != s.name)
                fix = f"ImageMetrics(metrics={keep!r})" if keep else "another metric"
                raise InputError(f"{s.title} cannot run here: {why}; or leave it out: {fix}")

    def reset(self) -> None:
        """Forget every value seen so far."""
        self._values = {k: [] for k, _, _ in self.keys}
        self._count = 0

    def __len__(self) -> int:
        """Number of images scored since the last ``reset``."""
        return self._count

    @property
    def values(self) -> dict[str, list[float | None]]:
        """Per-image values so far, per result key (copies; None where a masked value is
        undefined)."""
        return {k: list(v) for k, v in self._values.items()}

    def _functions(self, device: Any) -> dict[str, FrameFn]:
        """The registry's functions, built on first use (LPIPS needs the device of the data)."""
        if self._fns is None:
            ctx = FrameContext(data_range=self.data_range, protocol=self.protocol,
                               device=resolve_device(device), lpips_net=self.lpips_net,
                               pretrained_backbone=self.pretrained_backbone)
            self._fns = {s.name: call_hook(s, "build", ctx) for s in frame_specs(self.metrics)}
        return self._fns

    def update(self, pred: Any, gt: Any, mask: Any = None) -> dict[str, list[float | None]]:
        """Score every image of a batch and keep the values.

        Args:
            pred, gt: torch tensors (B, C, H, W) / (C, H, W) on any device, or numpy arrays
                (B, H, W, C) / (H, W, C) / (H, W); float in [0, data_range], or integers with
                ``data_range`` set (255 for uint8); equal shapes.
            mask: with ``masked=True`` only (and then required): one mask per image, (B, H, W),
                (B, 1, H, W) or (H, W), bool or weights in [0, 1], numpy or torch.

        Returns:
            This batch's per-image values, per result key.

        Raises:
            InputError: shapes differ or are not images (a channel-first numpy batch), values
                outside [0, data_range] (0..255 images with data_range=1: pass data_range=255
                or x / 255; under a protocol that clips, overshoots up to twice the range
                pass: validation.CLIPPED_LIMIT), NaN/Inf pixels,
                LPIPS input outside [0, 1], a mask missing, given without ``masked=True``, or
                not of the images' size. Nothing is kept from a batch that raised.
            WeightsUnavailableError: LPIPS asked for and its backbone weights are absent.
        """
        preds, gts = _images(pred, "pred"), _images(gt, "gt")
        if len(preds) != len(gts):
            raise InputError(f"pred has {len(preds)} images but gt has {len(gts)}")
        # every image checked once (shape, layout, values in [0, data_range]) before any is
        # scored; a protocol that clips (or quantises: clips, then 8 bit) takes floats outside
        clipped = self.protocol.clips_images()
        checked = [check_pair(p, g, data_range=self.data_range, clipped=clipped)
                   for p, g in zip(preds, gts, strict=True)]
        preds, gts = [p for p, _ in checked], [g for _, g in checked]
        if mask is not None and not self.masked:
            raise InputError("a mask was given to an ImageMetrics made without masked=True")
        weights = (_masks(mask, len(gts), gts[0].shape[:2]) if self.masked
                   else [None] * len(gts))
        device = self.device
        if device is None and is_torch_tensor(pred):
            device = pred.device
        fns = self._functions(device)
        with values_known_in(self.data_range):
            batch = self._score_batch(fns, preds, gts, weights)
        for k, vals in batch.items():
            self._values[k].extend(vals)
        self._count += len(gts)
        return batch

    def _score_batch(self, fns: dict[str, FrameFn], preds: list[np.ndarray],
                     gts: list[np.ndarray], weights: list) -> dict[str, list[float | None]]:
        """Every kept value of checked images, per result key."""
        batch: dict[str, list[float | None]] = {k: [] for k, _, _ in self.keys}
        for p, g, w in zip(preds, gts, weights, strict=True):
            p, g = self.protocol.prepare_images(p, g)
            regions = _Regions(w)
            for key, m, region in self.keys:
                batch[key].append(self._value(fns[m], p, g, region_argument(
                    region, key, self.protocol, regions), region))
        return batch

    @staticmethod
    def _value(fn: FrameFn, p: np.ndarray, g: np.ndarray, region: dict | None,
               variant: str) -> float | None:
        """One value; None where ``dynaeval score`` writes null for a mask (no pixel in it)."""
        if variant == "whole":
            return float(fn(p, g, region))
        if variant == "masked" and not region["mask"].any():
            return None
        try:
            return float(fn(p, g, region))
        except (EmptyRegionError, UndefinedMetricError):
            return None

    def compute(self) -> dict[str, float | None]:
        """Mean of the per-image values of each result key (``math.inf`` for PSNR when an image
        equals its ground truth, as the mean is then infinite); a masked key's mean is over the
        images where it is defined (None when it is nowhere).

        Raises:
            InputError: ``update`` was never called (since the last ``reset``).
        """
        if len(self) == 0:
            raise InputError("no image scored yet: call update(pred, gt) before compute()")
        out: dict[str, float | None] = {}
        for k, v in self._values.items():
            kept = [x for x in v if x is not None]
            out[k] = math.fsum(kept) / len(kept) if kept else None
        return out

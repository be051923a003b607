"""A thin accumulator over the metric functions, for training and validation loops.

The functions stay pure; ``MetricMeter`` only keeps the per-frame values and reports their mean
(the number NeRF tables report) next to the pooled PSNR (the squared error summed over all frames
first, what torchmetrics' ``PeakSignalNoiseRatio`` class computes), so the two are never confused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from dynaeval.errors import InputError
from dynaeval.metrics.pixel import SquaredErrorStats, psnr_from_stats, squared_error_stats

_SUPPORTED = ("psnr", "ssim", "lpips")


@dataclass
class MetricMeter:
    """Accumulates per-frame PSNR / SSIM / LPIPS over a loop; ``compute()`` gives their means.

    Example::

        meter = MetricMeter(("psnr", "ssim"))
        for pred, gt in frames:
            meter.update(pred, gt)       # per-frame values, also returned
        meter.compute()  # {"psnr": mean of per-frame PSNRs, "ssim": ..., "psnr_pooled": ...}
    """

    metrics: tuple[str, ...] = ("psnr", "ssim")
    """Metric names among ``psnr``, ``ssim``, ``lpips`` (evaluated in this order per frame)."""
    data_range: float = 1.0
    """Peak value L passed to PSNR and SSIM (explicit, never inferred)."""
    lpips_kwargs: dict[str, Any] = field(default_factory=dict)
    """Extra keyword arguments for ``lpips`` (``net``, ``device``, ``pretrained_backbone``...)."""
    values: dict[str, list[float]] = field(default_factory=dict, init=False)
    """Per-frame values so far, one list per metric."""
    pooled: SquaredErrorStats = field(default=SquaredErrorStats(0.0, 0), init=False)
    """Sum of squared errors and value count over all frames so far."""

    def __post_init__(self) -> None:
        unknown = [m for m in self.metrics if m not in _SUPPORTED]
        if unknown or not self.metrics:
            raise InputError(f"MetricMeter metrics must be among {_SUPPORTED}, got {self.metrics!r}")
        self.reset()

    def reset(self) -> None:
        """Forget every frame."""
        self.values = {m: [] for m in self.metrics}
        self.pooled = SquaredErrorStats(0.0, 0)

    def update(self, pred: object, gt: object, *, mask: object = None, boxes: object = None) -> dict[str, float]:
        """Score one frame (arguments as for ``psnr``/``ssim``/``lpips``); return its values."""
        from dynaeval import metrics as M

        row: dict[str, float] = {}
        for name in self.metrics:
            if name == "psnr":
                stats = squared_error_stats(pred, gt, mask=mask, boxes=boxes)
                row[name] = psnr_from_stats(stats, data_range=self.data_range)
            elif name == "ssim":
                row[name] = M.ssim(pred, gt, data_range=self.data_range, mask=mask, boxes=boxes)
            else:
                row[name] = M.lpips(pred, gt, mask=mask, boxes=boxes, **self.lpips_kwargs)
        # commit only once every metric of the frame succeeded
        if "psnr" in self.metrics:
            self.pooled = self.pooled + stats
        for name, value in row.items():
            self.values[name].append(value)
        return row

    def compute(self) -> dict[str, float]:
        """Mean over frames of each metric, plus ``psnr_pooled`` when PSNR is tracked.

        A frame with identical images has PSNR ``inf``, so the PSNR mean is then ``inf`` too
        (the results layer writes it as null with a reason). Raises InputError before any frame.
        """
        n = len(self.values[self.metrics[0]])
        if n == 0:
            raise InputError("MetricMeter.compute() before any update(): no frame to average")
        out = {name: math.fsum(vals) / n if not any(map(math.isinf, vals)) else math.inf
               for name, vals in self.values.items()}
        if "psnr" in self.metrics:
            out["psnr_pooled"] = psnr_from_stats(self.pooled, data_range=self.data_range)
        return out

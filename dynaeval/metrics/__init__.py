"""Image metrics as pure functions on (H, W[, C]) arrays/tensors: PSNR, SSIM, LPIPS, focused, masked.

Importing this package does not import torch: LPIPS imports it on first call.
"""

from dynaeval.metrics.accumulate import ImageMetrics
from dynaeval.metrics.focused import (
    focused_lpips,
    focused_psnr,
    focused_ssim,
    masked_lpips,
    masked_psnr,
    masked_ssim,
)
from dynaeval.metrics.perceptual import (
    LPIPS_BACKENDS,
    backbone_weights_file,
    load_lpips,
    load_lpips_onnx,
    lpips,
    lpips_map,
)
from dynaeval.metrics.pixel import (
    SquaredErrorStats,
    psnr,
    psnr_from_stats,
    quantize,
    squared_error_stats,
)
from dynaeval.metrics.presence import frame_presence
from dynaeval.metrics.registry import METRICS, MetricInfo
from dynaeval.metrics.structural import ssim, ssim_map, ssim_reference

__all__ = [
    "LPIPS_BACKENDS",
    "ImageMetrics",
    "METRICS",
    "MetricInfo",
    "SquaredErrorStats",
    "backbone_weights_file",
    "focused_lpips",
    "focused_psnr",
    "frame_presence",
    "focused_ssim",
    "load_lpips",
    "load_lpips_onnx",
    "lpips",
    "lpips_map",
    "masked_lpips",
    "masked_psnr",
    "masked_ssim",
    "psnr",
    "psnr_from_stats",
    "quantize",
    "squared_error_stats",
    "ssim",
    "ssim_map",
    "ssim_reference",
]

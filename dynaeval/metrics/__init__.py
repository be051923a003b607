"""Metrics as pure functions on (H, W[, C]) arrays/tensors: PSNR, SSIM, LPIPS, focused, masked,
temporal, presence; ``registry`` declares every one of them (``SPECS``, ``METRICS``).

Importing this package does not import torch: LPIPS imports it on first call.
"""

from dynaeval.metrics.accumulate import ImageMetrics
from dynaeval.metrics.flow import FlowCache, FlowConfig, optical_flow, valid_warp_mask, warp
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
from dynaeval.metrics.registry import METRICS, SPECS, MetricInfo, MetricSpec, result_key
from dynaeval.metrics.structural import ssim, ssim_map, ssim_reference
from dynaeval.metrics.temporal import (
    TemporalConfig,
    flicker,
    temporal_metrics,
    tlp,
    tof,
    warping_error,
)

__all__ = [
    "FlowCache",
    "FlowConfig",
    "ImageMetrics",
    "LPIPS_BACKENDS",
    "METRICS",
    "MetricInfo",
    "MetricSpec",
    "SPECS",
    "SquaredErrorStats",
    "TemporalConfig",
    "backbone_weights_file",
    "flicker",
    "focused_lpips",
    "focused_psnr",
    "focused_ssim",
    "frame_presence",
    "load_lpips",
    "load_lpips_onnx",
    "lpips",
    "lpips_map",
    "masked_lpips",
    "masked_psnr",
    "masked_ssim",
    "optical_flow",
    "psnr",
    "psnr_from_stats",
    "quantize",
    "result_key",
    "squared_error_stats",
    "ssim",
    "ssim_map",
    "ssim_reference",
    "temporal_metrics",
    "tlp",
    "tof",
    "valid_warp_mask",
    "warp",
    "warping_error",
]

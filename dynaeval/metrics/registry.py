"""One registry of every metric name dynaeval reports: direction, range, unit, meaning.

The results, tables and plots look metrics up here (e.g. to sort a leaderboard or to say "higher is
better"); a name in the results that is not here is a bug.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class MetricInfo:
    """What one reported number means."""

    name: str
    """Key in the results (``frames[i][name]``, ``summary[name]``)."""
    higher_is_better: bool
    """True for PSNR/SSIM, False for LPIPS and the temporal errors."""
    range: tuple[float, float]
    """Possible values (lo, hi); ``math.inf`` where unbounded (PSNR of identical images is inf)."""
    unit: str
    """Unit of the value ("dB", "" for unitless)."""
    description: str
    """One line: what is measured and over which pixels."""

    @property
    def direction(self) -> str:
        """``"higher"`` or ``"lower"`` (is better)."""
        return "higher" if self.higher_is_better else "lower"


def _info(name: str, higher: bool, rng: tuple[float, float], unit: str, desc: str) -> MetricInfo:
    return MetricInfo(name, higher, rng, unit, desc)


_BASE = {
    "psnr": (True, (0.0, math.inf), "dB", "peak signal-to-noise ratio, 10 log10(L^2 / MSE), float64 MSE"),
    "ssim": (True, (-1.0, 1.0), "", "SSIM (Wang et al. 2004), Gaussian window 11, sigma 1.5, valid windows"),
    "lpips": (False, (0.0, math.inf), "", "LPIPS v0.1 of the lpips package, AlexNet backbone"),
}
_REGIONS = {
    "": "whole frame",
    "focused_": "boxes around players and ball (PSNR: union of boxes; SSIM/LPIPS: area-weighted crops)",
    "masked_": "moving pixels of the motion mask (PSNR: those pixels; SSIM/LPIPS: map mean over them)",
}

METRICS: dict[str, MetricInfo] = {}
for _prefix, _where in _REGIONS.items():
    for _base, (_higher, _rng, _unit, _desc) in _BASE.items():
        _name = _prefix + _base
        METRICS[_name] = _info(_name, _higher, _rng, _unit, f"{_desc}; over the {_where}")
for _net, _netname in (("alex", "AlexNet"), ("vgg", "VGG16")):
    METRICS[f"lpips_{_net}"] = _info(
        f"lpips_{_net}", False, (0.0, math.inf), "", f"LPIPS v0.1 of the lpips package, {_netname} backbone; whole frame"
    )
# Temporal terms (defined in dynaeval.metrics.temporal): all errors, lower is better.
METRICS.update(
    {
        "warp_error": _info("warp_error", False, (0.0, math.inf), "", "error between a frame and the previous one warped by GT optical flow"),
        "tof": _info("tof", False, (0.0, math.inf), "", "tOF: difference of the optical flow of prediction and ground truth"),
        "tlp": _info("tlp", False, (0.0, math.inf), "", "tLP: difference of LPIPS between consecutive frames, prediction vs ground truth"),
        "flicker": _info("flicker", False, (0.0, math.inf), "", "temporal flicker of static pixels compared with the ground truth"),
    }
)
# Object presence (defined in dynaeval.metrics.presence): per frame, over the ground-truth objects.
for _cls in ("person", "ball"):
    METRICS[f"presence_{_cls}"] = _info(
        f"presence_{_cls}", True, (0.0, 1.0), "",
        f"fraction of the frame's ground-truth {_cls} objects the prediction shows (tight-box NCC "
        "and PSNR against calibrated thresholds, plus the detector when it made the boxes)")
    METRICS[f"tight_psnr_{_cls}"] = _info(
        f"tight_psnr_{_cls}", True, (0.0, math.inf), "dB",
        f"PSNR over the union of the {_cls} objects' tight boxes (raw boxes grown by the presence "
        "margin, not the expanded focus boxes)")

"""kplanes_agreement.py: max |difference| of --protocol kplanes against its sources on photos.

The table of docs/protocols.md (section kplanes). Run from the repository root:
``PYTHONPATH=. python tools/kplanes_agreement.py`` (needs torch, torchmetrics, scipy, scikit-image;
~2 min on 2 cores: torchmetrics' MS-SSIM is the slow part). Pairs: scikit-image's astronaut
(301x387), coffee (207x389) and chelsea (299x451), each with Gaussian noise (sigma 0.05), a blur
(sigma 2) and a 3-px shift, rounded to 8-bit levels (``tests/dynaeval/metrics/
test_protocol_kplanes.py``, whose float64 re-implementation of K-Planes' SSIM is used here).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torchmetrics.functional.image import multiscale_structural_similarity_index_measure as tm_f
from torchmetrics.image import MultiScaleStructuralSimilarityIndexMeasure

from dynaeval.metrics import ssim as dynaeval_ssim
from dynaeval.metrics.multiscale import d_ssim, ms_ssim
from dynaeval.metrics.protocols import get_protocol
from tests.dynaeval.metrics.test_protocol_kplanes import _photo_pairs, kplanes_ssim_reference


def _t(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(a)).permute(2, 0, 1)[None]


def main() -> None:
    proto = get_protocol("kplanes")
    module = MultiScaleStructuralSimilarityIndexMeasure(data_range=1.0)  # K-Planes' object
    rows: dict[str, list[float]] = {k: [] for k in (
        "psnr", "ssim", "ssim_vs_dynaeval", "msssim_f32", "msssim_f64", "dssim")}
    for _, pred, gt in _photo_pairs():
        mse = torch.mean((torch.from_numpy(pred) - torch.from_numpy(gt)) ** 2).item()
        rows["psnr"].append(abs(proto.whole_psnr(pred, gt) - 10 * math.log10(1 / mse)))
        ours = proto.whole_ssim(pred, gt)
        rows["ssim"].append(abs(ours - kplanes_ssim_reference(pred, gt)))
        rows["ssim_vs_dynaeval"].append(abs(ours - dynaeval_ssim(pred, gt)))
        ref32 = module(_t(pred), _t(gt)).item()
        ref64 = tm_f(_t(pred.astype(np.float64)), _t(gt.astype(np.float64)), data_range=1.0).item()
        rows["msssim_f32"].append(abs(ms_ssim(pred, gt) - ref32))
        rows["msssim_f64"].append(abs(ms_ssim(pred, gt) - ref64))
        rows["dssim"].append(abs(d_ssim(pred, gt) - (1 - ref32) / 2))
    for name, values in rows.items():
        print(f"{name:18s} max |diff| {max(values):.2e}  over {len(values)} pairs")


if __name__ == "__main__":
    main()

"""Max |difference| of --protocol 3dgs / nerfstudio / nerfstudio-splatfacto against their sources
on scikit-image's photographs at odd sizes (the pairs of tests/dynaeval/metrics/test_protocol_3dgs.py).

    TORCH_HOME=/work/golden/torch PYTHONPATH=. python tools/protocol_diffs_3dgs.py

Prints the Markdown table of docs/protocols.md. LPIPS rows need a (random-weight) vgg16
checkpoint in $TORCH_HOME/hub/checkpoints.
"""

from __future__ import annotations

import torch
from pytorch_msssim import SSIM
from pytorch_msssim import ssim as msssim
from torchmetrics.functional.image import peak_signal_noise_ratio as tm_psnr
from torchmetrics.functional.image import structural_similarity_index_measure as tm_ssim

from dynaeval.metrics.protocol_3dgs import lpips_unit_input
from dynaeval.metrics.protocols import get_protocol
from tests.dynaeval.metrics.test_protocol_3dgs import PAIRS, gs_psnr, gs_ssim, nchw


def rows():
    g3, ns, sp = (get_protocol(n) for n in ("3dgs", "nerfstudio", "nerfstudio-splatfacto"))
    f64 = torch.float64
    yield "3dgs SSIM", "their torch code, float32", lambda p, g: (g3.whole_ssim(p, g), gs_ssim(p, g, torch.float32))
    yield "3dgs SSIM", "their torch code, float64", lambda p, g: (g3.whole_ssim(p, g), gs_ssim(p, g, f64))
    yield "3dgs PSNR", "their torch code, float32", lambda p, g: (g3.whole_psnr(p, g), gs_psnr(p, g, torch.float32))
    yield "3dgs PSNR", "their torch code, float64", lambda p, g: (g3.whole_psnr(p, g), gs_psnr(p, g, f64))
    yield "nerfstudio SSIM", "torchmetrics 1.9, no data_range", lambda p, g: (ns.whole_ssim(p, g), float(tm_ssim(nchw(g), nchw(p))))
    yield "nerfstudio PSNR", "torchmetrics 1.9, data_range=1", lambda p, g: (ns.whole_psnr(p, g), float(tm_psnr(nchw(g), nchw(p), data_range=1.0)))
    yield "(before: SSIM with data_range=1)", "torchmetrics 1.9, no data_range", lambda p, g: (float(tm_ssim(nchw(g), nchw(p), data_range=1.0)), float(tm_ssim(nchw(g), nchw(p))))
    yield "nerfstudio-splatfacto SSIM", "pytorch_msssim 1.0 SSIM(data_range=1)", lambda p, g: (sp.whole_ssim(p, g), float(SSIM(data_range=1.0, channel=3)(nchw(g), nchw(p))))
    yield "nerfstudio-splatfacto SSIM", "pytorch_msssim 1.0, float64", lambda p, g: (sp.whole_ssim(p, g), float(msssim(nchw(g, f64), nchw(p, f64), data_range=1.0)))
    yield "3dgs LPIPS (random VGG)", "lpipsPyTorch re-implementation", _lpips


def _lpips(p, g):
    from pathlib import Path

    from tests.dynaeval.metrics.test_protocol_3dgs import LpipsPyTorch, checkpoint_features

    path = Path(torch.hub.get_dir()) / "checkpoints" / "vgg16-397923af.pth"
    with torch.no_grad():
        ref = float(LpipsPyTorch("vgg", checkpoint_features(path))(nchw(p), nchw(g)))
    return lpips_unit_input(p, g, net="vgg"), ref


def main() -> None:
    print("| dynaeval | against | max abs diff, all pairs | max on the range-0.6 renders |")
    print("|---|---|---|---|")
    for name, source, fn in rows():
        diffs = {n: abs(a - b) for n, p, g in PAIRS for a, b in [fn(p, g)]}
        dim = max(v for n, v in diffs.items() if n.endswith("-dim"))
        print(f"| {name} | {source} | {max(diffs.values()):.1e} | {dim:.1e} |")


if __name__ == "__main__":
    main()

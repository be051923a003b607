"""Max |difference| of --protocol 3dgs / 4dgaussians / nerfstudio / nerfstudio-splatfacto against
their sources on scikit-image's photographs at odd sizes (the pairs of
tests/dynaeval/metrics/test_protocol_3dgs.py), and 4dgaussians against 3dgs on the bundled sample.

    TORCH_HOME=/work/golden/torch PYTHONPATH=. python tools/protocol_diffs_3dgs.py
    PYTHONPATH=. python tools/protocol_diffs_3dgs.py --sample

Prints the Markdown tables of docs/protocols.md. The VGG LPIPS row needs a (random-weight) vgg16
checkpoint in $TORCH_HOME/hub/checkpoints (skipped without); the AlexNet rows and ``--sample``
use dynaeval's seeded random backbones (no weights can be downloaded here), so their LPIPS
differences show the input scaling, not the size of the pretrained networks' values.
"""

from __future__ import annotations

import sys

import numpy as np
import torch
from pytorch_msssim import SSIM, ms_ssim
from pytorch_msssim import ssim as msssim
from torchmetrics.functional.image import peak_signal_noise_ratio as tm_psnr
from torchmetrics.functional.image import structural_similarity_index_measure as tm_ssim

from dynaeval.metrics import perceptual
from dynaeval.metrics.multiscale import ms_ssim as torchmetrics_msssim
from dynaeval.metrics.protocol_3dgs import dssim_4dgaussians, lpips_unit_input, msssim_4dgaussians
from dynaeval.metrics.protocols import get_protocol
from tests.dynaeval.metrics.test_protocol_3dgs import (
    BIG_PAIRS,
    PAIRS,
    LpipsPyTorch,
    gs_psnr,
    gs_ssim,
    nchw,
    package_features,
)


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


def rows_4dgaussians():
    """(name, source, fn) on ``BIG_PAIRS`` (MS-SSIM needs 161 px)."""
    f64 = torch.float64
    theirs = lambda p, g, d=torch.float32: float(ms_ssim(nchw(p, d), nchw(g, d), data_range=1, size_average=True))  # noqa: E731
    yield "4dgaussians MS-SSIM", "pytorch_msssim 1.0 ms_ssim(data_range=1), float32", lambda p, g: (msssim_4dgaussians(p, g), theirs(p, g))
    yield "4dgaussians MS-SSIM", "pytorch_msssim 1.0, float64", lambda p, g: (msssim_4dgaussians(p, g), theirs(p, g, f64))
    yield "4dgaussians D-SSIM", "(1 - pytorch_msssim float32) / 2", lambda p, g: (dssim_4dgaussians(p, g), (1 - theirs(p, g)) / 2)
    yield "(before: `--protocol 3dgs --msssim`, torchmetrics' MS-SSIM)", "pytorch_msssim 1.0, float32", lambda p, g: (torchmetrics_msssim(p, g), theirs(p, g))
    alex = LpipsPyTorch("alex", package_features(perceptual.load_lpips("alex", pretrained_backbone=False)))
    yield "4dgaussians LPIPS-alex (random AlexNet)", "lpipsPyTorch re-implementation, float64", lambda p, g: (
        lpips_unit_input(p, g, net="alex", pretrained_backbone=False), float(alex(nchw(p), nchw(g))))


def _lpips(p, g):
    from pathlib import Path

    from tests.dynaeval.metrics.test_protocol_3dgs import LpipsPyTorch, checkpoint_features

    path = Path(torch.hub.get_dir()) / "checkpoints" / "vgg16-397923af.pth"
    with torch.no_grad():
        ref = float(LpipsPyTorch("vgg", checkpoint_features(path))(nchw(p), nchw(g)))
    return lpips_unit_input(p, g, net="vgg"), ref


def sample_table() -> None:
    """Per-frame max and mean |4dgaussians - 3dgs| on the bundled sample, at its size (144 px:
    no MS-SSIM under either) and upscaled 2x (bicubic, 288 x 512), LPIPS on random backbones."""
    import tempfile
    from pathlib import Path

    import cv2

    import dynaeval
    from dynaeval.cli import sample_dir
    from dynaeval.regions.focus import FocusConfig

    for name in ("load_lpips", "load_lpips_onnx"):  # seeded random backbones, real linear layers
        loader = getattr(perceptual, name)
        setattr(perceptual, name, lambda net="alex", _l=loader, **kw: _l(net, **{**kw, "pretrained_backbone": False}))
    import warnings

    warnings.simplefilter("ignore")  # the runs' own warnings (temporal off, sizes)
    kw = dict(temporal=False, progress=False, focus=FocusConfig(source="none", masked=False))
    metrics = ("psnr", "ssim", "lpips", "msssim", "dssim")
    print("| sample | metric | `4dgaussians` against | per-frame max abs diff | mean abs diff | summary diff |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp)
        for f in sample_dir().glob("*/*/*.png"):
            im = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
            out = big / f.relative_to(sample_dir())
            out.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(out), cv2.resize(im, (im.shape[1] * 2, im.shape[0] * 2), interpolation=cv2.INTER_CUBIC))
        for label, root in (("as shipped (144x256)", sample_dir()), ("2x (288x512)", big)):
            run = lambda root=root, **o: dynaeval.score(root / "pred", root / "gt", metrics=metrics, **kw, **o)  # noqa: E731
            g4, g3 = run(protocol="4dgaussians"), run(protocol="3dgs")
            a4, ours_alex = run(protocol="4dgaussians", lpips_net="alex"), run(protocol="dynaeval", lpips_net="alex")
            for metric, a, b, other in (("msssim", g4, g3, "`3dgs --msssim`"), ("dssim", g4, g3, "`3dgs --dssim`"),
                                        ("lpips", g4, g3, "`3dgs` (both VGG)"),
                                        ("lpips", a4, ours_alex, "`dynaeval --lpips-net alex` (LPIPS-alex)"),
                                        ("psnr", g4, g3, "`3dgs`"), ("ssim", g4, g3, "`3dgs`")):
                d = np.array([abs(x[metric] - y[metric]) for x, y in zip(a["frames"], b["frames"], strict=True)
                              if x.get(metric) is not None and y.get(metric) is not None])
                if not d.size:
                    print(f"| {label} | {metric} | {other} | undefined (null: under 161 px) | | |")
                    continue
                print(f"| {label} | {metric} | {other} | {d.max():.1e} | {d.mean():.1e} | "
                      f"{abs(a['summary'][metric] - b['summary'][metric]):.1e} |")


def main() -> None:
    if "--sample" in sys.argv[1:]:
        sample_table()
        return
    print("| dynaeval | against | max abs diff, all pairs | max on the range-0.6 renders |")
    print("|---|---|---|---|")
    for name, source, fn in rows():
        try:
            diffs = {n: abs(a - b) for n, p, g in PAIRS for a, b in [fn(p, g)]}
        except FileNotFoundError as err:  # the VGG checkpoint
            print(f"| {name} | {source} | skipped: {err.filename} | |")
            continue
        dim = max(v for n, v in diffs.items() if n.endswith("-dim"))
        print(f"| {name} | {source} | {max(diffs.values()):.1e} | {dim:.1e} |")
    for name, source, fn in rows_4dgaussians():
        diffs = [abs(a - b) for _, p, g in BIG_PAIRS if min(p.shape[:2]) >= 176 or "before" not in name
                 for a, b in [fn(p, g)]]  # torchmetrics' MS-SSIM needs 176 px
        print(f"| {name} | {source} | {max(diffs):.1e} ({len(diffs)} photo pairs) | — |")


if __name__ == "__main__":
    main()

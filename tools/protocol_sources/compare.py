"""Max |difference| of ``--protocol nerfbaselines`` / ``--protocol dycheck`` against the sources
themselves, on scikit-image photos at odd sizes with real-looking masks (docs/protocols.md).

    python tools/protocol_sources/compare.py --nerfbaselines-python NB_VENV/bin/python \\
        --jax-python JAX_VENV/bin/python --dycheck-src DYCHECK_CHECKOUT

NeRFBaselines 1.2.12 runs its own ``evaluation.evaluate`` on a render folder (16-bit PNG renders,
8-bit ground truth, ``mask/``; LPIPS stubbed: no torch in its venv); DyCheck's own jax
``compute_psnr``/``compute_ssim`` run on the same arrays dynaeval scores. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from dynaeval import score  # noqa: E402
from dynaeval.metrics.protocol_dycheck import dycheck_psnr, dycheck_ssim  # noqa: E402
from dynaeval.regions.focus import FocusConfig  # noqa: E402
from tests.dynaeval.mask_layouts import (  # noqa: E402
    PHOTOS,
    blob_mask,
    nerfbaselines_folder,
    photo_pair,
)

KW = dict(metrics=("psnr", "ssim"), temporal=False, progress=False, focus=FocusConfig("none"))


def nerfbaselines_per_image(python: str, run: Path) -> list[dict]:
    """NeRFBaselines' own ``evaluate`` (run by ``python``, its venv) on the render folder ``run``:
    its per-image metrics. Writes the ``info.json`` it needs (default protocol, sRGB) into
    ``run`` and its results beside it (``run.with_suffix(".json")``)."""
    (run / "info.json").write_text(json.dumps({"evaluation_protocol": "default",
                                               "render_dataset_metadata": {"color_space": "srgb"}}))
    out = run.with_suffix(".json")
    subprocess.run([python, str(ROOT / "tools/protocol_sources/nerfbaselines_eval.py"), str(run),
                    str(out)], check=True, capture_output=True)
    return json.loads(out.read_text())["per_image"]


def nerfbaselines_rows(python: str, tmp: Path) -> list[str]:
    run = nerfbaselines_folder(tmp / "nb")
    ref = nerfbaselines_per_image(python, run)
    ours = score(run, protocol="nerfbaselines", **KW)["frames"]
    plain = score(run, **KW)["frames"]
    rows = []
    for key in ("psnr", "ssim"):
        diff = max(abs(o[key] - r[key]) for o, r in zip(ours, ref, strict=True))
        gap = max(abs(p[key] - r[key]) for p, r in zip(plain, ref, strict=True))
        mgap = max(abs(p["masked_" + key] - r[key]) for p, r in zip(plain, ref, strict=True))
        nb_mean = np.mean([r[key] for r in ref])
        rows.append(f"| NeRFBaselines 1.2.12 `evaluate` (16-bit renders, `mask/`) | {key} | "
                    f"{nb_mean:.5f} | {diff:.1e} | {gap:.3g} | {mgap:.3g} |")
    return rows


def decode_rows(python: str, tmp: Path) -> list[str]:
    """The 16-bit decoding alone: NeRFBaselines without ``mask/`` against the Pillow rule and
    against the v / 65535 rule (dynaeval's reading, then the same truncation and float32 MSE)."""
    import shutil

    from dynaeval.io.images import read_image
    from dynaeval.metrics import quantize
    from dynaeval.metrics.protocols import psnr_float32

    run = nerfbaselines_folder(tmp / "nb16")
    shutil.rmtree(run / "mask")
    ref = nerfbaselines_per_image(python, run)
    ours = score(run, protocol="nerfbaselines", **KW)["frames"]
    old = [psnr_float32(*(quantize(read_image(f), "truncate") for f in (Path(o["pred"]), Path(o["gt"]))),
                        clip=True) for o in ours]
    diff = max(abs(o["psnr"] - r["psnr"]) for o, r in zip(ours, ref, strict=True))
    gap = max(abs(v - r["psnr"]) for v, r in zip(old, ref, strict=True))
    return [f"| NeRFBaselines 1.2.12 `evaluate` (16-bit renders, no `mask/`) | psnr | "
            f"{np.mean([r['psnr'] for r in ref]):.5f} | {diff:.1e} | {gap:.3g} (v / 65535 then "
            "truncation: the decoding alone) | |"]


def dycheck_rows(python: str, src: str, tmp: Path) -> list[str]:
    cases = {}
    for i, name in enumerate(PHOTOS):
        p, g = photo_pair(name, 20 + i)
        p8 = (p.astype(np.float32) * 255).clip(0, 255).astype(np.uint8).astype(np.float32) / 255
        m = blob_mask(*g.shape[:2])[..., None].astype(np.float32)
        cases.update({f"{name}/gt": g.astype(np.float32) / 255, f"{name}/pred": p8,
                      f"{name}/mask": m})
    np.savez(tmp / "cases.npz", **cases)
    subprocess.run([python, str(ROOT / "tools/protocol_sources/dycheck_jax.py"), src,
                    str(tmp / "cases.npz"), str(tmp / "dy.json")], check=True, capture_output=True)
    ref = json.loads((tmp / "dy.json").read_text())
    ours: dict[str, list[float]] = {k: [] for k in ("psnr", "ssim", "mpsnr", "mssim")}
    for name in PHOTOS:
        p, g, m = (cases[f"{name}/{k}"] for k in ("pred", "gt", "mask"))
        for key, fn in (("psnr", dycheck_psnr), ("ssim", dycheck_ssim)):
            ours[key].append(abs(fn(p, g) - ref[name][key]))
            ours["m" + key].append(abs(fn(p, g, weights=m) - ref[name]["m" + key]))
    return [f"| DyCheck `compute_{k.lstrip('m')}` (jax, float32){' with mask' if k[0] == 'm' else ''} "
            f"| {k} | {np.mean([ref[n][k] for n in PHOTOS]):.5f} | {max(ours[k]):.1e} | | |"
            for k in ours]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nerfbaselines-python")
    ap.add_argument("--jax-python")
    ap.add_argument("--dycheck-src")
    args = ap.parse_args()
    print("| source | metric | source's mean | max abs diff, dynaeval --protocol | "
          "max abs diff, dynaeval default whole | max abs diff, dynaeval default masked_ |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        if args.nerfbaselines_python:
            print("\n".join(nerfbaselines_rows(args.nerfbaselines_python, Path(tmp))))
            print("\n".join(decode_rows(args.nerfbaselines_python, Path(tmp))))
        if args.jax_python and args.dycheck_src:
            print("\n".join(dycheck_rows(args.jax_python, args.dycheck_src, Path(tmp))))


if __name__ == "__main__":
    main()

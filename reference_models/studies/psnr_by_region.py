"""Where a prediction's error is: PSNR over the stands, the pitch, the moving objects and the sky.

Is it the crowd texture (per-pixel random shirts, ``scenes.world.stand_albedo``) that caps a
reference model's whole-frame PSNR? The generator's depth and instance masks split every eval
view's pixels into

* ``objects``: an instance id in ``masks/`` (players, ball);
* ``sky``: depth 0;
* ``stands``: the static world above 0.4 m (stands, boards, goals: the boards are thin, so this
  is mostly crowd);
* ``pitch``: the static world below it;

and each region's PSNR is computed over all its pixels of all scored views (one MSE, 8-bit), with
its share of the pixels and of the whole-frame squared error::

    python -m reference_models.studies.psnr_by_region DATA RUN/pred [RUN2/pred ...]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

REGIONS = ("stands", "pitch", "objects", "sky")
STANDS_ABOVE_M = 0.4
"""Height (m) above which static world points count as stands."""


def region_labels(depth: np.ndarray, ids: np.ndarray, c2w: np.ndarray, fx: float, fy: float,
                  cx: float, cy: float) -> np.ndarray:
    """(H, W) int labels (index into ``REGIONS``) of one view from its z-depth (m, 0 = sky),
    instance ids and OpenGL camera-to-world (4, 4) with pinhole intrinsics (pixel centres +0.5)."""
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w] + 0.5
    cam = np.stack([(u - cx) / fx * depth, -(v - cy) / fy * depth, -depth], -1)
    height = cam @ c2w[:3, :3].T[:, 2] + c2w[2, 3]
    labels = np.where(height > STANDS_ABOVE_M, 0, 1)
    labels[depth <= 0] = 3
    labels[ids > 0] = 2
    return labels


def region_psnr(data: Path, pred: Path) -> dict[str, dict[str, float]]:
    """Per region: ``psnr`` (dB), ``pixel_share`` and ``error_share`` over the views in ``pred``."""
    import cv2

    frames = {f["file_path"]: f for f in json.loads((data / "transforms.json").read_text())["frames"]}
    sse, count = np.zeros(len(REGIONS)), np.zeros(len(REGIONS))
    files = sorted(pred.glob("*/*.png"))
    if not files:
        raise SystemExit(f"error: {pred}: no <camera>/<frame>.png predictions")
    for f in files:
        meta = frames.get(f"images/{f.parent.name}/{f.name}")
        if meta is None:
            raise SystemExit(f"error: {f}: no such view in {data / 'transforms.json'}")
        gt = cv2.imread(str(data / meta["file_path"]))[..., ::-1].astype(np.float64)
        got = cv2.imread(str(f))[..., ::-1].astype(np.float64)
        labels = region_labels(np.load(data / meta["depth_file_path"]),
                               cv2.imread(str(data / meta["instance_mask_path"]), cv2.IMREAD_UNCHANGED),
                               np.asarray(meta["transform_matrix"], np.float64),
                               meta["fl_x"], meta["fl_y"], meta["cx"], meta["cy"])
        err = ((got - gt) ** 2).sum(-1)
        for k in range(len(REGIONS)):
            sel = labels == k
            sse[k] += err[sel].sum()
            count[k] += 3 * sel.sum()
    total = sse.sum()
    return {name: {"psnr": (10 * math.log10(255.0 ** 2 * count[k] / sse[k]) if sse[k] else math.inf),
                   "pixel_share": count[k] / count.sum(),
                   "error_share": sse[k] / total if total else 0.0}
            for k, name in enumerate(REGIONS) if count[k]}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m reference_models.studies.psnr_by_region",
                                description=__doc__.split("\n")[0])
    p.add_argument("data", type=Path, help="the scene generator's folder (depth/, masks/)")
    p.add_argument("preds", type=Path, nargs="+", help="prediction folders <camera>/<frame>.png")
    args = p.parse_args(argv)
    print("| prediction | " + " | ".join(f"{r} PSNR (pixels, error)" for r in REGIONS) + " |")
    print("|---|" + "---|" * len(REGIONS))
    for pred in args.preds:
        res = region_psnr(args.data, pred)
        cells = [f"{res[r]['psnr']:.2f} ({100 * res[r]['pixel_share']:.0f} %, "
                 f"{100 * res[r]['error_share']:.0f} %)" if r in res else "—" for r in REGIONS]
        print(f"| {pred} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""How well can a grid of given cells per axis show the static world at all? The grid's ceiling.

A plane (or voxel) model cannot show detail finer than its cells. This study puts that bound in
numbers without training anything: every static pixel of an eval view is placed in the world
with the generator's exact depth, contracted like the models' grid coordinates
(``common.rays.contract`` with the model's scene box), and given the mean ground-truth colour of
all the view's pixels that fall into the same cell of a ``cells = (x, y, z)`` grid over the
contracted world — the ground truth box-filtered to the grid. The PSNR of that image against the
ground truth, per region (``psnr_by_region``: stands, pitch; objects and sky are kept exact),
is the best any model with that grid can do on those pixels::

    python -m reference_models.studies.grid_ceiling DATA --cells 256 256 256 --cells 832 832 192

A trained model's region PSNR (``psnr_by_region``) far below its grid's ceiling is under-trained;
one near it needs finer cells.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import torch

from reference_models.common.data import load_dataset
from reference_models.common.rays import contract
from reference_models.studies.psnr_by_region import REGIONS, region_labels

STATIC = (REGIONS.index("stands"), REGIONS.index("pitch"))


def world_points(depth: np.ndarray, c2w: np.ndarray, fx: float, fy: float, cx: float,
                 cy: float) -> np.ndarray:
    """(H, W, 3) float64 world points (metres) of a view's pixels from its z-depth (m)."""
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w] + 0.5
    cam = np.stack([(u - cx) / fx * depth, -(v - cy) / fy * depth, -depth], -1)
    return cam @ c2w[:3, :3].T + c2w[:3, 3]


def box_filtered(image: np.ndarray, points: np.ndarray, keep: np.ndarray, box: np.ndarray,
                 cells: tuple[int, int, int]) -> np.ndarray:
    """``image`` (H, W, 3) float64 with each ``keep`` pixel replaced by the mean colour of the
    kept pixels whose world ``points`` (H, W, 3) fall into its cell of the ``cells`` grid over
    the contracted world (``box``: the model's inner box (2, 3), metres)."""
    grid = contract(torch.as_tensor(points[keep]), torch.as_tensor(box, dtype=torch.float64)).numpy()
    n = np.asarray(cells)
    idx = np.clip(np.floor((grid + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)
    flat = (idx[:, 0] * n[1] + idx[:, 1]) * n[2] + idx[:, 2]
    _, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
    out = image.copy()
    colours = image[keep]
    means = np.stack([np.bincount(inverse, colours[:, c]) for c in range(3)], -1) / counts[:, None]
    out[keep] = means[inverse]
    return out


def grid_ceiling(data: Path, cells: tuple[int, int, int], camera: str | None = None
                 ) -> dict[str, float]:
    """PSNR (dB) of the box-filtered ground truth per static region and over the whole frame,
    over every eval view of ``data`` (or every view of ``camera``)."""
    import cv2

    box = load_dataset(data).box.astype(np.float64)
    meta = json.loads((data / "transforms.json").read_text())
    names = set(meta.get("eval_cameras", [])) if camera is None else {camera}
    sse, count = {k: 0.0 for k in (*STATIC, "whole")}, {k: 0 for k in (*STATIC, "whole")}
    for f in meta["frames"]:
        if f.get("camera") not in names:
            continue
        gt = cv2.imread(str(data / f["file_path"]))[..., ::-1].astype(np.float64)
        depth = np.load(data / f["depth_file_path"])
        c2w = np.asarray(f["transform_matrix"], np.float64)
        labels = region_labels(depth, cv2.imread(str(data / f["instance_mask_path"]),
                                                 cv2.IMREAD_UNCHANGED),
                               c2w, f["fl_x"], f["fl_y"], f["cx"], f["cy"])
        keep = np.isin(labels, STATIC)
        filtered = box_filtered(gt, world_points(depth, c2w, f["fl_x"], f["fl_y"], f["cx"], f["cy"]),
                                keep, box, cells)
        err = np.round(filtered) - gt  # an 8-bit image, as a model's render
        for k in STATIC:
            sse[k] += float((err[labels == k] ** 2).sum())
            count[k] += 3 * int((labels == k).sum())
        sse["whole"] += float((err ** 2).sum())
        count["whole"] += err.size
    if not count["whole"]:
        raise SystemExit(f"error: {data}: no views of {sorted(names)} in transforms.json")

    def db(k: str | int) -> float:
        return 10 * math.log10(255.0 ** 2 * count[k] / sse[k]) if sse[k] else math.inf

    return {"stands": db(STATIC[0]), "pitch": db(STATIC[1]), "whole": db("whole")}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m reference_models.studies.grid_ceiling",
                                description=__doc__.split("\n")[0])
    p.add_argument("data", type=Path, help="the scene generator's folder (depth/, masks/)")
    p.add_argument("--cells", type=int, nargs=3, action="append", metavar=("X", "Y", "Z"),
                   required=True, help="cells per axis over the contracted world (repeatable)")
    p.add_argument("--camera", help="views of this camera (default: the eval cameras)")
    args = p.parse_args(argv)
    print("| cells (x, y, z) | stands PSNR | pitch PSNR | whole-frame PSNR |")
    print("|---|---|---|---|")
    def fmt(v: float) -> str:
        return "exact" if math.isinf(v) else f"{v:.2f}"  # no two pixels share a cell

    for cells in args.cells:
        res = grid_ceiling(args.data, tuple(cells), args.camera)
        print(f"| {' x '.join(map(str, cells))} | {fmt(res['stands'])} | {fmt(res['pitch'])} | "
              f"{fmt(res['whole'])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

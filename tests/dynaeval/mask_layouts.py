"""Render folders with masks, from scikit-image photos at odd sizes: a NeRFBaselines render folder
(16-bit PNG renders, 8-bit ground truth, ``mask/``) and a DyCheck dataset (``rgb/2x/``,
``covisible/2x/val/``) with a predictions folder."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

PHOTOS = {"astronaut": (301, 257), "coffee": (211, 333), "chelsea": (187, 251)}


def photo_pair(name: str, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(prediction in [0, 1] float64, ground truth uint8) of a cropped scikit-image photo."""
    from skimage import data

    h, w = PHOTOS[name]
    img = getattr(data, name)()[:h, :w]
    g = img.astype(np.float64) / 255
    rng = np.random.default_rng(seed)
    p = np.clip(cv2.GaussianBlur(g, (5, 5), 1.2) + rng.normal(0, 0.03, g.shape), 0, 1)
    return p, img


def blob_mask(h: int, w: int) -> np.ndarray:
    """A real-looking (H, W) bool mask: an ellipse with a hole and a ragged edge, plus a patch."""
    yy, xx = np.mgrid[:h, :w]
    m = (xx - w * 0.55) ** 2 / (w * 0.3) ** 2 + (yy - h * 0.45) ** 2 / (h * 0.35) ** 2 < 1
    m &= ~((np.abs(xx - w * 0.5) < w * 0.05) & (np.abs(yy - h * 0.4) < h * 0.06))
    m |= (xx < w * 0.15) & (yy > h * 0.75)
    return m & ((xx + 3 * np.sin(yy / 4.0)) > 6)


def write16(path: Path, rgb: np.ndarray) -> None:
    cv2.imwrite(str(path), np.round(rgb[..., ::-1] * 65535).astype(np.uint16))


def nerfbaselines_folder(root: Path) -> Path:
    """``root/color`` (16-bit), ``root/gt-color`` (8-bit), ``root/mask`` (8-bit grey)."""
    for d in ("color", "gt-color", "mask"):
        (root / d).mkdir(parents=True)
    for i, name in enumerate(PHOTOS):
        p, g = photo_pair(name, i)
        write16(root / "color" / f"{i:05d}.png", p)
        cv2.imwrite(str(root / "gt-color" / f"{i:05d}.png"), g[..., ::-1])
        cv2.imwrite(str(root / "mask" / f"{i:05d}.png"), blob_mask(*g.shape[:2]).astype(np.uint8) * 255)
    return root


def dycheck_dataset(root: Path) -> tuple[Path, Path]:
    """A DyCheck iPhone-style dataset ``root/data``: ``rgb/2x/`` with training frames
    ``0_0000i.png`` and validation frames ``1_0000i.png``, ``splits/{train,val}.json``,
    ``covisible/2x/val/1_0000i.png``; and predictions of the val frames ``root/pred`` (16-bit
    PNG renders). Returns (predictions folder, ground-truth folder)."""
    import json

    data = root / "data"
    gt_dir, cov, pred = data / "rgb" / "2x", data / "covisible" / "2x" / "val", root / "pred"
    for d in (gt_dir, cov, pred, data / "splits"):
        d.mkdir(parents=True)
    splits: dict[str, list[str]] = {"train": [], "val": []}
    for i, name in enumerate(PHOTOS):
        p, g = photo_pair(name, 10 + i)
        train, frame = f"0_{i:05d}", f"1_{i:05d}"
        cv2.imwrite(str(gt_dir / f"{train}.png"), g[::-1, :, ::-1])  # another view
        cv2.imwrite(str(gt_dir / f"{frame}.png"), g[..., ::-1])
        cv2.imwrite(str(cov / f"{frame}.png"), blob_mask(*g.shape[:2]).astype(np.uint8) * 255)
        write16(pred / f"{frame}.png", p)
        splits["train"].append(train)
        splits["val"].append(frame)
    for split, names in splits.items():
        (data / "splits" / f"{split}.json").write_text(json.dumps(
            {"frame_names": names, "time_ids": list(range(len(names))),
             "camera_ids": [int(n[0]) for n in names]}))
    return pred, gt_dir

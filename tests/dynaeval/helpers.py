"""Small synthetic scenes on disk for evaluate/CLI tests."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def textured_frame(rng: np.random.Generator, h: int = 48, w: int = 64) -> np.ndarray:
    """(h, w, 3) uint8 smooth random texture (so optical flow has something to track)."""
    small = rng.integers(0, 256, size=(h // 4, w // 4, 3), dtype=np.uint8)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


def moving_square_scene(
    root: Path, *, cameras=("cam00", "cam01"), frames: int = 4, h: int = 48, w: int = 64, seed=0
) -> tuple[Path, dict[str, list[np.ndarray]]]:
    """Ground truth: a static texture with a bright square moving right; returns (gt dir, frames)."""
    rng = np.random.default_rng(seed)
    out: dict[str, list[np.ndarray]] = {}
    for cam in cameras:
        bg = textured_frame(rng, h, w)
        seq = []
        for t in range(frames):
            img = bg.copy()
            img[20:30, 8 + 4 * t: 18 + 4 * t] = (250, 40, 40)
            seq.append(img)
        out[cam] = seq
        write_frames(root, cam, seq)
    return root, out


def write_frames(root: Path, camera: str, frames: list[np.ndarray], ext: str = ".png") -> None:
    """Write RGB uint8 frames as root/camera/0000.png, ..."""
    (root / camera).mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(root / camera / f"{i:04d}{ext}"), np.ascontiguousarray(f[..., ::-1]))


def three_camera_scene(root: Path) -> tuple[Path, Path]:
    """``moving_square_scene`` with cameras cam0..cam2 and a noisy prediction of it (seed 3):
    (pred dir, gt dir). The scene of the merge tests and of ``data/v1``'s results files."""
    gt, frames = moving_square_scene(root / "gt", cameras=("cam0", "cam1", "cam2"))
    rng = np.random.default_rng(3)
    for cam, seq in frames.items():
        write_frames(root / "pred", cam, [
            np.clip(f.astype(int) + rng.integers(-9, 10, f.shape), 0, 255).astype(np.uint8)
            for f in seq])
    return root / "pred", gt

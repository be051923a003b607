"""The static-camera check of the motion masks on a pan of real photographs vs the bundled sample.

For each of scikit-image's photographs ``coffee``, ``chelsea`` and ``astronaut``, 12 crops of
320x180 px whose window moves 1, 2 or 4 px right per frame (a pan), and for each camera of the
bundled sample (static cameras): the global motion (``static_camera.camera_motion``, px per frame)
and the share of the frame the default ISG motion mask covers (mean, min, max over frames).

    python benchmarks/static_camera.py      # Markdown table on stdout
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

import dynaeval
from dynaeval.regions.motion import MotionConfig, motion_mask
from dynaeval.regions.static_camera import camera_motion, moving_camera_reason

SAMPLE = Path(dynaeval.__file__).resolve().parent / "data" / "sample" / "gt"


def pan(photo: np.ndarray, step: int, n: int = 12, h: int = 180, w: int = 320) -> list[np.ndarray]:
    """``n`` crops of ``photo`` (uint8 RGB), the window ``step`` px further right each frame."""
    return [photo[10:10 + h, 10 + step * t:10 + step * t + w].astype(np.float32) / 255 for t in range(n)]


def row(name: str, frames: list[np.ndarray]) -> str:
    fractions = motion_mask(np.stack(frames), MotionConfig()).reshape(len(frames), -1).mean(axis=1)
    px = camera_motion(lambda i: frames[i], len(frames))
    flagged = moving_camera_reason(px, float(fractions.mean()), "detector") is not None
    return (f"| {name} | {px:.2f} | {fractions.mean():.3f} | {fractions.min():.3f} | "
            f"{fractions.max():.3f} | {'yes' if flagged else 'no'} |")


def main() -> None:
    from skimage import data

    print("| sequence | global motion (px/frame) | mask share mean | min | max | warned |")
    print("|---|---|---|---|---|---|")
    for name in ("coffee", "chelsea", "astronaut"):
        photo = getattr(data, name)()
        for step in (1, 2, 4):
            print(row(f"pan of {name}, {step} px/frame", pan(photo, step)))
    for cam in sorted(p for p in SAMPLE.iterdir() if p.is_dir()):
        frames = [cv2.imread(str(f))[..., ::-1].astype(np.float32) / 255 for f in sorted(cam.glob("*.png"))]
        print(row(f"sample {cam.name} (static)", frames))


if __name__ == "__main__":
    main()

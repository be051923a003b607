"""Synthetic frame sequences shared by the temporal-metric tests (test_temporal*.py, test_static_flicker.py)."""

from __future__ import annotations

import numpy as np

H, W = 64, 80


def texture(rng: np.random.Generator, h: int = H + 40, w: int = W + 40) -> np.ndarray:
    """Smooth random RGB texture in [0.1, 0.9] (blurred noise: trackable by every flow method)."""
    import cv2

    t = cv2.GaussianBlur(rng.random((h, w, 3)).astype(np.float32), (0, 0), 2.0)
    t = (t - t.min()) / (t.max() - t.min())
    return (0.1 + 0.8 * t).astype(np.float32)


def panning(base: np.ndarray, n: int, step: tuple[int, int] = (2, -1)) -> list[np.ndarray]:
    """n frames in which the content moves by ``step = (dx, dy)`` px per frame."""
    dx, dy = step
    return [
        base[20 - k * dy : 20 - k * dy + H, 20 - k * dx : 20 - k * dx + W].copy() for k in range(n)
    ]


def mean_abs(a: np.ndarray, b: np.ndarray) -> float:
    """A cheap stand-in for LPIPS: deterministic, 0 on identical frames, grows with change."""
    return float(np.abs(np.asarray(a, np.float64) - b).mean())

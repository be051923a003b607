"""Fixtures shared by the metric tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest


@pytest.fixture
def structured() -> Callable[[int, int], np.ndarray]:
    """``structured(h, w)``: (h, w, 3) float64 in [0, 1] with a ramp, a sinusoid and a hard edge."""

    def make(h: int, w: int) -> np.ndarray:
        y, x = np.mgrid[0:h, 0:w].astype(np.float64)
        ramp = x / max(w - 1, 1)
        wave = 0.5 + 0.5 * np.sin(x / 3.0 + y / 5.0)
        edge = (x > w / 2).astype(np.float64)
        return np.stack([ramp, wave, edge], axis=-1)

    return make

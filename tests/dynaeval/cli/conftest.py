"""Fixtures of the command-line tests."""

from __future__ import annotations

import numpy as np
import pytest

from ..helpers import moving_square_scene, write_frames


@pytest.fixture
def scene(tmp_path):
    """``(pred, gt)``: the moving-square scene, predictions 5 grey levels brighter."""
    gt, frames = moving_square_scene(tmp_path / "gt")
    for cam, seq in frames.items():
        write_frames(tmp_path / "pred", cam, [np.clip(f.astype(int) + 5, 0, 255).astype(np.uint8)
                                              for f in seq])
    return tmp_path / "pred", gt

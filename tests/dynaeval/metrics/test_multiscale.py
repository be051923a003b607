"""MS-SSIM and D-SSIM input checks (the values against torchmetrics are in test_protocol_kplanes)."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.metrics.multiscale import d_ssim, ms_ssim


def test_0_255_input_is_refused_unless_the_protocol_clips(rng):
    a = rng.random((176, 180, 3)) * 255.0
    b = np.clip(a + rng.normal(0, 10, a.shape), 0, 255)
    with pytest.raises(InputError, match=r"pred holds values in \[0\.\d+, 255\].* data_range=255"):
        ms_ssim(a, b)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255"):
        d_ssim(a.astype(np.uint8), b.astype(np.uint8))
    assert ms_ssim(a, b, data_range=255) == pytest.approx(ms_ssim(a / 255, b / 255), abs=1e-12)
    over = a / 200.0  # up to 1.275: an overshoot, which clip=True takes (its tools clip it)
    assert ms_ssim(over, b / 255, clip=True) == pytest.approx(
        ms_ssim(np.clip(over, 0, 1), b / 255), abs=1e-12)
    with pytest.raises(InputError, match=r"pred holds values in \[0\.\d+, 255\].* data_range=255"):
        ms_ssim(a, b, clip=True)  # 0..255 floats are another unit, not an overshoot to clip


def test_channel_first_is_refused(rng):
    a = rng.random((3, 176, 180))
    with pytest.raises(InputError, match=r"looks channel-first: shape \(3, 176, 180\)"):
        ms_ssim(a, a)


def test_clip_still_refuses_integers_at_data_range_1(rng):
    a = (rng.random((176, 180, 3)) * 255).astype(np.uint8)
    with pytest.raises(InputError, match=r"pred is uint8 .* pass data_range=255"):
        ms_ssim(a, a, clip=True)  # clipping 0..255 to [0, 1] would be nonsense too

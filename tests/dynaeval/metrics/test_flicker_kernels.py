"""The compiled Welford loop gives the bits of the numpy block steps it replaced."""

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.metrics.static_flicker import TemporalStd


def _numpy_welford(frames, pixels):
    """The float64 Welford steps as numpy did them before the compiled loop (whole arrays; the
    blocks it ran them in change no value)."""
    index = np.flatnonzero(pixels)
    mean = m2 = None
    for n, frame in enumerate(frames, start=1):
        x = frame.reshape(-1, *frame.shape[2:])[index].astype(np.float64)
        if mean is None:
            mean, m2 = np.zeros_like(x), np.zeros_like(x)
        delta = x - mean
        mean += delta / np.float64(n)
        m2 += delta * (x - mean)
    return np.sqrt(m2 / len(frames))


@pytest.mark.parametrize("shape", [(30, 40, 3), (30, 40), (17, 9, 1), (8, 8, 4)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_temporal_std_equals_the_numpy_steps_bit_for_bit(rng, shape, dtype):
    frames = [rng.random(shape).astype(dtype) for _ in range(7)]
    frames[3] = frames[3] * 1e-3 + 0.5  # a near-constant frame: cancellation in the steps
    pixels = rng.random(shape[:2]) > 0.4
    acc = TemporalStd(pixels)
    for f in frames:
        acc.update(f)
    want = _numpy_welford(frames, pixels)
    got = acc.std()
    assert got.shape == want.shape == (pixels.sum(), *shape[2:])
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_strided_frames_are_read_as_their_values(rng):
    frame = rng.random((20, 30, 3), dtype=np.float32)
    pixels = np.ones((20, 15), bool)
    a, b = TemporalStd(pixels), TemporalStd(pixels)
    for f in (frame, frame[::-1] * 0.5):
        a.update(f[:, ::2])
        b.update(np.ascontiguousarray(f[:, ::2]))
    assert np.array_equal(a.std(), b.std())


def test_a_frame_of_another_shape_is_refused_not_read_out_of_bounds(rng):
    acc = TemporalStd(np.ones((10, 12), bool))
    acc.update(rng.random((10, 12, 3)))
    for bad in (rng.random((10, 13, 3)), rng.random((10, 12, 4)), rng.random((10, 12))):
        with pytest.raises(InputError, match="followed pixels"):
            acc.update(bad)

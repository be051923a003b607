"""The compiled flow loops give the bits of the numpy steps they replaced."""

import numpy as np
import pytest

from dynaeval.metrics.flow import visibility, visibility_reference
from dynaeval.metrics.pair_kernels import tof_terms


def _flows(rng, shape, scale):
    """Two flows ``(H, W, 2)`` float32: ``t -> s`` and a nearly inverse ``s -> t`` with noise,
    some samples outside the frame, exact zeros and samples on the border."""
    h, w = shape
    f = (rng.standard_normal((h, w, 2)) * scale).astype(np.float32)
    f[: h // 4] = 0.0  # zero flow: on the grid
    f[:, 0, 0] = -np.float32(0.0)
    f[-1, :, 1] = 0.0  # the last row samples the border exactly
    g = (-f + rng.standard_normal((h, w, 2)).astype(np.float32) * np.float32(scale / 4)).astype(
        np.float32)
    return f, g


@pytest.mark.parametrize("shape", [(37, 61), (64, 129), (130, 65), (1, 17), (17, 1)])
@pytest.mark.parametrize("scale", [0.3, 2.0, 40.0])
def test_visibility_equals_the_numpy_steps_bit_for_bit(rng, shape, scale):
    f, g = _flows(rng, shape, scale)
    got, want = visibility(f, g), visibility_reference(f, g)
    for a, b in zip(got, want, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert np.array_equal(a.view(np.uint8 if a.dtype == bool else np.uint32),
                              b.view(np.uint8 if b.dtype == bool else np.uint32))
    assert 0 < got[0].sum() < got[0].size or min(shape) == 1


def test_visibility_reads_strided_and_read_only_flows(rng):
    f, g = _flows(rng, (40, 100), 3.0)
    fs, gs = f[:, ::2], g[:, ::2]
    for a in (fs, gs):
        a.flags.writeable = False
    got, want = visibility(fs, gs), visibility_reference(np.ascontiguousarray(fs),
                                                         np.ascontiguousarray(gs))
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))


def _numpy_tof(fp, fw, region):
    epe = np.sqrt(np.sum((fp.astype(np.float64) - fw) ** 2, axis=-1))
    return float(epe.mean()), (float(epe[region].mean()) if region is not None and region.any()
                               else None)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 300.0])
def test_tof_terms_equal_the_numpy_endpoint_error_bit_for_bit(rng, scale):
    fp, fw = (rng.standard_normal((2, 67, 131, 2)) * scale).astype(np.float32)
    fw[:10] = fp[:10]  # zero error
    region = rng.random((67, 131)) > 0.5
    for reg in (region, None, np.zeros_like(region)):
        assert tof_terms(fp, fw, reg) == _numpy_tof(fp, fw, reg)


@pytest.mark.parametrize("shape", [(45, 77, 3), (45, 77, 1), (45, 77), (20, 30, 4)])
def test_the_gray_image_equals_the_numpy_steps(rng, shape):
    from dynaeval.metrics.flow import _LUMA, gray_of_checked

    frame = rng.random(shape, dtype=np.float32)
    frame.flat[::7] = (rng.integers(0, 255, frame.size)[::7] + 0.5) / np.float32(255.0)  # ties
    frame.flat[::11] = rng.choice([-0.3, 0.0, 1.0, 1.4], frame.size)[::11]  # clipped, edges
    luma = frame if frame.ndim == 2 else frame[..., 0] if shape[2] == 1 else frame[..., :3] @ _LUMA
    want = np.clip(np.rint(luma * 255.0), 0, 255).astype(np.uint8)
    got = gray_of_checked(frame)
    assert got.dtype == np.uint8 and np.array_equal(got, want)

"""The per-pair kernels give the bits of the numpy steps they replace."""

import numpy as np
import pytest

from dynaeval.metrics.pair_kernels import kept_mse


def _numpy_kept_mse(cur, warped, mask):
    """The warping error's reduction as ``warping_error`` writes it (boolean mask, float64)."""
    return float(((cur - warped)[mask].astype(np.float64) ** 2).mean())


def _take_kept_mse(cur, warped, keep):
    """``kept_mse`` as it was before the compiled gather (the difference over the whole frame,
    np.take into float32, then squares)."""
    diff = cur - warped
    c = 1 if diff.ndim == 2 else diff.shape[2]
    rows = diff.reshape(-1, c) if diff.ndim == 3 else diff.reshape(-1)
    got = np.take(rows, keep, axis=0)
    return float(np.square(got, dtype=np.float64).mean())


@pytest.mark.parametrize("shape", [(37, 53, 3), (37, 53), (40, 33, 1), (9, 11, 4), (1, 1, 3)])
@pytest.mark.parametrize("keep_share", [1.0, 0.6, 0.01])
def test_kept_mse_equals_the_numpy_reduction_bit_for_bit(rng, shape, keep_share):
    cur = rng.random(shape, dtype=np.float32)
    warped = (cur + rng.standard_normal(shape) * rng.choice([1e-7, 1e-3, 1.0], shape)).astype(
        np.float32)  # differences that round in float32, and large ones
    mask = rng.random(shape[:2]) < keep_share
    mask.flat[rng.integers(mask.size)] = True  # never empty
    keep = np.flatnonzero(mask)
    got = kept_mse(cur, warped, keep)
    assert got == _numpy_kept_mse(cur, warped, mask) == _take_kept_mse(cur, warped, keep)


def test_kept_mse_of_many_values_keeps_the_pairwise_sum(rng):
    """Sizes around numpy's pairwise blocks (8, 128 values) and a large one: same bits."""
    for n in (7, 8, 9, 127, 128, 129, 1023, 300_001):
        cur, warped = rng.random((2, n, 1, 3), dtype=np.float32)
        mask = np.ones((n, 1), bool)
        mask[::5] = False
        keep = np.flatnonzero(mask)
        assert (kept_mse(cur, warped, keep) == _numpy_kept_mse(cur, warped, mask)
                == _take_kept_mse(cur, warped, keep))


def test_kept_mse_of_no_pixel_is_none_and_a_single_pixel_its_square(rng):
    cur, warped = rng.random((2, 5, 6, 3), dtype=np.float32)
    assert kept_mse(cur, warped, np.array([], np.int64)) is None
    one = np.zeros((5, 6), bool)
    one[4, 5] = True
    assert kept_mse(cur, warped, np.flatnonzero(one)) == _numpy_kept_mse(cur, warped, one)


@pytest.mark.parametrize("focus", ["some", "none", "empty"])
def test_tof_terms_equal_tof_bit_for_bit(rng, focus):
    from dynaeval.metrics.pair_kernels import tof_terms
    from dynaeval.metrics.temporal_pairs import tof

    fp, fw = (rng.standard_normal((2, 70, 90, 2)) * 3).astype(np.float32)
    region = {"some": rng.random((70, 90)) > 0.6, "none": None,
              "empty": np.zeros((70, 90), bool)}[focus]
    whole, focused = tof_terms(fp, fw, region)
    assert whole == tof(fp, fw)
    assert focused == (tof(fp, fw, region) if focus == "some" else None)

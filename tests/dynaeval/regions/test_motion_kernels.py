"""The ISG median kernel (issue 33, prepare's speed): bit for bit ``np.median`` along the frame
axis, as ``temporal_median`` called it, on random values, ties, constants and float32 extremes."""

from __future__ import annotations

import itertools
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from dynaeval.regions.motion import LazyFrames, temporal_median
from dynaeval.regions.motion_kernels import BLOCK, median_network, median_of_stack

F32 = np.finfo(np.float32)


def _numpy(stack: np.ndarray) -> np.ndarray:
    """What ``temporal_median`` computed before the kernel: ``np.median`` over axis 0, in place."""
    return np.median(stack.copy(), axis=0, overwrite_input=True)


def _kernel(stack: np.ndarray) -> np.ndarray:
    out = np.empty(stack.shape[1:], np.float32)
    median_of_stack(stack.reshape(len(stack), -1), out.reshape(-1), median_network(len(stack)))
    return out


def _same_bits(a: np.ndarray, b: np.ndarray) -> None:
    assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.int32), b.view(np.int32))


def _values(rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    """``(n, count)`` float32: uniform values, ties (a few levels), constant columns, and float32
    extremes (max, min normal, subnormals, inf, values whose sum overflows)."""
    x = rng.random((n, count), dtype=np.float32)
    q = count // 5
    x[:, q:2 * q] = np.round(x[:, q:2 * q] * 3) / 3  # ties
    x[:, 2 * q:3 * q] = x[0, 2 * q:3 * q]  # constant over the frames
    pool = np.array([F32.max, -F32.max, F32.tiny, F32.smallest_subnormal, 3 * F32.smallest_subnormal,
                     np.inf, -np.inf, 1.0, 0.0, 0.5, 1e-30, 1e30, np.nextafter(1, 2, dtype=np.float32)],
                    np.float32)
    x[:, 3 * q:] = rng.choice(pool, size=(n, count - 3 * q))
    return x


@pytest.mark.parametrize("n", [*range(1, 18), 31, 32, 33, 63, 64, 65])
def test_the_kernel_is_np_median_bit_for_bit(n):
    rng = np.random.default_rng(n)
    stack = _values(rng, n, 3 * BLOCK + 17)  # several blocks and a partial one
    _same_bits(_kernel(stack), _numpy(stack))


def test_nan_gives_nan_as_np_median_does():
    stack = np.random.default_rng(0).random((6, 40), dtype=np.float32)
    stack[3, 5] = stack[0, 7] = np.nan
    got, want = _kernel(stack), _numpy(stack)
    assert np.isnan(got[[5, 7]]).all() and np.isnan(want[[5, 7]]).all()
    keep = np.ones(40, bool)
    keep[[5, 7]] = False
    _same_bits(got[keep], want[keep])


@pytest.mark.parametrize("n", [2, 3, 5, 8, 12])
def test_the_network_puts_the_middle_values_in_place(n):
    """0-1 principle: a comparator network sorts every input iff it sorts every 0/1 input; the
    pruned one must get the middle positions of each right."""
    size = 1 << (n - 1).bit_length()
    net = median_network(n)
    for bits in itertools.product((0.0, 1.0), repeat=n):
        v = np.array([*bits, *[np.inf] * (size - n)])
        for i, j in net:
            v[i], v[j] = min(v[i], v[j]), max(v[i], v[j])
        want = np.sort(bits)
        assert v[(n - 1) // 2] == want[(n - 1) // 2] and v[n // 2] == want[n // 2]


@pytest.mark.parametrize("max_bytes", [1 << 28, 37 * 23 * 3 * 4 * 4, 1])
@pytest.mark.parametrize("threads", [0, 3])
def test_temporal_median_is_np_median_in_every_path(max_bytes, threads):
    """Frames read once (they fit), bands of rows read again (they do not), on threads or not:
    the median ``np.median`` gave, bit for bit, each frame read once per band (frame 0 once)."""
    frames = _values(np.random.default_rng(1), 8, 37 * 23 * 3).reshape(8, 37, 23, 3)
    frames = np.clip(np.nan_to_num(frames, posinf=1, neginf=0), 0, 1)  # frames are in [0, 1]
    reads = []
    lazy = LazyFrames(range(8), lambda i: reads.append(i) or frames[i])
    pool = ThreadPoolExecutor(threads) if threads else None
    try:
        got = temporal_median(lazy, executor=pool, max_bytes=max_bytes)
    finally:
        if pool:
            pool.shutdown()
    _same_bits(got, _numpy(frames))
    row = 8 * 23 * 3 * 4
    bands = -(-37 // max(1, min(37, max_bytes // row)))
    assert sorted(reads) == sorted([0, *list(range(1, 8)) * bands])

"""The fused SSIM loops give the bits of the numpy/OpenCV passes they replaced."""

import cv2
import numpy as np
import pytest

from dynaeval.metrics import structural_kernels as K
from dynaeval.metrics.structural import _C1, _C2, K1, K2, RADIUS


def _passes(a, b, exy, ed2):
    """The SSIM step as the whole-buffer numpy/OpenCV passes computed it before the fused loop
    (each operation float32, in this order; ``addWeighted`` as OpenCV rounds it)."""
    a, b, exy, ed2 = (v.copy() for v in (a, b, exy, ed2))
    ab, e2 = np.empty_like(a), np.empty_like(a)
    np.multiply(a, b, out=ab)
    np.subtract(exy, ab, out=exy)
    cv2.addWeighted(exy, 2.0, exy, 0.0, K2 * K2, dst=exy)
    np.subtract(a, b, out=e2)
    np.multiply(e2, e2, out=e2)
    np.subtract(ed2, e2, out=ed2)
    np.add(ed2, exy, out=ed2)
    np.add(a, np.float32(0.5), out=a)
    np.add(b, np.float32(0.5), out=b)
    cv2.multiply(a, b, dst=ab, scale=2.0)
    cv2.addWeighted(ab, 1.0, e2, 1.0, K1 * K1, dst=e2)
    np.add(ab, np.float32(K1 * K1), out=ab)
    np.multiply(ab, exy, out=ab)
    np.multiply(e2, ed2, out=e2)
    return ab / e2


def _moments(rng, n, m, flat):
    """Filtered-moment-like tile buffers: centred means in [-0.5, 0.5], second moments near
    their products (flat windows: exactly constant levels, where the constants dominate)."""
    if flat:
        level = rng.choice([-0.5, -0.49, 0.0, 0.49, 0.5], size=(n, m)).astype(np.float32)
        a, b = level, level.copy()
    else:
        a = (rng.random((n, m), dtype=np.float32) - 0.5)
        b = np.clip(a + 0.05 * rng.standard_normal((n, m)).astype(np.float32), -0.5, 0.5)
    exy = (a * b + 0.01 * rng.random((n, m), dtype=np.float32)).astype(np.float32)
    ed2 = ((a - b) ** 2 + 0.01 * rng.random((n, m), dtype=np.float32)).astype(np.float32)
    return a, b, exy, ed2


@pytest.mark.parametrize("flat", [False, True])
@pytest.mark.parametrize("channels, m", [(3, 600), (1, 64), (4, 96), (3, 33)])
def test_ssim_windows_equals_the_numpy_passes_bit_for_bit(rng, flat, channels, m):
    n = 40
    rows = n - 2 * RADIUS
    a, b, exy, ed2 = _moments(rng, n, m, flat)
    q = np.full((rows, m + 50), np.nan, np.float32)
    q0 = 7
    K.ssim_windows(a, b, exy, ed2, q, rows, m, RADIUS, channels, q0, _C1, _C2)
    lo = RADIUS * channels
    want = _passes(*(v[RADIUS : RADIUS + rows] for v in (a, b, exy, ed2)))[:, lo : m - lo]
    got = q[:, q0 : q0 + m - 2 * lo]
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    assert np.isnan(q[:, :q0]).all() and np.isnan(q[:, q0 + m - 2 * lo :]).all()  # nothing else


def test_products_use_only_the_rows_and_values_asked_for(rng):
    x, y = (rng.random((20, 64), dtype=np.float32) for _ in range(2))
    d2, xy = np.full_like(x, -1.0), np.full_like(x, -1.0)
    K.products(x, y, d2, xy, 12, 48)
    assert np.array_equal(d2[:12, :48], (x - y)[:12, :48] ** 2)
    assert np.array_equal(xy[:12, :48], (x * y)[:12, :48])
    assert (d2[12:] == -1).all() and (d2[:, 48:] == -1).all() and (xy[12:] == -1).all()


def test_a_zero_denominator_gives_ieee_values_not_an_exception():
    z = np.zeros((2 * RADIUS + 1, 2 * RADIUS + 1), np.float32)
    a = np.full_like(z, -0.5)
    q = np.empty((1, 1), np.float32)
    K.ssim_windows(a, a, z, z, q, 1, 2 * RADIUS + 1, RADIUS, 1, 0, np.float32(0), np.float32(0))
    assert np.isnan(q[0, 0])

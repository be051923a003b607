"""The gather of the warping error's kept pixels as one compiled loop (numba), bit for bit the
numpy steps it replaces.

``pair_kernels.kept_mse`` formed the frame difference ``cur - warp(prev)`` over the whole frame,
gathered the kept values with ``np.take`` into a float32 buffer and squared them into a float64
one: three passes over ~6 M values per term at 1080p. Here one loop reads each kept pixel by
index, subtracts in float32, widens to float64 and squares (the operations numpy did, in its
order: numba neither reassociates nor fuses without ``fastmath``), so the float64 buffer holds
the same bits and numpy's mean of it (pairwise sum, same shape and order) is unchanged (tested).

Arrays: ``a``, ``b`` ``(P, C)`` float32 (two frames' pixels, row-major), ``index`` ``(N,)``
int64 increasing pixel indices, ``out`` ``(N, C)`` float64.
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.runtime import compiled


@compiled
def squared_differences_at(a: np.ndarray, b: np.ndarray, index: np.ndarray, out: np.ndarray) -> None:
    """``out[k, c] = float64(a[p, c] - b[p, c]) ** 2``, ``p = index[k]``, for every kept pixel
    ``k`` and channel ``c`` (the difference in float32)."""
    channels = a.shape[1]
    for k in range(index.size):
        p = index[k]
        for c in range(channels):
            x = np.float64(a[p, c] - b[p, c])
            out[k, c] = x * x

"""The gather of the warping error's kept pixels as one compiled loop (numba), bit for bit the
numpy steps it replaces.

``pair_kernels.kept_mse`` gathered the kept values with ``np.take`` into a float32 buffer and
squared them into a float64 one: two passes over ~6 M values per term at 1080p. Here one loop
reads each kept value by index, widens it to float64 and squares it (the float64 product numpy
took: numba neither reassociates nor fuses without ``fastmath``), so the float64 buffer holds
the same bits and numpy's mean of it (pairwise sum, same shape and order) is unchanged (tested).

Arrays: ``rows`` ``(P, C)`` float32 (a frame's pixels, row-major), ``index`` ``(N,)`` int64
increasing pixel indices, ``out`` ``(N, C)`` float64.
"""

from __future__ import annotations

import numpy as np

from dynaeval.runtime import compiled


@compiled
def squares_at(rows: np.ndarray, index: np.ndarray, out: np.ndarray) -> None:
    """``out[k, c] = float64(rows[index[k], c]) ** 2`` for every kept pixel ``k``, channel ``c``."""
    channels = rows.shape[1]
    for k in range(index.size):
        p = index[k]
        for c in range(channels):
            x = np.float64(rows[p, c])
            out[k, c] = x * x

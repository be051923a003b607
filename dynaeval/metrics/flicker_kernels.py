"""The streaming temporal std of ``static_flicker.TemporalStd`` as single compiled loops (numba),
bit for bit the numpy block steps they replace.

Per frame, each followed pixel and channel takes one Welford step in float64:
``delta = x - mean; mean += delta / n; m2 += delta * (x - mean)``. numpy did it in seven passes
over gathered blocks; here it is one loop that reads the frame's value by index. Each operation
is the float64 operation numpy did, in its order (numba neither reassociates nor fuses a
multiply-add without ``fastmath``), so the results are the same bits (tested).

Arrays: ``rows`` ``(P, C)`` float32/float64 (a frame's pixels, row-major), ``index`` ``(N,)``
int64 increasing pixel indices, ``mean`` and ``m2`` ``(N, C)`` float64.
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.runtime import compiled


@compiled
def welford_update(rows: np.ndarray, index: np.ndarray, mean: np.ndarray, m2: np.ndarray,
                   n: np.float64) -> None:
    """Add frame ``rows`` (the ``n``-th, 1-based) to the running ``mean`` and ``m2``."""
    channels = rows.shape[1]
    for k in range(index.size):
        p = index[k]
        for c in range(channels):
            x = np.float64(rows[p, c])
            delta = x - mean[k, c]
            mean[k, c] += delta / n
            m2[k, c] += delta * (x - mean[k, c])


@compiled
def population_std(m2: np.ndarray, count: np.float64, out: np.ndarray) -> None:
    """``out = sqrt(m2 / count)`` elementwise (``(N, C)`` float64)."""
    for k in range(m2.shape[0]):
        for c in range(m2.shape[1]):
            out[k, c] = np.sqrt(m2[k, c] / count)

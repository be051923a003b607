"""The per-pair flow arithmetic of ``flow.visibility`` and ``pair_kernels.tof_terms`` as single
compiled loops (numba), bit for bit the numpy steps they replace.

numpy formed the sample grid ``p + flow(p)``, the in-frame test, the forward-backward test
``|f + g|^2 < 0.01 (|f|^2 + |g|^2) + 0.5`` and the endpoint error
``sqrt((fp - fw)_x^2 + (fp - fw)_y^2)`` in a dozen passes with temporaries each; here every
output is one loop. Each operation is the one numpy did, in the same precision and order
(float32 for the grid and the visibility test, its constants float32; float64 for the endpoint
error), and numba neither reassociates nor fuses a multiply-add without ``fastmath``: the same
bits (tested against the numpy steps).

Arrays: flows ``(H, W, 2)`` float32 ``(dx, dy)``, C-contiguous or row-strided; grids
``(H, W)`` float32; masks ``(H, W)`` bool; the endpoint map ``(H, W)`` float64.
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.runtime import compiled


@compiled
def sample_grid(flow: np.ndarray, xs: np.ndarray, ys: np.ndarray, inside: np.ndarray) -> None:
    """``xs = x + dx``, ``ys = y + dy`` (float32) and ``inside``: the sample lies in
    ``[0, W-1] x [0, H-1]``."""
    h, w = xs.shape
    right = np.float32(w - 1)
    bottom = np.float32(h - 1)
    zero = np.float32(0.0)
    for i in range(h):
        fi = np.float32(i)
        for j in range(w):
            x = np.float32(j) + flow[i, j, 0]
            y = fi + flow[i, j, 1]
            xs[i, j] = x
            ys[i, j] = y
            inside[i, j] = (x >= zero) and (x <= right) and (y >= zero) and (y <= bottom)


@compiled
def consistent(f: np.ndarray, g: np.ndarray, valid: np.ndarray) -> None:
    """``valid &= |f + g|^2 < 0.01 (|f|^2 + |g|^2) + 0.5`` (float32, numpy's order:
    ``(f_x^2 + f_y^2) + (g_x^2 + g_y^2)``, then ``* 0.01``, then ``+ 0.5``)."""
    h, w = valid.shape
    c001 = np.float32(0.01)
    c05 = np.float32(0.5)
    for i in range(h):
        for j in range(w):
            if not valid[i, j]:
                continue
            f0 = f[i, j, 0]
            f1 = f[i, j, 1]
            g0 = g[i, j, 0]
            g1 = g[i, j, 1]
            s0 = f0 + g0
            s1 = f1 + g1
            lhs = s0 * s0 + s1 * s1
            rhs = (f0 * f0 + f1 * f1) + (g0 * g0 + g1 * g1)
            rhs = rhs * c001
            rhs = rhs + c05
            valid[i, j] = lhs < rhs


@compiled
def endpoint_error(fp: np.ndarray, fw: np.ndarray, out: np.ndarray) -> None:
    """``out = sqrt((fp - fw)_x^2 + (fp - fw)_y^2)``, the difference widened to float64 first."""
    h, w = out.shape
    for i in range(h):
        for j in range(w):
            d0 = np.float64(fp[i, j, 0]) - np.float64(fw[i, j, 0])
            d1 = np.float64(fp[i, j, 1]) - np.float64(fw[i, j, 1])
            out[i, j] = np.sqrt(d0 * d0 + d1 * d1)


@compiled
def gray_u8(luma: np.ndarray, out: np.ndarray) -> None:
    """``out = clip(rint(luma * 255), 0, 255)`` as uint8 (``luma`` float32 ``(H, W)``, the
    product in float32, ties to even as ``np.rint``)."""
    h, w = out.shape
    scale = np.float32(255.0)
    lo = np.float32(0.0)
    hi = np.float32(255.0)
    for i in range(h):
        for j in range(w):
            v = np.rint(luma[i, j] * scale)
            if v < lo:
                v = lo
            elif v > hi:
                v = hi
            out[i, j] = np.uint8(v)

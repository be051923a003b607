"""SSIM's elementwise steps fused into single loops (compiled with numba), bit for bit the
numpy/OpenCV steps they replace.

The fast SSIM filters a tile's moments with OpenCV and then combined them in ~17 numpy/OpenCV
passes, each reading and writing whole tile buffers: a third of its time at 1080p. Here each
step is one loop that reads its inputs once and keeps the intermediates in registers.

Same bits: every operation is the float32 operation the passes did, in their order (numba
neither reassociates nor contracts ``a * b + c`` into a fused multiply-add without ``fastmath``,
which is not set); the two OpenCV calls that do fuse are matched by operations that round the
same way (``addWeighted(e, 2, e, 0, c) = 2 e + c``, ``2 e`` being exact; see
:func:`ssim_windows`). A test holds the result to the numpy steps on random and flat data.

Arrays: C-contiguous float32 tile buffers ``(rows, width)``; ``n`` rows and ``m`` values per row
are used (a tile may be narrower than its buffers).
"""

from __future__ import annotations

import numpy as np

from dynaeval.core.runtime import compiled


@compiled
def products(x: np.ndarray, y: np.ndarray, d2: np.ndarray, xy: np.ndarray, n: int, m: int) -> None:
    """``d2 = (x - y)^2`` and ``xy = x y`` over the first ``n`` rows, ``m`` values of each."""
    for i in range(n):
        for j in range(m):
            a = x[i, j]
            b = y[i, j]
            d = a - b
            d2[i, j] = d * d
            xy[i, j] = a * b


@compiled
def ssim_windows(a: np.ndarray, b: np.ndarray, exy: np.ndarray, ed2: np.ndarray, q: np.ndarray,
                 rows: int, m: int, r: int, channels: int, q0: int, c1: np.float32,
                 c2: np.float32) -> None:
    """SSIM of the windows of a filtered tile into ``q[:rows, q0 : q0 + m - 2 r C]`` (``r``: the
    window radius, ``C`` channels; ``c1, c2``: SSIM's constants as float32).

    Inputs (rows ``r .. r + rows`` of the tile, columns ``r C .. m - r C``): ``a = mu_x - 0.5``,
    ``b = mu_y - 0.5``, ``exy = w * (x y)``, ``ed2 = w * (x - y)^2`` of the centred data. The
    formula is ``structural._band``'s: ``sigma_xy = exy - a b``, ``var(d) = ed2 - (a - b)^2``,
    ``S = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((2 mu_x mu_y + (a - b)^2 + C1)
    (var(d) + 2 sigma_xy + C2))``, each difference taken before a constant is added.
    """
    half = np.float32(0.5)
    two = np.float32(2.0)
    lo = r * channels
    width = m - 2 * lo
    for i in range(rows):
        ar = a[r + i, lo : m - lo]
        br = b[r + i, lo : m - lo]
        xr = exy[r + i, lo : m - lo]
        dr = ed2[r + i, lo : m - lo]
        qr = q[i, q0 : q0 + width]
        for j in range(width):
            ai = ar[j]
            bi = br[j]
            num2 = two * (xr[j] - ai * bi) + c2  # 2 sigma_xy + C2
            e = ai - bi
            e2 = e * e  # (mu_x - mu_y)^2
            den2 = (dr[j] - e2) + num2  # sigma_x^2 + sigma_y^2 + C2
            ab2 = two * ((ai + half) * (bi + half))  # 2 mu_x mu_y
            den1 = ab2 + (e2 + c1)  # OpenCV's addWeighted(ab2, 1, e2, 1, C1), as it rounds
            num1 = ab2 + c1
            qr[j] = (num1 * num2) / (den1 * den2)

"""The ISG temporal median (``dynaeval.regions.motion.temporal_median``) as one compiled loop
(numba), bit for bit ``np.median(stack, axis=0)`` of the float32 frames it replaces.

``np.median`` of ``n`` values along an axis partitions them and returns the middle one (``n``
odd) or the float32 mean of the two middle ones (``n`` even: their float32 sum divided by 2, a
float32 result; an overflowing sum gives inf as there), and NaN where one of them is NaN. Here
each pixel's ``n`` values are sorted by a fixed network of compare-exchanges (Batcher's
odd-even merge sort, padded to a power of two with +inf, pruned to the comparators the middle
positions depend on), which runs over a block of pixels at a time, and the middle ones are
combined by the same float32 operations. The order statistics are the same values, so the
result is the same bits, with one exception no caller sees: a median of ``0.0`` and ``-0.0``
takes the sign of whichever the sort put in the middle (``np.median``'s partition is just as
arbitrary there), and the ISG weights square the difference to it.

Arrays: ``stack`` ``(n, P)`` float32 (``n`` frames' pixels and channels, flat), ``out``
``(P,)`` float32, ``network`` ``(K, 2)`` int64 comparator pairs ``(i, j)``, ``i < j``, from
:func:`median_network`.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from dynaeval.core.runtime import compiled

BLOCK = 1024
"""Pixels (values) sorted at a time: ``n`` rows of them stay in the CPU's cache."""


def _merge_sort(lo: int, n: int) -> list[tuple[int, int]]:
    """Batcher's odd-even merge sort of positions ``lo .. lo + n - 1`` (``n`` a power of 2)."""
    if n < 2:
        return []
    half = n // 2
    return _merge_sort(lo, half) + _merge_sort(lo + half, half) + _merge(lo, n, 1)


def _merge(lo: int, n: int, r: int) -> list[tuple[int, int]]:
    """Comparators merging the two sorted halves of ``lo .. lo + n - 1``, every ``r``-th."""
    step = 2 * r
    if step >= n:
        return [(lo, lo + r)]
    return (_merge(lo, n, step) + _merge(lo + r, n, step)
            + [(i, i + r) for i in range(lo + r, lo + n - r, step)])


@cache
def median_network(n: int) -> np.ndarray:
    """``(K, 2)`` int64 comparators that put the middle value(s) of ``n >= 1`` values (sorted
    positions ``(n - 1) // 2`` and ``n // 2``) in place; ``n`` padded to a power of two."""
    size = 1 << max(0, (n - 1).bit_length())
    needed = {(n - 1) // 2, n // 2}
    kept = []
    for i, j in reversed(_merge_sort(0, size)):  # a comparator counts if its outputs are read
        if i in needed or j in needed:
            kept.append((i, j))
            needed |= {i, j}
    return np.array(kept[::-1], dtype=np.int64).reshape(-1, 2)


@compiled
def median_of_stack(stack: np.ndarray, out: np.ndarray, network: np.ndarray) -> None:
    """``out[p] = np.median(stack[:, p])`` for every ``p`` (module docstring)."""
    n, count = stack.shape
    size = 1
    while size < n:
        size *= 2
    block = np.empty((size, BLOCK), np.float32)
    block[n:] = np.inf
    nan = np.empty(BLOCK, np.bool_)
    hi, lo = n // 2, (n - 1) // 2
    for p0 in range(0, count, BLOCK):
        m = min(BLOCK, count - p0)
        nan[:m] = False
        for k in range(n):
            for q in range(m):
                v = stack[k, p0 + q]
                block[k, q] = v
                nan[q] |= v != v
        for c in range(network.shape[0]):
            i, j = network[c, 0], network[c, 1]
            for q in range(m):
                a, b = block[i, q], block[j, q]
                block[i, q] = a if a < b else b
                block[j, q] = b if a < b else a
        for q in range(m):
            if nan[q]:
                out[p0 + q] = np.float32(np.nan)
            elif hi == lo:
                out[p0 + q] = block[hi, q]
            else:
                total = np.float32(block[lo, q] + block[hi, q])
                out[p0 + q] = np.float32(total / np.float32(2.0))


"""Bit-packed (H, W) bool masks: the form a camera's per-frame motion masks are kept in.

A 1080p bool mask is 2.1 MB; a scoring run holds one per frame until the camera's temporal pass
ends (its static region is the pixels in no frame's mask), so a 300-frame camera held 620 MB of
masks. Packed (``np.packbits`` of the flat mask, 8 pixels a byte) they take 1/8 of it, and
``dynaeval prepare`` stores these same bytes in its regions files.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from dynaeval.core.errors import InputError


@dataclass(frozen=True, eq=False)
class PackedMask:
    """An ``(H, W)`` bool mask, 8 pixels a byte."""

    bits: np.ndarray
    """``(ceil(H * W / 8),)`` uint8: ``np.packbits`` of the mask in C order (the last byte's
    unused low bits 0)."""
    shape: tuple[int, int]
    """(H, W) of the mask."""

    @staticmethod
    def pack(mask: np.ndarray) -> PackedMask:
        """Pack an ``(H, W)`` bool mask."""
        m = np.asarray(mask)
        if m.dtype != bool or m.ndim != 2:
            raise InputError(f"PackedMask.pack takes an (H, W) bool mask, got {m.dtype} {m.shape}")
        return PackedMask(np.packbits(m.ravel()), (int(m.shape[0]), int(m.shape[1])))

    def unpack(self) -> np.ndarray:
        """The ``(H, W)`` bool mask (a new array)."""
        h, w = self.shape
        return np.unpackbits(self.bits, count=h * w).reshape(h, w).view(bool)

    @property
    def nbytes(self) -> int:
        """Bytes the packed mask holds."""
        return int(self.bits.nbytes)


def union(masks: Iterable[PackedMask]) -> np.ndarray | None:
    """``(H, W)`` bool: the pixels in any of ``masks`` (all of one shape), or None without any.

    ORed byte-wise on the packed bits, one mask at a time: no (T, H, W) stack of the masks.
    """
    out: np.ndarray | None = None
    shape = None
    for m in masks:
        if out is None:
            out, shape = m.bits.copy(), m.shape
        elif m.shape != shape:
            raise InputError(f"masks differ in shape: {m.shape} and {shape}")
        else:
            np.bitwise_or(out, m.bits, out=out)
    return None if out is None else PackedMask(out, shape).unpack()

"""Decoded frames kept for reuse, so one scoring run decodes each file once where memory allows.

A camera's ground truth is read by several passes (motion masks, detector, per-frame metrics,
temporal terms) and its predictions by two; PNG decoding of a 1080p frame costs about as much as
its SSIM. ``FrameCache`` keeps decoded frames up to a byte budget. It never evicts: once full, the
frames already kept keep hitting and the rest are decoded on each read, so a sequential pass over
more frames than fit degrades to the uncached cost instead of thrashing as an LRU would.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dynaeval.io.frames import FrameRef


class FrameCache:
    """Thread-safe store of decoded frames (read-only arrays), up to ``max_bytes``.

    ``decoded``: where image files decoded beforehand come from (``path -> uint8 array or
    None``: a prepared ground truth); a miss on such a file skips reading and decoding it.
    """

    def __init__(self, max_bytes: int,
                 decoded: Callable[[Path], np.ndarray | None] | None = None) -> None:
        self.max_bytes = int(max_bytes)
        self.decoded = decoded
        self.bytes = 0
        self.hits = 0
        self.misses = 0
        self._frames: dict[tuple[FrameRef, str | float], np.ndarray] = {}
        self._lock = threading.Lock()

    def read(self, ref: FrameRef, background: str | float = "white",
             decode: str = "dynaeval") -> np.ndarray:
        """``ref.read(background, decode)``, from the cache when it was read before.

        Returns a read-only (H, W, C) float32 array: callers must not modify it in place.
        """
        key = (ref, background, decode)  # the whole reference: a K-Planes stack's parts share path and index
        with self._lock:
            frame = self._frames.get(key)
            if frame is not None:
                self.hits += 1
                return frame
            self.misses += 1
        raw = None
        if self.decoded is not None and type(ref) is FrameRef and ref.index is None:
            raw = self.decoded(ref.path)  # an image file (not a video frame, not a stack part)
        frame = ref.read(background, decode, decoded=raw) if raw is not None else ref.read(
            background, decode)
        frame.flags.writeable = False
        with self._lock:
            if key not in self._frames and self.bytes + frame.nbytes <= self.max_bytes:
                self._frames[key] = frame
                self.bytes += frame.nbytes
        return frame

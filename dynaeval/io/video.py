"""Video files as cameras: one file is one camera, its frames in decoding order.

Frames are decoded sequentially (seeking is not frame-exact for many codecs): a reader keeps its
position and re-opens the file only when asked for an earlier frame, so scoring a camera in order
decodes each frame once.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from dynaeval.errors import InputError

VIDEO_EXTENSIONS = frozenset({".mp4", ".avi", ".mov", ".mkv", ".webm"})


def count_frames(path: str | Path) -> int:
    """Number of decodable frames in a video file (decodes the stream: the container's frame
    count is often wrong).

    Raises:
        InputError: the file cannot be opened or holds no frame.
    """
    import cv2

    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError("cannot open video file", path=path)
    n = 0
    while cap.grab():
        n += 1
    cap.release()
    if n == 0:
        raise InputError("video file holds no decodable frame", path=path)
    return n


class VideoReader:
    """Sequential frame access to one video file, safe to share between threads."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._cap = None
        self._next = 0

    def _open(self) -> None:
        import cv2

        if self._cap is not None:
            self._cap.release()
        self._cap = cv2.VideoCapture(str(self.path))
        if not self._cap.isOpened():
            raise InputError("cannot open video file", path=self.path)
        self._next = 0

    def read(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) as (H, W, 3) uint8 RGB."""
        with self._lock:
            if self._cap is None or index < self._next:
                self._open()
            while self._next < index:
                if not self._cap.grab():
                    raise InputError(f"video ends before frame {index}", path=self.path)
                self._next += 1
            ok, frame = self._cap.read()
            if not ok:
                raise InputError(f"cannot decode frame {index}", path=self.path)
            self._next += 1
        return np.ascontiguousarray(frame[..., ::-1])

    def close(self) -> None:
        with self._lock:
            if self._cap is not None:
                self._cap.release()
                self._cap = None


_readers: dict[Path, VideoReader] = {}
_readers_lock = threading.Lock()


def read_video_frame(path: str | Path, index: int) -> np.ndarray:
    """Frame ``index`` of a video file as (H, W, 3) uint8 RGB, through a shared sequential reader."""
    key = Path(path).resolve()
    with _readers_lock:
        reader = _readers.get(key)
        if reader is None:
            reader = _readers[key] = VideoReader(key)
    return reader.read(index)


def close_videos() -> None:
    """Release every open video reader (called at the end of a scoring run)."""
    with _readers_lock:
        for reader in _readers.values():
            reader.close()
        _readers.clear()

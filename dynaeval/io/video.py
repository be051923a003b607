"""Video files as cameras: one file is one camera, its frames in decoding order.

Frames are decoded sequentially (seeking is not frame-exact for many codecs): a reader keeps its
position and re-opens the file only when asked for an earlier frame, so scoring a camera in order
decodes each frame once.

Damaged files (``scan_video``): OpenCV gives no per-frame error signal (FFmpeg's decoder messages
go to stderr only, and a frame whose bytes are damaged but still decodable, with the decoder's
error concealment, is returned as if it were fine). What can be seen is counted: frames the
decoder dropped, found as gaps in the frames' timestamps (their frame numbers are reported), and
a stream that ends before the container's frame count. Damage that the decoder conceals without
dropping a frame is **not** detected.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError

VIDEO_EXTENSIONS = frozenset({".mp4", ".avi", ".mov", ".mkv", ".webm"})


@dataclass
class VideoScan:
    """What decoding a whole video file found."""

    n_frames: int
    """Frames decoded."""
    container_frames: int | None = None
    """The frame count the container states (None when it states none)."""
    dropped: list[int] = field(default_factory=list)
    """Frame numbers (0-based, by timestamp) the decoder skipped: gaps in the timestamps."""

    def problem(self) -> str | None:
        """A sentence for the results' warnings when frames were lost, else None."""
        parts = []
        if self.dropped:
            shown = ", ".join(map(str, self.dropped[:20])) + (" …" if len(self.dropped) > 20 else "")
            parts.append(f"{len(self.dropped)} frame(s) could not be decoded (frame numbers by "
                         f"timestamp: {shown})")
        lost = (self.container_frames or 0) - self.n_frames - len(self.dropped)
        if lost > 0:
            parts.append(f"the stream ends {lost} frame(s) before the container's count "
                         f"({self.container_frames})")
        if not parts:
            return None
        return ("damaged video: " + "; ".join(parts) + f"; {self.n_frames} frames decoded and "
                "scored, frames after a gap pair by position with the next ones (re-encode or "
                "replace the file)")


MAX_FAILED_GRABS = 8
"""Failed grabs in a row taken as damaged frames rather than the end of the stream. OpenCV 5.0
skips a frame it cannot decode inside ``grab()``; OpenCV 5.1 returns False for it and decodes the
frames after it on the next calls (measured on a 20-frame MPEG-4 file with 400 damaged bytes:
5.1 stopped at frame 7 where 5.0 gave 19 frames)."""


def grab_decodable(cap: Any, stated: int = 0) -> bool:
    """Advance ``cap`` (an open ``cv2.VideoCapture``) to its next decodable frame, passing over
    up to ``MAX_FAILED_GRABS`` damaged ones in a row; False at the end of the stream (also once
    ``stated`` > 0 frames, the container's count, have been passed)."""
    import cv2

    for _ in range(MAX_FAILED_GRABS + 1):
        if cap.grab():
            return True
        if stated > 0 and cap.get(cv2.CAP_PROP_POS_FRAMES) >= stated:
            return False
    return False


def scan_video(path: str | Path) -> VideoScan:
    """Decode every frame of a video file (without converting it) and note the frames lost.

    Raises:
        InputError: the file cannot be read or opened, or holds no frame.
    """
    import cv2

    _check_readable(path)
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError("cannot open video file", path=path)
    fps = cap.get(cv2.CAP_PROP_FPS)
    stated = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    step = 1000.0 / fps if fps and fps > 0 else None
    n = 0
    dropped: list[int] = []
    while grab_decodable(cap, stated):
        if step is not None:
            number = round(cap.get(cv2.CAP_PROP_POS_MSEC) / step)
            dropped.extend(range(n + len(dropped), number))
        n += 1
    cap.release()
    if n == 0:
        raise InputError("video file holds no decodable frame", path=path)
    return VideoScan(n, stated if stated > 0 else None, dropped)


def video_fps(path: str | Path) -> float | None:
    """The frame rate a video file states (frames per second), or None when it states none."""
    import cv2

    _check_readable(path)
    cap = cv2.VideoCapture(str(path))
    try:
        fps = cap.get(cv2.CAP_PROP_FPS) if cap.isOpened() else 0.0
    finally:
        cap.release()
    return float(fps) if fps and fps > 0 and fps < 1000 else None


def count_frames(path: str | Path) -> int:
    """Number of decodable frames in a video file (decodes the stream: the container's frame
    count is often wrong).

    Raises:
        InputError: the file cannot be opened or holds no frame.
    """
    return scan_video(path).n_frames


def _check_readable(path: str | Path) -> None:
    """InputError naming the file when it cannot be opened for reading (OpenCV only says no)."""
    try:
        with open(path, "rb"):
            pass
    except PermissionError as err:
        raise InputError("cannot read the video file: permission denied (check its "
                         "permissions, e.g. chmod a+r)", path=path) from err
    except OSError as err:
        raise InputError(f"cannot read the video file ({err.strerror or err})", path=path) from err


class VideoReader:
    """Sequential frame access to one video file, safe to share between threads."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._cap = None
        self._next = 0
        self._stated = 0
        self._last: tuple[int, np.ndarray] | None = None
        """The frame decoded last (a K-Planes stack reads one frame twice: prediction, then
        ground truth)."""

    def _open(self) -> None:
        import cv2

        if self._cap is not None:
            self._cap.release()
        self._cap = cv2.VideoCapture(str(self.path))
        if not self._cap.isOpened():
            raise InputError("cannot open video file", path=self.path)
        self._stated = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        self._next = 0

    def read(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) as (H, W, 3) uint8 RGB (read-only)."""
        with self._lock:
            if self._last is not None and self._last[0] == index:
                return self._last[1]
            if self._cap is None or index < self._next:
                self._open()
            while self._next < index:
                if not grab_decodable(self._cap, self._stated):
                    raise InputError(f"video ends before frame {index}", path=self.path)
                self._next += 1
            ok = grab_decodable(self._cap, self._stated)
            ok, frame = self._cap.retrieve() if ok else (False, None)
            if not ok:
                raise InputError(f"cannot decode frame {index}", path=self.path)
            self._next += 1
            rgb = np.ascontiguousarray(frame[..., ::-1])
            rgb.flags.writeable = False
            self._last = (index, rgb)
        return rgb

    def close(self) -> None:
        with self._lock:
            if self._cap is not None:
                self._cap.release()
                self._cap = None
            self._last = None


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

"""Video files: damaged streams are counted and named (issue 16 item 13), unreadable ones named."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.io import pair_frames
from dynaeval.io.video import VideoScan, count_frames, scan_video
from dynaeval.regions.focus import FocusConfig


def _video(path: Path, n: int = 20) -> Path:
    rng = np.random.default_rng(0)
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (64, 48))
    for i in range(n):
        f = np.full((48, 64, 3), 60, np.uint8)
        cv2.rectangle(f, (i * 2, 10), (i * 2 + 10, 30), (200, 100, 50), -1)
        w.write(cv2.add(f, rng.integers(0, 30, f.shape, dtype=np.uint8)))
    w.release()
    return path


def _damaged(src: Path, dst: Path) -> Path:
    """``src`` with 400 random bytes a third of the way in (the decoder drops a frame)."""
    data = bytearray(src.read_bytes())
    k = len(data) // 3
    data[k:k + 400] = np.random.default_rng(0).integers(0, 255, 400, dtype=np.uint8).tobytes()
    dst.write_bytes(bytes(data))
    return dst


def test_intact_video_has_no_problem(tmp_path):
    scan = scan_video(_video(tmp_path / "v.mp4"))
    assert (scan.n_frames, scan.dropped, scan.problem()) == (20, [], None)
    assert count_frames(tmp_path / "v.mp4") == 20


def test_damaged_video_names_the_dropped_frame_numbers(tmp_path):
    bad = _damaged(_video(tmp_path / "v.mp4"), tmp_path / "bad.mp4")
    scan = scan_video(bad)
    assert scan.n_frames == 19 and scan.dropped == [7]
    assert "1 frame(s) could not be decoded (frame numbers by timestamp: 7)" in scan.problem()


def test_stream_shorter_than_container_is_said():
    scan = VideoScan(n_frames=8, container_frames=10)
    assert "ends 2 frame(s) before the container's count (10)" in scan.problem()


def test_damaged_video_reaches_the_results_warnings(tmp_path):
    import dynaeval

    (tmp_path / "gt").mkdir()
    (tmp_path / "pred").mkdir()
    _video(tmp_path / "gt" / "cam0.mp4")
    _damaged(tmp_path / "gt" / "cam0.mp4", tmp_path / "pred" / "cam0.mp4")
    pairing = pair_frames(tmp_path / "pred", tmp_path / "gt", allow_missing=True)
    assert [w["camera"] for w in pairing.warnings] == ["cam0"]
    res = dynaeval.score(tmp_path / "pred", tmp_path / "gt", allow_missing=True,
                         focus=FocusConfig(source="none", masked=False), temporal=False,
                         progress=False)
    got = [w["reason"] for w in res["warnings"] if "damaged video" in w["reason"]]
    assert len(got) == 1 and "pred/cam0.mp4: damaged video" in got[0] and "timestamp: 7" in got[0]


def test_unreadable_video_is_named(tmp_path, monkeypatch):
    path = _video(tmp_path / "v.mp4", n=3)
    import builtins

    real = builtins.open

    def refuse(file, *a, **k):  # noqa: ANN001, ANN202
        if str(file) == str(path):
            raise PermissionError(13, "Permission denied", str(file))
        return real(file, *a, **k)

    monkeypatch.setattr(builtins, "open", refuse)
    with pytest.raises(InputError, match=r"v\.mp4: cannot read the video file: permission denied"):
        scan_video(path)


def test_reader_reads_past_a_damaged_frame(tmp_path):
    """OpenCV 5.1 fails the grab of a damaged frame and decodes the next ones on later calls:
    the reader takes the frames after it (19 of 20), the same frames the scan counts."""
    from dynaeval.io.video import VideoReader

    bad = _damaged(_video(tmp_path / "v.mp4"), tmp_path / "bad.mp4")
    reader = VideoReader(bad)
    frames = [reader.read(i) for i in range(scan_video(bad).n_frames)]
    assert len(frames) == 19 and frames[-1].shape == (48, 64, 3)
    with pytest.raises(InputError, match="frame 19"):
        reader.read(19)

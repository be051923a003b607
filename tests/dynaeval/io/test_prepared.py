"""The prepared folder's background writer (issue 33, prepare's speed): the digests it takes
as it writes are the files' own, and a failed write reaches the caller, the same exception,
with nothing written after it and nothing writing once the caller has left."""

from __future__ import annotations

import errno
import os
import threading
import time

import numpy as np
import pytest

from dynaeval.io import prepared
from dynaeval.io.prepared import FolderWriter, file_digest, folder_digests, saved_digest


@pytest.mark.parametrize("array", [
    np.arange(24, dtype=np.float32).reshape(2, 3, 4),
    np.asfortranarray(np.arange(12.0).reshape(3, 4)),  # written in Fortran order
    np.arange(12, dtype=">i4").reshape(3, 4)[:, ::2],  # not contiguous: saved as a copy
    np.zeros((0, 5), np.uint8),
    np.arange(7, dtype=np.uint8),
], ids=["c", "fortran", "strided", "empty", "1d"])
def test_saved_digest_is_the_files_digest_and_numpy_save_wrote_it(tmp_path, array):
    got = saved_digest(tmp_path / "a.npy", array)
    assert got == file_digest(tmp_path / "a.npy")
    np.save(tmp_path / "b.npy", array)
    assert (tmp_path / "a.npy").read_bytes() == (tmp_path / "b.npy").read_bytes()


def test_the_writer_writes_in_the_background_with_the_files_digests(tmp_path):
    arrays = {f"x/{k}.npy": np.full((64, 64), k, np.float32) for k in range(5)}
    (tmp_path / "x").mkdir()
    with FolderWriter(tmp_path, max_pending=3 * 64 * 64 * 4) as writer:  # waits for the disk
        for rel, a in arrays.items():
            writer.save(rel, a)
        writer.write("x/r.npz", lambda path: np.savez_compressed(path, a=np.eye(3)))
        assert "x/3.npy" in writer and "x/9.npy" not in writer
        written = writer.finish()
    assert written == folder_digests(tmp_path)
    assert folder_digests(tmp_path, written) == folder_digests(tmp_path)
    for rel, a in arrays.items():
        np.testing.assert_array_equal(np.load(tmp_path / rel), a)


def _failing_save(after: int, err: BaseException):
    calls = {"n": 0}
    real = np.save

    def save(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > after:
            raise err
        return real(*args, **kwargs)

    return save, calls


def test_a_failed_write_is_raised_in_the_callers_thread_and_stops_the_writes(tmp_path,
                                                                                monkeypatch):
    full = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    save, calls = _failing_save(1, full)
    monkeypatch.setattr(np, "save", save)
    with pytest.raises(OSError) as caught, FolderWriter(tmp_path) as writer:
        writer.save("a.npy", np.zeros(4))
        writer.save("b.npy", np.zeros(4))  # fails in the writer's thread
        deadline = time.monotonic() + 10
        while calls["n"] < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        writer.save("c.npy", np.zeros(4))  # raises the failure here
        raise AssertionError("not reached")
    assert caught.value is full
    assert calls["n"] == 2  # nothing written after the failure
    assert not (tmp_path / "c.npy").exists()


def test_finish_raises_the_failure(tmp_path, monkeypatch):
    save, _ = _failing_save(0, PermissionError(errno.EROFS, os.strerror(errno.EROFS)))
    monkeypatch.setattr(np, "save", save)
    writer = FolderWriter(tmp_path)
    writer.save("a.npy", np.zeros(4))
    with pytest.raises(PermissionError):
        writer.finish()


def test_leaving_by_an_interrupt_waits_for_the_file_being_written(tmp_path, monkeypatch):
    """Ctrl-C while files are queued: what is queued is dropped, the file being written is
    finished before the block is left, so the caller can remove the folder for good."""
    started, release = threading.Event(), threading.Event()
    done = []
    real = prepared.saved_digest

    def slow(path, array):
        started.set()
        release.wait(10)
        out = real(path, array)
        done.append(path.name)
        return out

    monkeypatch.setattr(prepared, "saved_digest", slow)
    timer = threading.Timer(0.2, release.set)
    with pytest.raises(KeyboardInterrupt), FolderWriter(tmp_path) as writer:
        for k in range(4):
            writer.save(f"{k}.npy", np.zeros(4))
        started.wait(10)
        timer.start()
        raise KeyboardInterrupt
    assert done == ["0.npy"]  # the one being written when the interrupt came, and no other
    assert not writer._thread.is_alive()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["0.npy"]

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


def _counting_hashes(monkeypatch) -> list[int]:
    """Count the files ``file_digest`` reads (blake2b objects of 20 bytes made)."""
    import hashlib

    made, real = [], hashlib.blake2b

    def blake2b(*args, **kwargs):
        if kwargs.get("digest_size") == 20:
            made.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(prepared.hashlib, "blake2b", blake2b)
    return made


def test_file_digest_hashes_an_unchanged_file_once_per_process(tmp_path, monkeypatch):
    monkeypatch.setattr(prepared, "_DIGESTS", {})
    monkeypatch.setattr(prepared, "RACY_SECONDS", 0.0)
    made = _counting_hashes(monkeypatch)
    f = tmp_path / "a.bin"
    f.write_bytes(b"x" * 5000)
    first = file_digest(f)
    assert file_digest(f) == file_digest(str(f)) == first and len(made) == 1


def test_file_digest_sees_every_change_even_with_the_size_and_mtime_kept(tmp_path, monkeypatch):
    """Rewritten in place with the same size and its mtime set back, or replaced by rename:
    the status-change time (or the inode) differs, so the file is hashed again."""
    import hashlib

    monkeypatch.setattr(prepared, "_DIGESTS", {})
    monkeypatch.setattr(prepared, "RACY_SECONDS", 0.0)
    f = tmp_path / "a.bin"
    f.write_bytes(b"x" * 5000)
    before = os.stat(f)
    old = file_digest(f)
    with open(f, "r+b") as g:
        g.write(b"y")
    os.utime(f, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert os.stat(f).st_size == before.st_size and os.stat(f).st_mtime_ns == before.st_mtime_ns
    now = file_digest(f)
    assert now != old and now == hashlib.blake2b(f.read_bytes(), digest_size=20).hexdigest()
    (tmp_path / "b.bin").write_bytes(b"z" * 5000)
    os.replace(tmp_path / "b.bin", f)
    assert file_digest(f) == hashlib.blake2b(b"z" * 5000, digest_size=20).hexdigest()


def test_a_file_changed_just_before_it_was_hashed_is_not_remembered(tmp_path, monkeypatch):
    monkeypatch.setattr(prepared, "_DIGESTS", {})
    made = _counting_hashes(monkeypatch)
    f = tmp_path / "a.bin"
    f.write_bytes(b"x" * 5000)  # its status changed now: within RACY_SECONDS
    file_digest(f)
    file_digest(f)
    assert len(made) == 2 and not prepared._DIGESTS


def test_a_second_prepared_run_in_one_process_does_not_hash_the_folder_again(tmp_path, monkeypatch):
    """Two PreparedFiles of one folder (a suite's scorings of one scene): the files are hashed
    by the first only, and a file changed in between is still refused by the second."""
    from dynaeval.errors import InputError

    monkeypatch.setattr(prepared, "_DIGESTS", {})
    monkeypatch.setattr(prepared, "RACY_SECONDS", 0.0)
    np.save(tmp_path / "a.npy", np.arange(10.0))
    np.save(tmp_path / "b.npy", np.arange(20.0))
    digests = folder_digests(tmp_path)
    made = _counting_hashes(monkeypatch)
    for _ in range(2):
        files = prepared.PreparedFiles(tmp_path, digests)
        assert files.load("a.npy").sum() == 45 and files.load("b.npy").sum() == 190
    assert len(made) == 0  # folder_digests above hashed them already, in this process
    st = os.stat(tmp_path / "b.npy")
    with open(tmp_path / "b.npy", "r+b") as g:
        g.seek(-1, 2)
        g.write(b"\x01")
    os.utime(tmp_path / "b.npy", ns=(st.st_atime_ns, st.st_mtime_ns))
    with pytest.raises(InputError, match="changed or truncated"):
        prepared.PreparedFiles(tmp_path, digests).load("b.npy")


def test_an_unreadable_prepared_file_is_exit_2_naming_it(tmp_path, monkeypatch):
    """Issue 43 item 4: a prepared file without read permission was a PermissionError
    traceback. (Tests may run as root, where chmod does not stop a read: the open is made to
    fail as it does for another user.)"""
    from dynaeval.errors import InputError

    target = tmp_path / "a.npy"
    np.save(target, np.zeros(3))
    files = prepared.PreparedFiles(tmp_path, {"a.npy": file_digest(target)})
    real_open = open

    def no_permission(path, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003
        if str(path) == str(target):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr("builtins.open", no_permission)
    prepared._DIGESTS.clear()
    with pytest.raises(InputError, match=r"a\.npy: cannot read this prepared file \(Permission denied\)"):
        files.path("a.npy")


@pytest.mark.parametrize("hashes", ["abc", None, 5, {"a.npy": 5}])
def test_a_manifest_with_tables_of_the_wrong_type_is_refused_naming_the_key(tmp_path, hashes):
    """Issue 43 item 4: a manifest whose `hashes` had the wrong type (its id computed again) was
    a ValueError or TypeError deep in a run."""
    import json

    from dynaeval.errors import InputError

    manifest = {"format_version": prepared.FORMAT_VERSION, "files": {}, "hashes": hashes}
    manifest["id"] = prepared.manifest_id(manifest)
    (tmp_path / prepared.MANIFEST).write_text(json.dumps(manifest))
    with pytest.raises(InputError, match="the manifest's 'hashes' must map file paths to digests"):
        prepared.read_manifest(tmp_path)

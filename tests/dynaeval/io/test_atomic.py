"""Atomic writes: content, refusal to overwrite, no leftovers, ordinary permissions."""

from __future__ import annotations

import os
import stat

import pytest

from dynaeval.errors import InputError
from dynaeval.io.atomic import write_text_atomic


def test_writes_replaces_only_when_asked_and_leaves_no_temporary(tmp_path):
    out = tmp_path / "r.json"
    write_text_atomic(out, "one")
    with pytest.raises(InputError, match="exists; pass --overwrite"):
        write_text_atomic(out, "two")
    assert out.read_text() == "one"
    write_text_atomic(out, "two", overwrite=True)
    assert out.read_text() == "two"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_missing_folders_are_created_and_a_failed_write_removes_them(tmp_path, monkeypatch):
    """The one rule of every output (issue 32, item 8: -o in a missing folder was refused):
    missing folders are created when the file is written; a write that fails removes those it
    created; a path under a file is refused naming the file."""
    from dynaeval.io import atomic

    out = write_text_atomic(tmp_path / "new" / "deeper" / "r.json", "x")
    assert out.read_text() == "x"
    (tmp_path / "keep").mkdir()

    def fail(*args):
        raise OSError("disk full")

    monkeypatch.setattr(atomic, "_stage", fail)
    with pytest.raises(OSError, match="disk full"):
        write_text_atomic(tmp_path / "keep" / "a" / "b" / "r.json", "x")
    assert list((tmp_path / "keep").iterdir()) == []  # a/ and a/b/ removed, keep/ kept
    monkeypatch.undo()
    with pytest.raises(InputError, match=r"r\.json/sub: cannot create the folder for the "
                                         r"output file"):
        write_text_atomic(out / "sub" / "x.json", "x")


def test_file_gets_the_permissions_of_a_plain_open(tmp_path):
    """mkstemp creates 0600 files; a results file others cannot read would be a surprise."""
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    atomic = write_text_atomic(tmp_path / "atomic.txt", "x")
    mode = stat.S_IMODE(os.stat(atomic).st_mode)
    assert mode == stat.S_IMODE(os.stat(plain).st_mode)


def test_racing_writers_exactly_one_wins(tmp_path, monkeypatch):
    """Issue 16 item 3. Every writer has finished its temporary file (and passed the existence
    check) before any moves it into place: the barrier in fsync makes the worst interleaving the
    only one. Check-then-replace lets all of them 'succeed'; the exclusive link lets one."""
    import threading

    from dynaeval.io import atomic

    n = 6
    barrier = threading.Barrier(n, timeout=20)
    monkeypatch.setattr(atomic.os, "fsync", lambda fd: barrier.wait())
    out = tmp_path / "r.json"
    won, lost = [], []

    def writer(i: int) -> None:
        try:
            write_text_atomic(out, f"writer {i}", what="results file")
            won.append(i)
        except InputError as err:
            lost.append(str(err))

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert not any(t.is_alive() for t in threads)
    assert len(won) == 1 and len(lost) == n - 1
    assert all("results file exists (another run wrote it meanwhile?)" in m for m in lost)
    assert out.read_text() == f"writer {won[0]}"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]  # no temporary left


def test_overwrite_replaces_even_when_racing(tmp_path):
    out = tmp_path / "r.json"
    out.write_text("old")
    write_text_atomic(out, "new", overwrite=True)
    assert out.read_text() == "new"


def test_without_hard_links_the_name_is_reserved_exclusively(tmp_path, monkeypatch):
    from dynaeval.io import atomic

    def no_link(src, dst):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(atomic.os, "link", no_link)
    out = tmp_path / "r.json"
    write_text_atomic(out, "one")
    assert out.read_text() == "one"
    real_exists = atomic.refuse_existing
    monkeypatch.setattr(atomic, "refuse_existing", lambda *a, **k: None)  # the target appears late
    with pytest.raises(InputError, match="exists \\(another run wrote it meanwhile\\?\\)"):
        write_text_atomic(out, "two")
    monkeypatch.setattr(atomic, "refuse_existing", real_exists)
    assert out.read_text() == "one"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_write_into_a_folder_or_unwritable_place_is_an_input_error(tmp_path):
    (tmp_path / "d").mkdir()
    with pytest.raises(InputError, match="must be a file, but this is a folder"):
        write_text_atomic(tmp_path / "d", "x", overwrite=True)
    if os.path.isdir("/proc/self"):
        with pytest.raises(InputError, match="/proc: cannot write the output file in this folder"):
            write_text_atomic("/proc/x.json", "x")


# -- check_writable: every output checked before the work -----------------------------------


def test_check_writable_accepts_a_new_file_and_leaves_nothing(tmp_path):
    from dynaeval.io.atomic import check_writable

    check_writable(tmp_path / "r.json", overwrite=False)
    check_writable(None, overwrite=False)
    check_writable(tmp_path / "new" / "deeper", overwrite=False, folder=True)
    check_writable(tmp_path / "new" / "b.json", overwrite=False)
    check_writable(tmp_path / "new" / "deeper" / "b.json", overwrite=False)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("case,message", [
    ("folder", r"d: the results file must be a file, but this is a folder"),
    ("exists", r"r\.json: results file exists; pass --overwrite"),
    ("image", r"0000\.png: refusing to write the results file over an existing image or video"),
    ("video", r"cam\.mp4: refusing to write the results file over an existing image or video"),
    ("input", r"in\.json: the results file would replace an input of this run"),
    ("parent-file", r"r\.json: the results file would be under this file, which is not a "
                    "folder; choose another path"),
    ("grandparent-file", r"r\.json: the results file would be under this file"),
])
def test_check_writable_refuses(tmp_path, case, message):
    from dynaeval.io.atomic import check_writable

    (tmp_path / "d").mkdir()
    for name in ("r.json", "0000.png", "cam.mp4", "in.json"):
        (tmp_path / name).write_text("keep")
    path = {"folder": tmp_path / "d", "grandparent-file": tmp_path / "r.json" / "x" / "y.json",
            "exists": tmp_path / "r.json", "image": tmp_path / "0000.png",
            "video": tmp_path / "cam.mp4", "input": tmp_path / "in.json",
            "parent-file": tmp_path / "r.json" / "x.json"}[case]
    with pytest.raises(InputError, match=message):
        check_writable(path, overwrite=case not in ("exists",), what="results file",
                       inputs=[tmp_path / "in.json"])
    assert all((tmp_path / n).read_text() == "keep" for n in ("r.json", "0000.png", "in.json"))


def test_check_writable_report_folder_that_is_a_file(tmp_path):
    from dynaeval.io.atomic import check_writable

    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"f: the report folder must be a folder, but this is a file"):
        check_writable(tmp_path / "f", overwrite=True, what="report folder", folder=True)


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc")
def test_check_writable_unwritable_folder(tmp_path):
    """/proc refuses new files even to root (a chmod 0555 folder would not stop root)."""
    from dynaeval.io.atomic import check_writable

    with pytest.raises(InputError, match=r"/proc: cannot write the results file in this folder"):
        check_writable("/proc/x.json", overwrite=True, what="results file")


def test_check_writable_read_only_folder(tmp_path):
    from dynaeval.io.atomic import check_writable

    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK) and os.geteuid() == 0:
            pytest.skip("root writes into a 0555 folder; /proc covers the refusal")
        with pytest.raises(InputError, match=r"ro: cannot write the results file in this folder"):
            check_writable(ro / "r.json", overwrite=False, what="results file")
    finally:
        ro.chmod(0o755)


def test_several_files_are_written_as_one(tmp_path, monkeypatch):
    """write_files_atomic (issue 34, item 2): when the second file cannot be placed, the first,
    already placed, is taken back (a new one removed, a replaced one restored)."""
    from dynaeval.io import atomic
    from dynaeval.io.atomic import write_files_atomic

    (tmp_path / "a.txt").write_text("old a")
    real = atomic._place

    def place(tmp, path, overwrite, what):
        if path.name == "b.txt":
            raise InputError("b.txt appeared meanwhile", path=path)
        real(tmp, path, overwrite, what)

    monkeypatch.setattr(atomic, "_place", place)
    files = [(tmp_path / "a.txt", "new a", "A"), (tmp_path / "c" / "c.txt", "c", "C"),
             (tmp_path / "b.txt", "b", "B")]
    with pytest.raises(InputError, match="appeared meanwhile"):
        write_files_atomic(files, overwrite=True)
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a.txt"]  # no c/, no temporary file
    assert (tmp_path / "a.txt").read_text() == "old a"
    monkeypatch.undo()
    assert write_files_atomic(files, overwrite=True) == [f[0] for f in files]
    assert [f[0].read_text() for f in files] == ["new a", "c", "b"]


def test_write_failure_tells_a_full_disk_from_a_bug(tmp_path):
    import errno

    from dynaeval.io.atomic import write_failure

    full = write_failure(OSError(errno.ENOSPC, "No space left on device"), tmp_path / "r.json",
                         "results file")
    assert "r.json: cannot write the results file: no space left on the device; free space " \
           "there or choose another path" in str(full)
    assert "read-only file system; choose another path" in str(
        write_failure(OSError(errno.EROFS, "x"), tmp_path / "r.json", "results file"))
    assert write_failure(OSError(errno.EBADF, "x"), tmp_path, "results file") is None
    # no errno (numpy's short write): a full disk only where little is free
    assert write_failure(OSError("9216 requested and 3968 written"), tmp_path, "x") is None

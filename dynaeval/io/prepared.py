"""The files of a prepared ground truth (``dynaeval prepare``): a folder with ``manifest.json``,
compressed ``.npz`` region files and uncompressed ``.npy`` flows, written atomically.

This module knows the folder, not what is in it: content hashes of the ground-truth files, the
manifest's format version, and the atomic write of a whole folder (built under a temporary name
beside the target, then renamed into place: a failed run leaves nothing behind, and an existing
folder is replaced only with ``overwrite``). ``dynaeval.run.prepare`` fills it.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.io.atomic import _UMASK, parent_folders, write_failure
from dynaeval.io.jsonfile import read_json

FORMAT_VERSION = 4
"""Version of the prepared folder's layout; a folder of another version is refused. 2: the
manifest holds the digest of every prepared file (``hashes``), checked when the file is read.
3: each frame's regions carry their statuses (``boxes_status``, ``mask_status``: why a region
is missing), which a version-2 folder lacks and would have reported as ``no-region``.
4: the ground-truth half of every temporal pair (``gt_pairs``: its visibility mask as
``visible/<key>.npy``, its warping errors), which a scoring run read from a version-3 folder
would compute again (a suite re-prepares such a folder: its key holds this version)."""
MANIFEST = "manifest.json"


RACY_SECONDS = 2.0
"""A file whose status changed less than this before it was hashed is not remembered: a change
within the same timestamp tick of a coarse file system could leave its stamp as it was."""
_DIGESTS: dict[str, tuple[tuple[int, ...], str]] = {}
"""Absolute path -> (stamp, digest) of the files this process hashed (``file_digest``)."""
_DIGESTS_LOCK = threading.Lock()


def file_digest(path: str | Path) -> str:
    """blake2b (20 bytes, hex) of a file's bytes: a ground-truth file's identity.

    Remembered for the process by the file's stamp (device, inode, size, modification and
    status-change times in ns, read from the open file), as git's index does: a suite's
    scorings of one prepared folder, and its keys of the same inputs, hash each file once. Any
    write, truncation, replacement or ``touch`` changes the status-change time, which no user
    can set back, so a changed file is always hashed again."""
    key = os.path.abspath(path)
    with open(path, "rb") as f:
        st = os.fstat(f.fileno())
        stamp = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
        with _DIGESTS_LOCK:
            known = _DIGESTS.get(key)
        if known is not None and known[0] == stamp:
            return known[1]
        h = hashlib.blake2b(digest_size=20)
        for block in iter(lambda: f.read(1 << 22), b""):
            h.update(block)
    digest = h.hexdigest()
    if time.time_ns() - st.st_ctime_ns > RACY_SECONDS * 1e9:
        with _DIGESTS_LOCK:
            _DIGESTS[key] = (stamp, digest)
    return digest


def json_digest(obj: Any, size: int) -> str:
    """blake2b (``size`` bytes, hex) of ``obj``'s canonical JSON (keys sorted, no spaces), so
    equal documents have equal digests whatever their key order."""
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"))
    return hashlib.blake2b(text.encode(), digest_size=size).hexdigest()


def manifest_id(manifest: dict[str, Any]) -> str:
    """The id of a manifest: ``json_digest`` (10 bytes) of it without the ``id`` field."""
    return json_digest({k: v for k, v in manifest.items() if k != "id"}, 10)


def read_manifest(folder: str | Path) -> dict[str, Any]:
    """The checked manifest of a prepared folder.

    Raises:
        InputError: no such folder or manifest, unreadable JSON, another format version, an
            id that does not match the content (edited by hand), or tables of the wrong type.
    """
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise InputError("not a prepared ground truth (no manifest.json): make one with "
                         "'dynaeval prepare GT -o PREP'", path=folder)
    manifest = read_json(path, what="prepared ground truth's manifest",
                         fix="prepare it again: 'dynaeval prepare GT -o PREP'")
    version = manifest.get("format_version") if isinstance(manifest, dict) else None
    if version != FORMAT_VERSION:
        raise InputError(f"prepared ground truth of format version {version!r}; this dynaeval "
                         f"reads version {FORMAT_VERSION}: prepare it again ('dynaeval prepare "
                         "GT -o PREP --overwrite')", path=path)
    if manifest.get("id") != manifest_id(manifest):
        raise InputError("the prepared ground truth's manifest was changed after it was written "
                         "(its id does not match): prepare it again", path=path)
    _check_shapes(manifest, path)
    return manifest


_DIGEST_TABLES = ("files", "hashes")
"""Manifest keys that map a relative path to a digest (both strings)."""
_TABLES = ("settings", "cameras", "decoded")
"""Manifest keys that hold an object."""


def _check_shapes(manifest: dict[str, Any], path: Path) -> None:
    """Refuse a manifest whose tables have the wrong types (hand-edited with its id computed
    again): they were a ValueError or TypeError deep in a run. InputError names the key."""
    for key in _DIGEST_TABLES:
        table = manifest.get(key)
        if not isinstance(table, dict) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in table.items()):
            raise InputError(f"the manifest's {key!r} must map file paths to digests (strings), "
                             f"got {type(table).__name__}; prepare it again ('dynaeval prepare GT "
                             "-o PREP --overwrite')", path=path)
    for key in _TABLES:
        if key in manifest and not isinstance(manifest[key], dict):
            raise InputError(f"the manifest's {key!r} must be an object, got "
                             f"{type(manifest[key]).__name__}; prepare it again ('dynaeval "
                             "prepare GT -o PREP --overwrite')", path=path)


def write_folder_atomic(out: str | Path, fill: Callable[[Path], None], *,
                        overwrite: bool = False, what: str = "prepared folder") -> Path:
    """Build a folder with ``fill(tmp)`` under a temporary name beside ``out``, then rename it
    to ``out``: exclusively (InputError if ``out`` exists), or with ``overwrite`` replacing it.
    Missing folders above ``out`` are created (``dynaeval.io.atomic.parent_folders``, the rule
    of every output). On any failure the temporary folder and the folders created are removed
    and ``out`` is untouched."""
    out = Path(out)
    if out.exists() and not overwrite:
        raise InputError(f"{what} exists; pass --overwrite or choose another -o", path=out)
    with parent_folders(out, what):
        return _fill_and_rename(out, fill, overwrite, what)


def _fill_and_rename(out: Path, fill: Callable[[Path], None], overwrite: bool, what: str) -> Path:
    """``write_folder_atomic``'s body, once ``out``'s parent folder exists."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    try:
        fill(tmp)
        os.chmod(tmp, 0o777 & ~_umask())
        if out.exists():
            if not overwrite:
                raise InputError(f"{what} exists (another run wrote it meanwhile?); pass "
                                 "--overwrite or choose another -o", path=out)
            old = out.with_name(f".{out.name}.old.{os.getpid()}")
            os.rename(out, old)
            os.rename(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(tmp, out)
    except BaseException as err:
        failure = write_failure(err, out, what) if isinstance(err, OSError) else None
        shutil.rmtree(tmp, ignore_errors=True)
        if failure is not None:
            raise failure from err
        raise
    return out


PREPARE_AGAIN = "prepare it again: dynaeval prepare GT -o PREP --overwrite"


def folder_digests(folder: str | Path, known: dict[str, str] | None = None) -> dict[str, str]:
    """``file_digest`` of every file under ``folder`` but the manifest, by its path relative to
    ``folder`` (``/``-separated): what ``PreparedFiles`` checks them against. ``known``: digests
    of files by that path, taken as they were written (``FolderWriter.finish``), not read again."""
    folder, known = Path(folder), known or {}
    rels = (p.relative_to(folder).as_posix() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != MANIFEST)
    return {rel: known[rel] if rel in known else file_digest(folder / rel) for rel in rels}


WRITE_AHEAD_BYTES = 256 * 2**20
"""Bytes of arrays a ``FolderWriter`` holds queued before ``save`` waits for the disk."""


def saved_digest(path: Path, array: np.ndarray) -> str:
    """``numpy.save`` of ``array`` as ``path`` and the file's ``file_digest``, from the bytes
    written: the header read back and the array's memory (what ``tofile`` wrote), not a second
    pass over the file. An array whose bytes are not its memory in C order (Fortran-ordered,
    objects) is hashed from the file."""
    with open(path, "wb") as f:
        np.save(f, array)
        size = f.tell()
    if not array.flags.c_contiguous or array.dtype.hasobject or size < array.nbytes:
        return file_digest(path)
    h = hashlib.blake2b(digest_size=20)
    with open(path, "rb") as f:
        h.update(f.read(size - array.nbytes))
    h.update(array.reshape(-1).view(np.uint8))
    return h.hexdigest()


class FolderWriter:
    """Writes the files of a folder being built in one background thread, in the order given,
    with the digest of each (``file_digest``) taken as it is written: writing and hashing
    release the GIL, so they overlap the caller's work instead of adding to it.

    A failed write (a full disk, a read-only place) is raised in the caller's thread, the same
    exception, by the next ``save``/``write`` or by ``finish``; nothing is written after it.
    Used as a context manager: leaving the block by an exception (an interrupt) drops what is
    queued and waits for the file being written, so that the caller can remove the folder
    knowing nothing writes into it any more.
    """

    def __init__(self, root: str | Path, max_pending: int = WRITE_AHEAD_BYTES) -> None:
        self.root = Path(root)
        self.digests: dict[str, str] = {}
        self._max = max_pending
        self._jobs: deque[tuple[str, int, Callable[[Path], str]]] = deque()
        self._names: set[str] = set()
        self._pending = 0
        self._error: BaseException | None = None
        self._closed = False
        self._cv = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="dynaeval-prepared-writer",
                                        daemon=True)
        self._thread.start()

    def __contains__(self, rel: str) -> bool:
        """Whether ``rel`` was queued (or written)."""
        with self._cv:
            return rel in self._names

    def save(self, rel: str, array: np.ndarray) -> None:
        """``numpy.save`` of ``array`` as ``root/rel``, queued: ``array`` must not change after."""
        self._put(rel, array.nbytes, lambda path: saved_digest(path, array))

    def write(self, rel: str, write: Callable[[Path], None]) -> None:
        """``write(root/rel)``, queued (a small file: its digest is read from it)."""
        self._put(rel, 0, lambda path: (write(path), file_digest(path))[1])

    def _put(self, rel: str, nbytes: int, job: Callable[[Path], str]) -> None:
        with self._cv:
            while self._error is None and self._pending and self._pending + nbytes > self._max:
                self._cv.wait()
            if self._error is not None:
                raise self._error
            self._jobs.append((rel, nbytes, job))
            self._names.add(rel)
            self._pending += nbytes
            self._cv.notify_all()

    def _run(self) -> None:
        while True:
            with self._cv:
                while not self._jobs and not self._closed:
                    self._cv.wait()
                if not self._jobs:
                    return
                rel, nbytes, job = self._jobs.popleft()
            try:
                digest = job(self.root / rel)
            except BaseException as err:  # raised in the caller's thread
                with self._cv:
                    self._error = err
                    self._jobs.clear()
                    self._cv.notify_all()
                return
            with self._cv:
                self.digests[rel] = digest
                self._pending -= nbytes
                self._cv.notify_all()

    def finish(self) -> dict[str, str]:
        """Wait until every queued file is written; their digests by path.

        Raises:
            The first failed write's exception (``OSError``: a full disk, a read-only place).
        """
        with self._cv:
            self._closed = True
            self._cv.notify_all()
        self._thread.join()
        if self._error is not None:
            raise self._error
        return dict(self.digests)

    def __enter__(self) -> FolderWriter:
        return self

    def __exit__(self, kind: type | None, *_: Any) -> None:
        if kind is None:
            self.finish()
            return
        with self._cv:  # an error or an interrupt: write nothing more
            self._jobs.clear()
            self._closed = True
            self._cv.notify_all()
        while self._thread.is_alive():  # the file being written is finished before we go on
            try:
                self._thread.join()
            except KeyboardInterrupt:  # a second Ctrl-C: still wait for that one file
                continue


class PreparedFiles:
    """The files of a prepared folder, each checked against the manifest's digest the first
    time it is read (a file changed, truncated or deleted after ``dynaeval prepare`` would
    otherwise give other numbers, silently). Thread-safe. Reading a file costs one extra pass
    over its bytes (blake2b, ~1 GB/s), once per process while the file's stamp is unchanged
    (``file_digest`` remembers it: a suite's second and third scorings of a scene do not hash its
    prepared folder again)."""

    def __init__(self, root: str | Path, digests: dict[str, str]) -> None:
        self.root = Path(root)
        self.digests = dict(digests)
        self._checked: set[str] = set()
        self._pending: dict[str, Future] = {}
        self._lock = threading.Lock()

    def check_in_background(self, rels: list[str]) -> None:
        """Start checking ``rels`` in this order in one background (daemon) thread: hashing
        releases the GIL, so it overlaps the run's own work instead of adding to it. ``path``
        of one of them waits for its check (and raises its error)."""
        todo = [r for r in dict.fromkeys(rels) if r not in self._checked]
        with self._lock:
            for rel in todo:
                self._pending.setdefault(rel, Future())

        def work() -> None:
            for rel in todo:
                future = self._pending[rel]
                if future.done():
                    continue
                try:
                    self._check(rel)
                    future.set_result(None)
                except BaseException as err:  # handed to the reader, raised there
                    future.set_exception(err)

        threading.Thread(target=work, name="dynaeval-prepared-check", daemon=True).start()

    def path(self, rel: str) -> Path:
        """``root/rel``, checked (waiting for its background check, if one was started).

        Raises:
            InputError: naming the file: not in the manifest, missing, or its digest differs
                (changed or truncated); each with the fix (prepare again).
        """
        with self._lock:
            future = self._pending.get(rel)
        if future is not None:
            future.result()
        else:
            self._check(rel)
        return self.root / rel

    def _check(self, rel: str) -> None:
        """Check ``root/rel`` against the manifest once (see ``path``)."""
        with self._lock:
            if rel in self._checked:
                return
        target = self.root / rel
        if rel not in self.digests:
            raise InputError(f"this prepared file is not listed in the manifest; {PREPARE_AGAIN}",
                             path=target)
        if not target.is_file():
            raise InputError("this prepared file is missing (deleted after 'dynaeval prepare'?); "
                             f"{PREPARE_AGAIN}", path=target)
        try:
            digest = file_digest(target)
        except OSError as err:  # no read permission, an I/O error: the user's to fix
            raise InputError(f"cannot read this prepared file ({err.strerror or err}); make it "
                             f"readable, or {PREPARE_AGAIN}", path=target) from None
        if digest != self.digests[rel]:
            raise InputError("this prepared file was changed or truncated after 'dynaeval "
                             f"prepare' (its digest differs from the manifest's); {PREPARE_AGAIN}",
                             path=target)
        with self._lock:
            self._checked.add(rel)

    def load(self, rel: str, *, mmap: bool = False) -> Any:
        """``numpy.load`` of the checked file ``rel`` (memory-mapped, read-only, with ``mmap``;
        an ``.npz`` as its ``NpzFile``)."""
        path = self.path(rel)
        try:
            return np.load(path, mmap_mode="r" if mmap else None)
        except (OSError, ValueError) as err:  # the digest matched: written broken (a bug)
            raise InputError(f"cannot read this prepared file ({err}); {PREPARE_AGAIN}",
                             path=path) from err


def _umask() -> int:
    return _UMASK

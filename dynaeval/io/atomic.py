"""Writing output files atomically and exclusively: a failed or interrupted run never leaves a
half-written file, and of two runs racing for one path exactly one wins.

One rule for every output (``score -o``, ``--report``, ``--3dgs-json``, ``prepare -o``,
``detect -o``, ``leaderboard -o``, ``merge -o``): missing folders above it are created, when it
is written (``parent_folders``: those it created are removed again if the write fails).
``check_writable`` is called by the CLI for every output before any frame is read, so a bad
``-o`` / ``--report`` (a path under a file, a folder that cannot be created) fails in a second,
not after the whole run, and creates nothing; ``write_text_atomic`` makes the final step
exclusive (``os.link`` of the finished temporary file, which fails if the target appeared
meanwhile), or ``os.replace`` with ``overwrite``.
"""

from __future__ import annotations

import errno
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from pathlib import Path

from dynaeval.core.errors import InputError
from dynaeval.io.images import IMAGE_EXTENSIONS
from dynaeval.io.video import VIDEO_EXTENSIONS


def refuse_existing(path: str | Path | None, *, overwrite: bool, what: str = "output file") -> None:
    """Raise InputError when ``path`` exists and ``overwrite`` is False (None: nothing to check).

    Callers that run long before writing check this first (``check_writable`` does, and more),
    so a finished run is never refused at the end; ``write_text_atomic`` checks it again, and
    atomically, when it writes.
    """
    if path is not None and Path(path).exists() and not overwrite:
        raise InputError(f"{what} exists; pass --overwrite or choose another -o", path=path)


def _media_extensions() -> frozenset[str]:
    return frozenset(IMAGE_EXTENSIONS) | frozenset(VIDEO_EXTENSIONS)


def _probe_folder(folder: Path, what: str) -> None:
    """Create and remove a file in ``folder``: the one test that holds for read-only mounts,
    ``/proc`` and root (``os.access`` says yes to root on a read-only folder)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".dynaeval-check.", suffix=".tmp", dir=folder)
    except OSError as err:
        raise InputError(f"cannot write the {what} in this folder ({err.strerror or err})",
                         path=folder) from err
    os.close(fd)
    Path(probe).unlink(missing_ok=True)


def check_writable(
    path: str | Path | None, *, overwrite: bool, what: str = "output file",
    inputs: Iterable[str | Path | None] = (), folder: bool = False,
) -> None:
    """Check, before any work, that ``path`` can be written (None: nothing to check). Missing
    folders above it are fine (the writer creates them): the nearest existing one must be a
    writable folder. Nothing is created here.

    Args:
        path: the output: a file (``-o``), or with ``folder`` a folder (``--report DIR``).
        overwrite: an existing file may be replaced (``--overwrite``).
        what: what the output is, for messages ("results file", "report folder", ...).
        inputs: the run's input paths (files or folders); the output may be none of them.
        folder: ``path`` is a folder the writer creates (with its parents) if missing.

    Raises:
        InputError: naming the path: it is a folder (a file was expected) or a file (a folder
            was expected); it exists and not ``overwrite``; it is one of the inputs, or an
            existing image or video file (never replaced, even with ``overwrite``: a mistyped
            ``-o`` must not destroy a ground-truth frame); it lies under a file; the nearest
            existing folder above it is not writable (a folder that cannot be created).
    """
    if path is None:
        return
    path = Path(path)
    target = path.resolve()
    for inp in inputs:
        if inp is not None and Path(inp).exists() and Path(inp).resolve() == target:
            raise InputError(f"the {what} would replace an input of this run; choose another "
                             "path", path=path)
    if folder:
        if path.exists() and not path.is_dir():
            raise InputError(f"the {what} must be a folder, but this is a file", path=path)
    elif path.is_dir():
        raise InputError(f"the {what} must be a file, but this is a folder; give a file name, "
                         f"e.g. {path / 'results.json'}", path=path)
    elif path.exists():
        if path.suffix.lower() in _media_extensions():
            raise InputError(f"refusing to write the {what} over an existing image or video "
                             "file (never replaced, even with --overwrite); choose another path",
                             path=path)
        refuse_existing(path, overwrite=overwrite, what=what)
    parent = path if folder else path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"the {what} would be under this file, which is not a folder; choose "
                         "another path", path=parent)
    _probe_folder(parent, what)


@contextmanager
def parent_folders(path: str | Path, what: str = "output file") -> Iterator[Path]:
    """Create the missing folders above ``path`` (the one rule for every output); if the body
    raises, remove again those it created (when still empty), so a failed write leaves no
    new empty folder behind. Yields ``path``'s folder.

    Raises:
        InputError: naming the folder that cannot be created (a file in the way, no permission).
    """
    folder = Path(path).parent
    missing = []
    probe = folder
    while not probe.exists() and probe != probe.parent:
        missing.append(probe)
        probe = probe.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"cannot create the folder for the {what} ({err.strerror or err})",
                         path=folder) from err
    try:
        yield folder
    except BaseException:
        for made in missing:  # deepest first
            try:
                made.rmdir()
            except OSError:
                break
        raise


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()  # read once: os.umask sets it process-wide, which races with threads


def _place_exclusively(tmp: str, path: Path, what: str) -> None:
    """Move the finished ``tmp`` to ``path`` only if ``path`` does not exist, atomically.

    ``os.link`` fails if the target exists, so of two racing writers exactly one wins. Where the
    file system has no hard links, ``O_EXCL`` reserves the name first; the reservation is
    replaced by the content at once (a reader may see an empty file for that instant, never a
    half-written one).
    """
    taken = f"{what} exists (another run wrote it meanwhile?); pass --overwrite or choose another -o"
    try:
        os.link(tmp, path)
    except FileExistsError as err:
        raise InputError(taken, path=path) from err
    except OSError as err:
        if err.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK,
                             errno.EXDEV, errno.ENOSYS):
            raise
        try:
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
        except FileExistsError as err2:
            raise InputError(taken, path=path) from err2
        os.replace(tmp, path)
        return
    Path(tmp).unlink(missing_ok=True)


def write_text_atomic(
    path: str | Path, text: str, *, overwrite: bool = False, what: str = "output file"
) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file in the same folder, flushed to
    disk and then moved into place: exclusively (``os.link``, fails if ``path`` appeared
    meanwhile), or with ``overwrite`` by ``os.replace`` (atomic on POSIX and Windows). The file
    gets the permissions a plain ``open(path, "w")`` would give (0666 minus the umask).

    Args:
        path: file to write; missing folders above it are created (``parent_folders``).
        text: the whole content.
        overwrite: replace an existing file (else InputError: never overwritten silently).
        what: what the file is, for error messages ("results file", "boxes file", ...).

    Raises:
        InputError: ``path`` exists (or appears during the write) and not ``overwrite``, it is
            a folder, its folder cannot be created or is not writable, or the disk is full
            (``write_failure``; nothing is left behind).
    """
    return write_files_atomic([(path, text, what)], overwrite=overwrite)[0]


def write_files_atomic(files: Sequence[tuple[str | Path, str, str]], *,
                       overwrite: bool = False) -> list[Path]:
    """Write several output files as one (a run's results file, 3DGS files and report): every
    file is first written in full to a temporary file beside its target and flushed, and only
    when all are on disk are they moved into place. A failure or an interrupt (a full disk,
    Ctrl-C) while writing leaves none of them, no new folder, and every existing file as it was
    (one replaced with ``overwrite`` is put back from a hard link kept until the end).

    Args:
        files: ``(path, text, what)`` for each file; ``what`` names it in messages.
        overwrite: replace existing files (else InputError, checked for all before writing any).

    Returns:
        The paths written, in order.

    Raises:
        InputError: as ``write_text_atomic``, naming the file concerned.
    """
    targets = [(Path(path), text, what) for path, text, what in files]
    for path, _, what in targets:
        refuse_existing(path, overwrite=overwrite, what=what)
        if path.is_dir():
            raise InputError(f"the {what} must be a file, but this is a folder", path=path)
    with ExitStack() as folders:
        for path, _, what in targets:
            folders.enter_context(parent_folders(path, what))
        staged: list[tuple[Path, str, str]] = []
        placed: list[tuple[Path, str | None]] = []
        try:
            for path, text, what in targets:
                staged.append((path, _stage(path, text, what), what))
            for path, tmp, what in staged:
                old = _keep_old(path) if overwrite else None
                try:
                    _place(tmp, path, overwrite, what)
                except BaseException:
                    if old is not None:
                        Path(old).unlink(missing_ok=True)
                    raise
                placed.append((path, old))
        except BaseException:
            for _, tmp, _ in staged:
                Path(tmp).unlink(missing_ok=True)
            for path, old in reversed(placed):
                _put_back(path, old)
            raise
        for _, old in placed:
            if old is not None:
                Path(old).unlink(missing_ok=True)
    return [path for path, _, _ in targets]


NO_SPACE_ERRNOS = {
    errno.ENOSPC: "no space left on the device", errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "file too large for this file system", errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied", errno.EPERM: "operation not permitted",
    errno.EIO: "input/output error",
}
"""The write failures that are the place's, not dynaeval's: ``write_failure`` makes them exit 2."""


def write_failure(err: OSError, path: str | Path, what: str) -> InputError | None:
    """The InputError (exit 2) for an OSError raised while writing ``path``: a full disk, a quota,
    a read-only or forbidden place; None for any other error (a bug: re-raise it).

    Call it before removing what the failed write left, so the disk is still full: an OSError
    without an errno (numpy's ``tofile`` reports a short write that way) is taken for a full
    disk when less than ``NEARLY_FULL`` bytes are free where ``path`` goes. The message names
    the path, the cause and the fix, and says that nothing was left behind (the writers of this
    module remove what they staged before raising it).
    """
    cause = NO_SPACE_ERRNOS.get(err.errno) if err.errno is not None else (
        NO_SPACE_ERRNOS[errno.ENOSPC] if _free_bytes(Path(path)) < NEARLY_FULL else None)
    if cause is None:
        return None
    fix = ("free space there or choose another path" if cause in _FULL_CAUSES
           else "choose another path")
    return InputError(f"cannot write the {what}: {cause}; {fix} (nothing was written)", path=path)


NEARLY_FULL = 1 << 20
"""Bytes free below which a short write without an errno is a full disk (``write_failure``)."""
_FULL_CAUSES = {NO_SPACE_ERRNOS[e] for e in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)}


def _free_bytes(path: Path) -> int:
    """Bytes free on the file system of ``path`` (its nearest existing folder); a large number
    when that cannot be told."""
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return 1 << 62


def _stage(path: Path, text: str, what: str) -> str:
    """Write ``text`` to a new temporary file beside ``path``, flushed to disk; its name."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as err:
        raise InputError(f"cannot write the {what} in this folder ({err.strerror or err})",
                         path=path.parent) from err
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the usual permissions
    except BaseException as err:
        failure = write_failure(err, path, what) if isinstance(err, OSError) else None
        Path(tmp).unlink(missing_ok=True)
        if failure is not None:
            raise failure from err
        raise
    return tmp


def _keep_old(path: Path) -> str | None:
    """A hard link to the file ``path`` is about to replace (None: no such file, or the file
    system has no hard links), so a failed multi-file write can put it back."""
    if not path.is_file():
        return None
    old = f"{path.parent / ('.' + path.name)}.old.{os.getpid()}"
    try:
        Path(old).unlink(missing_ok=True)
        os.link(path, old)
    except OSError:
        return None
    return old


def _put_back(path: Path, old: str | None) -> None:
    """Undo placing ``path``: restore the file it replaced (``old``), else remove it."""
    if old is not None:
        os.replace(old, path)
    else:
        path.unlink(missing_ok=True)


def _place(tmp: str, path: Path, overwrite: bool, what: str) -> None:
    """Move the staged ``tmp`` to ``path``: ``os.replace`` with ``overwrite``, else exclusively."""
    if overwrite:
        os.replace(tmp, path)
    else:
        _place_exclusively(tmp, path, what)

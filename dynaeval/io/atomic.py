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
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from dynaeval.errors import InputError


def refuse_existing(path: str | Path | None, *, overwrite: bool, what: str = "output file") -> None:
    """Raise InputError when ``path`` exists and ``overwrite`` is False (None: nothing to check).

    Callers that run long before writing check this first (``check_writable`` does, and more),
    so a finished run is never refused at the end; ``write_text_atomic`` checks it again, and
    atomically, when it writes.
    """
    if path is not None and Path(path).exists() and not overwrite:
        raise InputError(f"{what} exists; pass --overwrite or choose another -o", path=path)


def _media_extensions() -> frozenset[str]:
    from dynaeval.io.images import IMAGE_EXTENSIONS
    from dynaeval.io.video import VIDEO_EXTENSIONS

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
            a folder, or its folder cannot be created or is not writable.
    """
    path = Path(path)
    refuse_existing(path, overwrite=overwrite, what=what)
    if path.is_dir():
        raise InputError(f"the {what} must be a file, but this is a folder", path=path)
    with parent_folders(path, what):
        return _write_new_file(path, text, overwrite, what)


def _write_new_file(path: Path, text: str, overwrite: bool, what: str) -> Path:
    """``write_text_atomic``'s body, once ``path``'s folder exists."""
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
        if overwrite:
            os.replace(tmp, path)
        else:
            _place_exclusively(tmp, path, what)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path

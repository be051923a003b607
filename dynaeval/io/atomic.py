"""Writing output files atomically: a failed or interrupted run never leaves a half-written file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from dynaeval.errors import InputError


def refuse_existing(path: str | Path | None, *, overwrite: bool, what: str = "output file") -> None:
    """Raise InputError when ``path`` exists and ``overwrite`` is False (None: nothing to check).

    Callers that run long before writing check this first, so a finished run is never refused
    at the end; ``write_text_atomic`` checks it again when it writes.
    """
    if path is not None and Path(path).exists() and not overwrite:
        raise InputError(f"{what} exists; pass --overwrite or choose another -o", path=path)


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()  # read once: os.umask sets it process-wide, which races with threads


def write_text_atomic(
    path: str | Path, text: str, *, overwrite: bool = False, what: str = "output file"
) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file in the same folder, flushed to
    disk and renamed into place (``os.replace`` is atomic on POSIX and Windows). The file gets
    the permissions a plain ``open(path, "w")`` would give (0666 minus the umask).

    Args:
        path: file to write; its folder must exist.
        text: the whole content.
        overwrite: replace an existing file (else InputError: never overwritten silently).
        what: what the file is, for error messages ("results file", "boxes file", ...).

    Raises:
        InputError: ``path`` exists and not ``overwrite``, or its folder is missing.
    """
    path = Path(path)
    refuse_existing(path, overwrite=overwrite, what=what)
    if not path.parent.is_dir():
        raise InputError(f"folder for the {what} does not exist", path=path.parent)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path

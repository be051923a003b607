"""One writer per output folder: ``hold_folder(OUT)`` while a long run writes into ``OUT``.

Two ``dynaeval suite`` runs into the same ``-o OUT`` would both see a pair as missing, score it
twice and write the same results, keys and leaderboard files over each other. The first run
creates ``OUT/.dynaeval.lock`` (exclusively: ``O_CREAT | O_EXCL``) with its process id, host and
start time, and removes it when it ends, however it ends; the second refuses with exit 2 naming
the folder, the holder and the fix. A lock left by a process that no longer runs on this host
(``kill -9``, a power cut) is taken over; one from another host, or one that cannot be read, is
never guessed about: the message says to delete it if no run is using the folder.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from dynaeval.core.errors import InputError

LOCK_NAME = ".dynaeval.lock"


def _holder() -> dict[str, object]:
    return {"pid": os.getpid(), "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def _read_holder(path: Path) -> dict[str, object] | None:
    """The lock file's holder, or None when it cannot be read as one (empty, cut, not JSON)."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (isinstance(doc, dict) and isinstance(doc.get("pid"), int)
            and isinstance(doc.get("host"), str)):
        return None
    return doc


def _runs_here(holder: dict[str, object]) -> bool:
    """Whether ``holder`` is a process that runs now, as far as this host can tell (a holder on
    another host counts as running: it cannot be checked from here)."""
    if holder["host"] != socket.gethostname():
        return True
    try:
        os.kill(int(holder["pid"]), 0)  # type: ignore[call-overload]
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, as another user
        return True
    return True


def _create(path: Path) -> bool:
    """Create ``path`` holding this process; False if it exists."""
    try:
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(_holder(), f)
    return True


def _refusal(folder: Path, path: Path, holder: dict[str, object] | None, what: str) -> InputError:
    if holder is None:
        who = f"its lock file {path} cannot be read"
    else:
        who = (f"process {holder['pid']} on {holder['host']} has held it since "
               f"{holder.get('started', '?')}")
    return InputError(f"{what} {folder} is in use by another dynaeval run ({who}): wait for that "
                      f"run to finish or pass another -o; if no run is using it, delete {path}",
                      path=str(folder))


@contextlib.contextmanager
def hold_folder(folder: str | Path, what: str = "output folder") -> Iterator[None]:
    """Hold ``folder`` (an existing directory) for this process until the block ends.

    Raises:
        InputError: another process that still runs holds it, or its lock file is unreadable
            (nothing is written then).
    """
    folder = Path(folder)
    path = folder / LOCK_NAME
    if not _create(path):
        holder = _read_holder(path)
        if holder is None or _runs_here(holder):
            raise _refusal(folder, path, holder, what)
        with contextlib.suppress(FileNotFoundError):
            path.unlink()  # its process is gone: a stale lock
        if not _create(path):  # another run took it over first
            raise _refusal(folder, path, _read_holder(path), what)
    try:
        yield
    finally:
        if (_read_holder(path) or {}).get("pid") == os.getpid():
            with contextlib.suppress(FileNotFoundError):
                path.unlink()

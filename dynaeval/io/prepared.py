"""The files of a prepared ground truth (``dynaeval prepare``): a folder with ``manifest.json``,
compressed ``.npz`` region files and uncompressed ``.npy`` flows, written atomically.

This module knows the folder, not what is in it: content hashes of the ground-truth files, the
manifest's format version, and the atomic write of a whole folder (built under a temporary name
beside the target, then renamed into place: a failed run leaves nothing behind, and an existing
folder is replaced only with ``overwrite``). ``dynaeval.prepare`` fills it.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dynaeval.errors import InputError
from dynaeval.io.atomic import write_failure

FORMAT_VERSION = 1
"""Version of the prepared folder's layout; a folder of another version is refused."""
MANIFEST = "manifest.json"


def file_digest(path: str | Path) -> str:
    """blake2b (20 bytes, hex) of a file's bytes: a ground-truth file's identity."""
    h = hashlib.blake2b(digest_size=20)
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 22), b""):
            h.update(block)
    return h.hexdigest()


def manifest_id(manifest: dict[str, Any]) -> str:
    """The id of a manifest: blake2b (10 bytes, hex) of its JSON without the ``id`` field."""
    body = {k: v for k, v in manifest.items() if k != "id"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    return hashlib.blake2b(text.encode(), digest_size=10).hexdigest()


def read_manifest(folder: str | Path) -> dict[str, Any]:
    """The checked manifest of a prepared folder.

    Raises:
        InputError: no such folder or manifest, unreadable JSON, another format version, or an
            id that does not match the content (edited by hand).
    """
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise InputError("not a prepared ground truth (no manifest.json): make one with "
                         "'dynaeval prepare GT -o PREP'", path=folder)
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise InputError(f"cannot read the prepared ground truth's manifest ({err})",
                         path=path) from err
    version = manifest.get("format_version") if isinstance(manifest, dict) else None
    if version != FORMAT_VERSION:
        raise InputError(f"prepared ground truth of format version {version!r}; this dynaeval "
                         f"reads version {FORMAT_VERSION}: prepare it again", path=path)
    if manifest.get("id") != manifest_id(manifest):
        raise InputError("the prepared ground truth's manifest was changed after it was written "
                         "(its id does not match): prepare it again", path=path)
    return manifest


def write_folder_atomic(out: str | Path, fill: Callable[[Path], None], *,
                        overwrite: bool = False, what: str = "prepared folder") -> Path:
    """Build a folder with ``fill(tmp)`` under a temporary name beside ``out``, then rename it
    to ``out``: exclusively (InputError if ``out`` exists), or with ``overwrite`` replacing it.
    Missing folders above ``out`` are created (``dynaeval.io.atomic.parent_folders``, the rule
    of every output). On any failure the temporary folder and the folders created are removed
    and ``out`` is untouched."""
    from dynaeval.io.atomic import parent_folders

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


def _umask() -> int:
    from dynaeval.io.atomic import _UMASK

    return _UMASK

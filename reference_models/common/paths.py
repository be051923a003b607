"""Where the dynaeval repository is: studies write its ``docs/`` and the bundled sample, which are
files of the repository, never of an installed package (``Path(__file__)`` of an installed module
points into the interpreter's lib folder).

The root is, in this order: ``$DYNAEVAL_REPO`` (must be the repository), else the first folder
holding a ``pyproject.toml`` with ``name = "dynaeval"`` and a ``docs/`` folder found walking up from
the current directory, else from this file (an editable install).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

ENV = "DYNAEVAL_REPO"
_NAME = re.compile(r'^name\s*=\s*"dynaeval"\s*$', re.MULTILINE)


class RepositoryNotFoundError(FileNotFoundError):
    """No dynaeval repository where the studies could write their documents."""


def is_repo_root(folder: Path) -> bool:
    """Whether ``folder`` is the dynaeval repository: its project file and its ``docs/``."""
    project = folder / "pyproject.toml"
    return project.is_file() and (folder / "docs").is_dir() and bool(_NAME.search(project.read_text()))


def repo_root() -> Path:
    """The dynaeval repository's root folder (module docstring); raises
    ``RepositoryNotFoundError`` naming what was searched and how to point at a clone."""
    env = os.environ.get(ENV)
    if env:
        root = Path(env).expanduser().resolve()
        if not is_repo_root(root):
            raise RepositoryNotFoundError(
                f"{ENV}={env}: not the dynaeval repository (expected a pyproject.toml with "
                'name = "dynaeval" and a docs/ folder there)')
        return root
    starts = (Path.cwd().resolve(), Path(__file__).resolve().parent)
    for start in starts:
        for folder in (start, *start.parents):
            if is_repo_root(folder):
                return folder
    raise RepositoryNotFoundError(
        f"no dynaeval repository above {starts[0]} or {starts[1]} (a folder with a pyproject.toml "
        f'naming "dynaeval" and a docs/ folder): run from inside a clone, or set {ENV}=/path/to/clone')


def docs_dir() -> Path:
    """The repository's ``docs/`` folder, where the studies write their tables."""
    return repo_root() / "docs"


def code_version(folder: Path | None = None) -> dict | None:
    """The git commit of the checkout holding ``folder`` (default: the one this package is
    imported from), as ``{"commit": 40 hex digits, "dirty": bool}``; ``dirty`` is true when
    tracked files under ``dynaeval/`` or ``reference_models/`` differ from the commit (so a run
    trained on uncommitted code says so). None where ``folder`` is not in a git checkout or git
    is not installed: an installed package has no commit to name."""
    import subprocess

    folder = Path(folder) if folder is not None else Path(__file__).resolve().parents[2]

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(folder), *args], capture_output=True,
                                  text=True, timeout=30)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if not commit:
        return None
    changes = git("status", "--porcelain", "--untracked-files=no", "--", "dynaeval",
                  "reference_models")
    return {"commit": commit, "dirty": bool(changes)}

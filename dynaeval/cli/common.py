"""What every command module shares: exit codes, the output-folder rule, the sample scene."""

from __future__ import annotations

import argparse
from pathlib import Path

EXIT_OK, EXIT_BUG, EXIT_INPUT = 0, 1, 2

FOLDERS_RULE = "missing folders are created when it is written"
"""The one rule of every output option (``dynaeval.io.atomic.parent_folders``), in its help."""


def sample_dir() -> Path:
    """Folder of the sample scene shipped inside the package (``pred/`` and ``gt/``)."""
    return Path(__file__).resolve().parents[1] / "data" / "sample"


def add_overwrite(p: argparse.ArgumentParser, what: str = "an existing -o file") -> None:
    """``--overwrite``: replace ``what`` (every command that writes has it)."""
    p.add_argument("--overwrite", action="store_true", help=f"replace {what}")

"""Named sections of docs/benchmarks.md that different benchmark scripts own.

A section is the text between ``<!-- begin NAME -->`` and ``<!-- end NAME -->``; the script that
owns it replaces it (or appends it) and leaves the rest of the file alone, so
``benchmarks/bench.py`` and ``benchmarks/temporal_speed.py`` regenerate their own parts only.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

_BLOCK = re.compile(r"<!-- begin (?P<name>[\w-]+) -->\n.*?<!-- end (?P=name) -->\n", re.S)


def blocks(text: str) -> dict[str, str]:
    """Every named section of ``text``: name -> the block with its two marker lines."""
    return {m.group("name"): m.group(0) for m in _BLOCK.finditer(text)}


def put_section(path: str | Path, name: str, body: str) -> None:
    """Replace (or append) section ``name`` of the markdown file ``path`` with ``body``."""
    path = Path(path)
    text = path.read_text() if path.exists() else ""
    block = f"<!-- begin {name} -->\n{body.rstrip()}\n<!-- end {name} -->\n"
    old = blocks(text).get(name)
    text = text.replace(old, block) if old else text.rstrip("\n") + "\n\n" + block
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def keep_sections(old_text: str, new_text: str) -> str:
    """``new_text`` with the named sections of ``old_text`` it lacks appended (a script that
    rewrites the whole file keeps the sections other scripts own)."""
    have = blocks(new_text)
    kept = [b for name, b in blocks(old_text).items() if name not in have]
    return new_text if not kept else new_text.rstrip("\n") + "\n\n" + "\n".join(kept)


def command_line(prog: str, argv: list[str] | None = None) -> str:
    """``prog`` with its arguments as given (``argv``; None: this process's own), for the
    "Command:" line of a section."""
    return (prog + " " + shlex.join(argv if argv is not None else sys.argv[1:])).rstrip()


def utc_stamp() -> str:
    """The time now as ``YYYY-MM-DD HH:MM UTC``: when a benchmark ran."""
    return datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def publish(out: str, name: str, text: str) -> None:
    """Print a benchmark's section ``text`` and put it into section ``name`` of the markdown file
    ``out`` (``"-"``: print only, the benchmarks' ``--out -``)."""
    print(text)
    if out != "-":
        put_section(out, name, text)


def checkout_commit(code: Path) -> str:
    """The short commit of the git checkout ``code``, ``+changes`` when its tracked files differ
    from it (``?`` outside git): which code a benchmark's other checkout was."""
    done = subprocess.run(["git", "-C", str(code), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", str(code), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    return (done.stdout.strip() or "?") + ("+changes" if dirty else "")

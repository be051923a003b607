"""What reaches the terminal: control characters shown, never run.

A name or a path printed on the console can carry control characters (a method called
``"x\\x1b]0;title\\x07"``, a file name with a carriage return): written as they are, an escape
sequence recolours, retitles or clears the terminal and a carriage return overwrites the line.
``console_text`` writes every control character but the line break and the tab as a visible
``\\xNN`` escape; the command line (``dynaeval.cli.main``) sends its whole output through
``ConsoleStream`` (results files keep the names as given). Two writers go around it:
the progress bars, which draw in place with their own carriage returns (``raw_stream``), and
data a command writes on stdout (``write_data``), which reaches a file or a pipe as it is.
Stdlib only.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f]")
"""C0 controls but line break and tab, DEL, and the C1 controls (U+009B is a CSI too)."""


def console_text(text: str) -> str:
    """``text`` with its control characters (all but ``\\n`` and ``\\t``) written as ``\\xNN``."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", text)


class ConsoleStream:
    """A text stream (``sys.stdout``, ``sys.stderr``) whose ``write`` goes through
    ``console_text``; everything else is the stream's own. ``unescaped`` is the stream beneath."""

    def __init__(self, stream: TextIO) -> None:
        self.unescaped: TextIO = raw_stream(stream)
        """The stream written to."""

    def write(self, text: str) -> int:
        return self.unescaped.write(console_text(text))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.unescaped, name)


def raw_stream(stream: TextIO) -> TextIO:
    """The stream beneath a ``ConsoleStream`` (``stream`` itself otherwise): for a progress bar's
    own carriage return and line clearing, its text escaped with ``console_text``."""
    return getattr(stream, "unescaped", stream)


def _is_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def write_data(text: str) -> None:
    """Write data (a leaderboard's CSV, JSON or Markdown) on ``sys.stdout``: as it is when stdout
    is a file or a pipe (escaping would change the data: a name keeps its characters, as in the
    results), shown as the rest of the console is on a terminal."""
    raw = raw_stream(sys.stdout)
    (sys.stdout if _is_terminal(raw) else raw).write(text)


@contextmanager
def escaped_console() -> Iterator[None]:
    """``sys.stdout`` and ``sys.stderr`` as ``ConsoleStream`` s while the block runs."""
    saved = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = ConsoleStream(sys.stdout), ConsoleStream(sys.stderr)  # type: ignore[assignment]
    try:
        yield
    finally:
        sys.stdout, sys.stderr = saved

"""``dynaeval.core.terminal``: control characters reach the console as visible escapes (issue 42
item 7), while the progress bar keeps drawing in place."""

from __future__ import annotations

import io
import sys

from dynaeval.core.progress import Progress
from dynaeval.core.terminal import ConsoleStream, console_text, escaped_console


def test_control_characters_but_line_breaks_and_tabs_are_escaped():
    assert console_text("a\x1b[31mb\x07\rc\x00d\x7f\x9b\te\nf é") == \
        "a\\x1b[31mb\\x07\\x0dc\\x00d\\x7f\\x9b\te\nf é"


def test_the_console_is_escaped_inside_the_block_only_and_not_twice():
    raw = io.StringIO()
    saved = sys.stdout
    sys.stdout = raw
    try:
        with escaped_console():
            print("x\x1by")
            with escaped_console():  # a command run inside another: one escape, not two
                print("\x07")
            assert sys.stdout.unescaped is raw
        assert sys.stdout is raw
    finally:
        sys.stdout = saved
    assert raw.getvalue() == "x\\x1by\n\\x07\n"


def test_the_progress_bar_draws_in_place_through_an_escaped_console_with_its_notes_escaped():
    raw = io.StringIO()
    bar = Progress({"frames": 2}, stream=ConsoleStream(raw), tty=True, interval=None)
    bar.advance("frames", 1, note="cam\x1b]0;x\x07")
    bar.close()
    text = raw.getvalue()
    assert text.startswith("\r") and "\x1b[K" in text and "cam\\x1b]0;x\\x07" in text
    assert "\x07" not in text


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_data_on_a_redirected_stdout_is_written_as_it_is_and_shown_escaped_on_a_terminal():
    """A leaderboard's CSV or JSON on stdout is data: piped or redirected to a file it keeps a
    name's characters as the results hold them; only a terminal shows them escaped."""
    from dynaeval.core.terminal import write_data

    saved = sys.stdout
    try:
        for raw, expected in ((io.StringIO(), "m\x1b[31m,\x85\n"),
                              (_Terminal(), "m\\x1b[31m,\\x85\n")):
            sys.stdout = raw
            with escaped_console():
                write_data("m\x1b[31m,\x85\n")
            assert raw.getvalue() == expected
    finally:
        sys.stdout = saved

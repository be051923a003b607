"""Command line: a thin layer of argument parsing over the library.

One module per command (``score``, ``merge``, ``detect``, ``detector``, ``prepare``,
``suite``, ``leaderboard``, ``demo``), each with ``NAME``, ``add(subparsers)`` and
``run(args) -> exit code``, registered in ``COMMANDS``; ``options`` is the one option table of
the scoring settings (made from ``ScoreConfig``'s fields) that ``score``, ``demo`` and
``prepare`` share.

Exit codes: 0 scored; 2 bad input or usage (the message names the file and what is wrong);
1 a bug (a traceback is printed: please report it).
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback

from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.core.runtime import check_opencv, keep_freed_memory
from dynaeval.core.terminal import escaped_console
from dynaeval.core.version import VERSION

from . import demo, detect, detector, leaderboard, merge, prepare, score, suite
from .common import EXIT_BUG, EXIT_INPUT, EXIT_OK, FOLDERS_RULE, sample_dir
from .console import print_frame_warnings as _print_frame_warnings
from .metric_flags import add_plugin_flags
from .options import config_from_args, parse_classes

__all__ = ["COMMANDS", "EXIT_BUG", "EXIT_INPUT", "EXIT_OK", "FOLDERS_RULE", "build_parser",
           "config_from_args", "main", "parse_classes", "sample_dir", "_print_frame_warnings"]

COMMANDS = (score, merge, detect, detector, prepare, suite, leaderboard, demo)
"""The commands, in the order ``dynaeval --help`` lists them. A new command is a module with
``NAME``, ``add`` and ``run``, and its entry here."""


class _Parser(argparse.ArgumentParser):
    """argparse's parser with did-you-mean on an invalid choice (``--metrics lpip``, ``--protocol
    nerfstudi``; Python 3.11's argparse has none): the closest choice added to its message."""

    def _check_value(self, action: argparse.Action, value: object) -> None:
        try:
            super()._check_value(action, value)
        except argparse.ArgumentError as err:
            hint = did_you_mean(value, map(str, action.choices or ()))
            raise argparse.ArgumentError(action, f"{err.message}{hint}") from None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="dynaeval",
        description="Score novel views of dynamic scenes: whole-frame, focused, masked and "
                    "temporal metrics.",
    )
    parser.add_argument("--version", action="version", version=f"dynaeval {VERSION}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add(sub)
    add_plugin_flags(list(sub.choices.values()))  # last: dynaeval's options come first
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``dynaeval`` command; returns the exit code. What it prints shows
    control characters as escapes (``dynaeval.core.terminal``): a name or a path cannot run an
    escape sequence on the terminal."""
    with escaped_console():
        try:
            args = build_parser().parse_args(argv)
        except KeyboardInterrupt:
            print("dynaeval: interrupted; nothing done", file=sys.stderr)
            return 130
        given = vars(args)  # the run-wide checks, for the commands that have these options
        keep_freed_memory(given.get("workers") or 1)
        try:
            if note := check_opencv(needs_tvl1=given.get("flow") == "tvl1"):
                print(f"dynaeval: warning: {note}", file=sys.stderr)
            return {c.NAME: c.run for c in COMMANDS}[args.command](args)
        except InputError as err:
            print(f"dynaeval: error: {err}", file=sys.stderr)
            return EXIT_INPUT
        except BrokenPipeError:  # stdout closed early (| head): the work is done, stay quiet
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return EXIT_OK
        except KeyboardInterrupt:
            print("dynaeval: interrupted; no results written", file=sys.stderr)
            return 130
        except Exception:
            traceback.print_exc()
            print("dynaeval: internal error (a bug): please report it with the traceback above",
                  file=sys.stderr)
            return EXIT_BUG

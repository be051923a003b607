"""``dynaeval.__main__``: the command's entry point, and Ctrl-C before a command runs (issue 43)."""

from __future__ import annotations

import builtins
import sys

import dynaeval.__main__ as entry
from dynaeval import cli


def test_ctrl_c_while_the_command_line_loads_is_exit_130_without_a_traceback(monkeypatch, capsys):
    """The command's modules load before ``cli.main`` can catch anything: an interrupt there
    was a traceback (and once went on to exit 0)."""
    monkeypatch.delitem(sys.modules, "dynaeval.cli", raising=False)
    real = builtins.__import__

    def interrupted(name, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003
        if name == "dynaeval.cli":
            raise KeyboardInterrupt
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted)
    assert entry.main() == 130
    err = capsys.readouterr().err
    assert err == "dynaeval: interrupted while starting; nothing done\n"


def test_ctrl_c_while_the_arguments_are_parsed_is_exit_130(monkeypatch, capsys):
    def interrupted(*args, **kwargs):  # noqa: ANN002, ANN003
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["--version"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_the_entry_point_runs_the_command_line(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["dynaeval", "leaderboard", "nonexist.json"])
    assert entry.main() == 2
    assert "nonexist.json" in capsys.readouterr().err

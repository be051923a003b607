"""The option table of ``score``, ``demo`` and ``prepare`` (``dynaeval.cli.options``, issue 31):
made from ``ScoreConfig``'s fields, read back by ``config_from_args``, every flag as before."""

from __future__ import annotations

import argparse
import json
from dataclasses import fields
from pathlib import Path

import pytest

from dynaeval.cli import build_parser, config_from_args, sample_dir
from dynaeval.cli.fields import field_docs
from dynaeval.cli.options import EXPOSED, NOT_ON_CLI, score_options
from dynaeval.metrics.registry import selectable_specs
from dynaeval.regions.focus import FocusConfig
from dynaeval.run.config import ScoreConfig

BEFORE = Path(__file__).resolve().parents[1] / "data" / "cli-options-f44755f.json"
"""Every command's options on main before the CLI became a package (``describe_commands``
run there; the file says so)."""


def _describe(parser: argparse.ArgumentParser) -> dict[str, dict]:
    toggles = {s.flag for s in selectable_specs()}  # the registry makes these
    out = {}
    for a in parser._actions:
        if isinstance(a, argparse._HelpAction | argparse._SubParsersAction):
            continue
        key = " ".join(a.option_strings) or a.dest
        if key in toggles:
            continue
        default = a.default.replace(str(sample_dir()), "<sample>") if isinstance(
            a.default, str) else a.default
        choices = None if a.choices is None or key == "--metrics" else list(a.choices)
        out[key] = {"dest": a.dest, "default": default, "choices": choices, "nargs": a.nargs,
                    "action": type(a).__name__, "type": getattr(a.type, "__name__", None),
                    "metavar": a.metavar, "required": a.required}
    return out


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def describe_commands() -> dict[str, dict[str, dict]]:
    """Every command's (and ``detector``'s actions') options, but the per-metric flags."""
    out = {}
    for name, p in _subparsers(build_parser()).items():
        out[name] = _describe(p)
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                out.update({f"{name} {n}": _describe(q) for n, q in action.choices.items()})
    return out


ADDED_SINCE = ("suite",)
"""Commands added after the snapshot was taken (issue 33), whose options it does not hold."""

OPTIONS_ADDED_SINCE = {("leaderboard", "--sort")}
"""Options added to a command after the snapshot (issue 42: the leaderboard ranks)."""

CHANGED_SINCE = {("detect", "--device"): {"choices": ["cpu", "cuda", "auto"]}}
"""Options changed on purpose after the snapshot, and how: ``detect --device`` is the table's
``device`` option now, so it takes ``auto`` as ``score --device`` does."""


def test_every_command_has_the_options_it_had():
    before = json.loads(BEFORE.read_text())["commands"]
    now = describe_commands()
    assert sorted(now) == sorted([*before, *ADDED_SINCE])
    for command, options in before.items():
        added = sorted(f for c, f in OPTIONS_ADDED_SINCE if c == command)
        assert sorted(now[command]) == sorted([*options, *added]), command
        for flag, was in options.items():
            assert now[command][flag] == {**was, **CHANGED_SINCE.get((command, flag), {})}, (
                command, flag)


@pytest.mark.parametrize("command", ["score", "demo"])
def test_the_metric_flags_are_the_registrys(command):
    p = _subparsers(build_parser())[command]
    flags = {f for a in p._actions for f in a.option_strings}
    assert {s.flag for s in selectable_specs()} <= flags


def test_every_field_is_exposed_or_said_why_not():
    names = {f.name for f in fields(ScoreConfig)} | {f"focus.{f.name}" for f in fields(FocusConfig)}
    assert set(EXPOSED) | set(NOT_ON_CLI) == names
    assert not set(EXPOSED) & set(NOT_ON_CLI)


def test_every_field_has_a_docstring_the_help_is_made_of():
    assert set(field_docs(ScoreConfig)) == {f.name for f in fields(ScoreConfig)}
    assert set(field_docs(FocusConfig)) == {f.name for f in fields(FocusConfig)}
    helps = {row.path: row.kwargs["help"] for row in score_options()}
    assert helps["fps"].startswith("frame rate (frames per second) of cameras given as image "
                                   "files, for the video metrics (jod)")
    assert helps["fps"].endswith("(default: 30)")
    assert helps["temporal"] == ("do not compute the temporal terms (warp_error, tof, tlp, "
                                 "flicker) per camera")
    assert all(helps.values())


def test_prepare_takes_its_options_from_the_same_table():
    commands = _subparsers(build_parser())
    score = {a.option_strings[0]: a for a in commands["score"]._actions if a.option_strings}
    prepare = [a for a in commands["prepare"]._actions if a.option_strings
               and a.option_strings[0] not in ("-h", "-o", "--overwrite")]
    assert len(prepare) == 13
    for a in prepare:
        same = score[a.option_strings[0]]
        assert (a.help, a.default, a.choices, a.metavar) == (same.help, same.default,
                                                             same.choices, same.metavar)


def test_the_choices_are_the_constants_the_config_checks():
    from dynaeval.metrics import pixel
    from dynaeval.regions import expand
    from dynaeval.run import config

    rows = {row.path: row.kwargs for row in score_options()}
    assert rows["quantize"]["choices"] is config.QUANTIZE_MODES is pixel.QUANTIZE_MODES
    assert rows["focus.expand"]["choices"] is expand.EXPAND_RULES
    assert rows["background"]["choices"] is config.BACKGROUNDS


_VALUES = {  # path: (the command-line value, the field's value); the others derived below
    "method": ("m", "m"), "scene": ("s", "s"), "split": ("train", "train"),
    "masks": ("given", "given"), "iteration": ("7", 7), "shard": ("2/3", (2, 3)),
    "focus.source": ("motion", "motion"), "focus.classes": ("person,3", ("person", 3)),
    "focus.detector_model": ("m.onnx", "m.onnx"),
}


def _given(row, default, tmp_path):
    """Command-line words setting ``row``'s field to something not its default, and that value."""
    if row.path == "prepared":
        (tmp_path / "manifest.json").write_text("{}")
        return [row.flags[-1], str(tmp_path)], str(tmp_path)
    if row.kwargs.get("action") == "store_true":
        return [row.flags[-1]], row.read(True)
    if row.path in _VALUES:
        typed, value = _VALUES[row.path]
        return [row.flags[-1], typed], value
    if "choices" in row.kwargs:
        other = next(c for c in row.kwargs["choices"] if c != default)
        return [row.flags[-1], other], other
    value = row.kwargs["type"](default + 1)
    return [row.flags[-1], str(value)], value


def test_every_option_reaches_its_field(tmp_path, random_lpips):
    """Each option of the table, given alone with a value other than its default, sets its
    field (``focus.NAME``: of ``config.focus``) to that value: config_from_args reads the
    table, not a list of names."""
    base = ScoreConfig()
    for row in score_options():
        owner, _, name = row.path.rpartition(".")
        default = getattr(base.focus if owner else base, name)
        words, value = _given(row, default, tmp_path)
        if row.path == "focus.detector_model":
            words = [*words, "--focus", "detector"]
        config = config_from_args(build_parser().parse_args(["score", "p", "g", *words]))
        got = getattr(config.focus if owner else config, name)
        assert got == value != default, (row.path, words, got)

"""The flags of ``ScoreConfig.metrics`` and ``.metric_options``, made from the metric registry:
``--metrics NAME ...``, ``--no-NAME`` / ``--NAME`` per metric, ``--metric-option``,
``--flip-every``."""

from __future__ import annotations

import argparse
import warnings
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.metrics.plugins import MetricPluginWarning
from dynaeval.metrics.registry import PLUGIN_METRICS, SPECS, MetricSpec, selectable_specs


def add_metric_flags(p: Any) -> None:
    """``--metrics NAME ...`` (exactly these), ``--no-NAME`` for every chosen metric (per-frame
    or video) that runs by default, ``--NAME`` for the others (from the registry); ``p``: a
    parser or an argument group. The metrics of plugins come last (``add_plugin_flags``)."""
    own = [s for s in selectable_specs() if s.name not in PLUGIN_METRICS]
    names = [s.name for s in own]
    p.add_argument("--metrics", nargs="+", choices=names, metavar="NAME",
                   help=_metrics_help(names))
    options = [f"{s.name}.{o}" for s in selectable_specs() for o, _, _ in s.options]
    p.add_argument("--metric-option", action="append", default=[], metavar="NAME.OPTION=VALUE",
                   dest="metric_option",
                   help=f"an option of one metric (repeatable): {', '.join(options) or 'none'}")
    for spec in own:
        _add_flag(p, spec)
    p.add_argument("--flip-every", type=int, metavar="K",
                   help="FLIP on every K-th frame only (frame index %% K == 0; K-Planes uses 10; "
                        "= --metric-option flip.every=K)")


def _metrics_help(names: list[str]) -> str:
    return (f"compute exactly these metrics ({', '.join(names)}), instead of the defaults "
            "adjusted by --no-NAME / --NAME (which it cannot be combined with)")


def _add_flag(p: Any, spec: MetricSpec) -> None:
    """A metric's ``--no-NAME`` (on by default) or ``--NAME`` flag."""
    extra = f" (needs pip install 'dynaeval[{spec.extra}]')" if spec.extra else ""
    what = (f"skip {spec.title}" if spec.default
            else f"also compute {spec.title}: {spec.description}")
    p.add_argument(spec.flag, action="store_true", dest=toggle_dest(spec), help=what + extra)


def add_plugin_flags(commands: list[argparse.ArgumentParser]) -> None:
    """The metrics of plugins (entry points ``dynaeval.metrics``) on the commands that have the
    metric flags: their ``--no-NAME`` / ``--NAME`` flag in a group of their own and their name
    among ``--metrics``' choices. Called once every option of every command is there, so that
    a plugin never takes one of dynaeval's options: a plugin metric whose flag or its argparse
    dest is already one of any command's (a metric named ``workers``, or ``masked`` on by
    default: ``--no-masked``) is skipped on the command line, with one
    ``MetricPluginWarning`` naming the plugin (the library still computes it by name). The
    commands' ``plugin_metrics`` default lists the plugin metrics they offer."""
    commands = [c for c in commands if "--metric-option" in c._option_string_actions]
    # argparse has no public listing of a parser's options: _actions is what it checks against
    flags = {f for c in commands for f in c._option_string_actions}
    dests = {a.dest for c in commands for a in c._actions}
    offered: list[MetricSpec] = []
    for spec in selectable_specs():
        if spec.name not in PLUGIN_METRICS:
            continue
        taken = spec.flag if spec.flag in flags else (
            f"argument name {toggle_dest(spec)}" if toggle_dest(spec) in dests else None)
        if taken is not None:
            warnings.warn(f"{PLUGIN_METRICS[spec.name]} declares the metric {spec.name!r}, whose "
                          f"flag ({taken}) is one of dynaeval's own options: it is skipped on "
                          f"the command line (rename it in the plugin; the library still "
                          f"computes it by name)", MetricPluginWarning, stacklevel=2)
            continue
        flags.add(spec.flag)
        dests.add(toggle_dest(spec))
        offered.append(spec)
    for c in commands:
        if offered:
            group = c.add_argument_group("metrics of installed plugins (entry points "
                                         "dynaeval.metrics)")
            for spec in offered:
                _add_flag(group, spec)
            action = c._option_string_actions["--metrics"]
            action.choices = [*action.choices, *(s.name for s in offered)]
            action.help = _metrics_help(action.choices)
        c.set_defaults(plugin_metrics=tuple(s.name for s in offered))


def toggle_dest(spec: MetricSpec) -> str:
    """The argparse dest of a metric's ``--no-NAME`` (on by default) or ``--NAME`` flag."""
    return f"no_{spec.name}" if spec.default else f"with_{spec.name}"


def metric_values(args: argparse.Namespace) -> dict[str, Any]:
    """``{"metrics": ..., "metric_options": ...}`` of a command with these flags; ``{}`` for
    one without them (its config keeps the registry's defaults).

    Raises:
        InputError: ``--metrics`` given with a ``--no-NAME`` / ``--NAME`` flag; a malformed
            ``--metric-option``, or an option of a metric that is not computed.
    """
    given = vars(args)
    if "metrics" not in given:
        return {}
    metrics = _chosen(given)
    return {"metrics": metrics,
            "metric_options": _metric_options(given["metric_option"], given["flip_every"], metrics)}


def _chosen(given: dict[str, Any]) -> tuple[str, ...]:
    """The metrics asked for: ``--metrics`` exactly (in registry order), else the registry's
    defaults minus ``--no-NAME`` plus ``--NAME``."""
    offered = given.get("plugin_metrics", ())  # not one skipped on the command line
    specs = [s for s in selectable_specs() if s.name not in PLUGIN_METRICS or s.name in offered]
    toggled = [s for s in specs if given.get(toggle_dest(s), False)]
    chosen = given["metrics"]
    if chosen:
        flags = [s.flag for s in toggled]
        if flags:
            raise InputError(f"--metrics sets the metrics exactly and cannot be combined with "
                             f"{', '.join(flags)}: drop {'it' if len(flags) == 1 else 'them'} "
                             "or --metrics")
        return tuple(s.name for s in specs if s.name in chosen)
    return tuple(s.name for s in specs if s.default != (s in toggled))


def _metric_options(specs: list[str], flip_every: int | None = None,
                    metrics: tuple[str, ...] = ()) -> dict[str, dict[str, Any]]:
    """``["flip.pixels_per_degree=40"]`` -> ``{"flip": {"pixels_per_degree": "40"}}`` (the
    config converts and checks the values); ``--flip-every K`` is ``flip.every=K``.

    Raises:
        InputError: a malformed option, or an option of a registered metric that is not
            computed (``--flip-every`` without ``--flip``, ``--metric-option jod.model=fvvdp``
            without ``--jod``), naming both flags.
    """
    out: dict[str, dict[str, Any]] = {}
    given: list[tuple[str, str]] = []  # (metric, the flag as typed)
    if flip_every is not None:
        out["flip"] = {"every": flip_every}
        given.append(("flip", "--flip-every"))
    for spec in specs:
        key, sep, value = spec.partition("=")
        metric, dot, name = key.partition(".")
        if not (sep and dot and metric and name and value):
            raise InputError(f"--metric-option must be NAME.OPTION=VALUE, e.g. "
                             f"flip.pixels_per_degree=40; got {spec!r}")
        out.setdefault(metric, {})[name] = value
        given.append((metric, f"--metric-option {spec}"))
    for metric, flag in given:  # an unknown metric is the config's error (it lists them)
        if metric in SPECS and metric not in metrics:
            s = SPECS[metric]
            raise InputError(f"{flag} is an option of {s.title}, which is not computed: "
                             f"{s.switch_on} (or {s.name} to --metrics), or drop "
                             f"{flag.split()[0]}")
    return out

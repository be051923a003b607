"""Metrics from other packages: the entry-point group ``dynaeval.metrics``.

An installed package registers metrics by naming, in its ``pyproject.toml``::

    [project.entry-points."dynaeval.metrics"]
    toy_mae = "toy_package:SPEC"

where ``SPEC`` is a ``dynaeval.metrics.registry.MetricSpec`` (or a list of them, or a function
returning one or a list). The registry reads the group once, when it is first imported; each
metric then has its CLI flag, ``ScoreConfig(metrics=...)``, results keys, table, report and
leaderboard columns like a metric of dynaeval's own. A plugin that cannot be loaded is one
``MetricPluginWarning`` naming its entry point, and the run goes on without it; a metric whose
name or result key is already taken is refused with a warning naming both owners.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from importlib.metadata import EntryPoint, entry_points
from typing import Any

ENTRY_POINT_GROUP = "dynaeval.metrics"


class MetricPluginWarning(UserWarning):
    """A metric plugin was skipped (it failed to load, or reuses a name)."""


def _where(ep: EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    package = f", package {dist.name}" if dist is not None else ""
    return f"metric plugin {ep.name!r} ({ep.value}{package})"


def _specs_of(ep: EntryPoint, spec_type: type) -> list[Any]:
    """The MetricSpecs an entry point names; TypeError for anything else."""
    obj = ep.load()
    if callable(obj) and not isinstance(obj, spec_type):
        obj = obj()
    if not isinstance(obj, (spec_type, list, tuple)):
        raise TypeError(f"expected a MetricSpec or a list of them, got a {type(obj).__name__}")
    specs = [obj] if isinstance(obj, spec_type) else list(obj)
    wrong = [type(s).__name__ for s in specs if not isinstance(s, spec_type)]
    if wrong or not specs:
        raise TypeError(f"expected a MetricSpec or a list of them, got {wrong or 'nothing'}")
    return specs


def plugin_specs(spec_type: type, taken: dict[str, str],
                 keys_of: Callable[[Any], list[str]],
                 found: Callable[[], Any] = lambda: entry_points(group=ENTRY_POINT_GROUP),
                 kinds: tuple[str, ...] = (),
                 plugin_kinds: dict[str, str] | None = None) -> list[Any]:
    """The metrics the installed plugins declare, checked, in entry-point name order.

    Args:
        spec_type: ``MetricSpec`` (passed in: the registry imports this module).
        taken: every metric name and result key already registered -> who owns it (updated
            with the plugins' own).
        keys_of: a spec's base name and result keys.
        found: the entry points to read (tests pass their own).
        kinds: the metric kinds dynaeval has (a spec of another kind is refused); empty: any.
        plugin_kinds: the kinds a plugin's metric may have -> the function it then gives
            (a spec of another of ``kinds``, one dynaeval's own engines compute, or one without
            a ``build`` is refused); None: any of ``kinds``.

    Warns:
        MetricPluginWarning: per plugin that fails to load (an exception or ``sys.exit`` on
            import) or is not a MetricSpec, and per metric of an unknown kind or one a plugin
            cannot have, without a build, or whose name or key is taken, by dynaeval's metrics
            or a field of the results (it is refused, the others are kept).
    """
    out = []
    for ep in sorted(found(), key=lambda e: e.name):
        try:
            specs = _specs_of(ep, spec_type)
        except (Exception, SystemExit) as err:  # a broken plugin must not break dynaeval
            # (sys.exit() on import made every command, --version too, exit silently)
            warnings.warn(f"{_where(ep)} could not be loaded and is skipped: "
                          f"{type(err).__name__}: {err}", MetricPluginWarning, stacklevel=2)
            continue
        for spec in specs:
            refused = _refusal(spec, kinds, plugin_kinds)
            if refused is not None:
                warnings.warn(f"{_where(ep)} declares the metric {spec.name!r}{refused}",
                              MetricPluginWarning, stacklevel=2)
                continue
            clash = next((k for k in keys_of(spec) if k in taken), None)
            if clash is not None:
                warnings.warn(f"{_where(ep)} declares the metric {spec.name!r}, which is "
                              f"refused: its key {clash!r} is taken by {taken[clash]} (rename "
                              "it in the plugin)", MetricPluginWarning, stacklevel=2)
                continue
            for key in keys_of(spec):
                taken[key] = _where(ep)
            out.append(spec)
    return out


def _refusal(spec: Any, kinds: tuple[str, ...],
             plugin_kinds: dict[str, str] | None) -> str | None:
    """Why a plugin's metric cannot be registered (the end of its warning), or None: a kind
    dynaeval does not have, one a plugin cannot have (a plugin ``pair`` metric was called as a
    video metric, a ``TypeError`` in the run), no ``build`` (nothing would compute it)."""
    if kinds and spec.kind not in kinds:
        return (f" of kind {spec.kind!r}, which is refused: dynaeval has no such kind (kinds: "
                f"{', '.join(kinds)})")
    if plugin_kinds is not None and spec.kind not in plugin_kinds:
        allowed = " or ".join(f"{k} ({what})" for k, what in plugin_kinds.items())
        return (f" of kind {spec.kind!r}, which is refused: dynaeval's own engines compute the "
                f"metrics of that kind; a plugin's metric is of kind {allowed}")
    if spec.build is None:
        return (", which is refused: it has no build ('module:function' returning the metric's "
                "function), so nothing would compute it")
    return None

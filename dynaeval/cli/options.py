"""The one option table of ``score``, ``demo`` and ``prepare``, made from ``ScoreConfig``'s fields.

Every field of ``ScoreConfig`` (and of its ``FocusConfig``) is either in ``EXPOSED`` or in
``NOT_ON_CLI`` (a test holds it). From the field come the flag (``--cache-mb`` for
``cache_mb``; ``--no-NAME`` for a setting on by default), the type (``int``/``float`` of the
annotation, else the string as typed, which the config reads), the default (the dataclass's) and
the help (the field's docstring); ``EXPOSED`` adds the choices (each from the one constant the
config checks against), a metavar, and the spelling where the CLI's differs. ``config_from_args``
reads the table back: no command lists its fields again.
"""

from __future__ import annotations

import argparse
import functools
from dataclasses import fields
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.metrics.flow import FLOW_METHODS
from dynaeval.metrics.perceptual import LPIPS_BACKENDS, LPIPS_NETS
from dynaeval.metrics.protocols import PROTOCOL_NAMES
from dynaeval.regions.expand import EXPAND_RULES
from dynaeval.regions.focus import FocusConfig
from dynaeval.regions.sources import DetectorSource
from dynaeval.run.config import BACKGROUNDS, DEVICES, QUANTIZE_MODES, ScoreConfig

from .fields import Cli, Option, option_of
from .metric_flags import add_metric_flags, metric_values


def parse_classes(items: list[str] | None) -> tuple[str | int, ...] | None:
    """``--classes`` values -> class names and ids: each item split at commas, stripped,
    digits as integer ids (``["person,32", "sports ball"]`` -> ``("person", 32, "sports ball")``).

    Raises:
        InputError: no class left (``--classes ,``).
    """
    if items is None:
        return None
    parts = [p.strip() for item in items for p in item.split(",")]
    out = tuple(int(p) if p.isdigit() else p for p in parts if p)
    if not out:
        raise InputError("--classes names no class: give names or ids, e.g. --classes person,ball")
    return out


METRIC_FLAGS = "metric flags"
"""``EXPOSED`` value of ``metrics`` and ``metric_options``: made from the registry
(``metric_flags``)."""

EXPOSED: dict[str, Cli | str] = {
    "method": Cli(),
    "scene": Cli(),
    "metrics": METRIC_FLAGS,
    "metric_options": METRIC_FLAGS,
    "fps": Cli(metavar="FPS"),
    "lpips_net": Cli(choices=LPIPS_NETS, help="LPIPS backbone (default: alex, or the protocol's: "
                     "vgg for 3dgs and 4dgaussians, which also allows alex)"),
    "lpips_backend": Cli(choices=LPIPS_BACKENDS),
    "quantize": Cli(choices=QUANTIZE_MODES),
    "background": Cli(choices=BACKGROUNDS),
    "allow_missing": Cli(),
    "focus.source": Cli(flags=("--focus",), metavar="detector|motion|boxes:FILE|none",
                        help="boxes for the focused_* metrics, from the ground truth: the ONNX "
                             "detector (default), connected components of the motion masks, a "
                             "boxes file (dynaeval detect, or the scene generator's boxes.json), "
                             "or none"),
    "focus.detector_model": Cli(flags=("--detector",), metavar="MODEL.onnx|NAME",
                                help="ONNX detector for --focus detector, or the name of one "
                                     "fetched with 'dynaeval detector fetch' (default: the one "
                                     "shipped with dynaeval, for the synthetic scenes)"),
    "focus.classes": Cli(nargs="+", metavar="CLASS", read=parse_classes,
                         help="the detector's classes to keep, by name or integer id, separated "
                              "by commas or spaces (a name with a space, e.g. 'sports ball', "
                              "needs commas or quotes); default: person, sports ball"),
    "focus.expand": Cli(choices=EXPAND_RULES),
    "focus.masked": Cli(),
    "presence": Cli(),
    "temporal": Cli(),
    "flow": Cli(choices=FLOW_METHODS),
    "workers": Cli(metavar="N"),
    "device": Cli(choices=DEVICES, help="torch device for LPIPS and the detector"),
    "progress": Cli(flags=("-q", "--quiet"), help="no progress bar"),
    "cache_mb": Cli(metavar="MB"),
    "shard": Cli(metavar="I/N", read=lambda spec: spec or None,
                 help="score only the I-th of N slices of the cameras (1 <= I <= N); 'dynaeval "
                      "merge' combines the N results into the unsharded numbers"),
    "protocol": Cli(choices=PROTOCOL_NAMES),
    "iteration": Cli(metavar="N"),
    "split": Cli(metavar="NAME"),
    "masks": Cli(metavar="DIR", help="given masks, one grey PNG per ground-truth frame at the "
                 "same relative path (or a DyCheck dataset folder: its covisible/<factor>x/"
                 "<split>/): masked_* are computed over them instead of the motion masks, and the "
                 "protocol uses them as its source does (default: a NeRFBaselines render "
                 "folder's mask/, DyCheck's covisible/ beside rgb/<factor>x/)"),
    "frames_are_video": Cli(help="score a render folder's frames (NeRFBaselines, ns-render, "
                            "gaussian-splatting: separate test views, scored per frame only by "
                            "default) as one video per camera: temporal terms and motion masks"),
    "prepared": Cli(metavar="PREP"),
}
"""The fields the CLI sets (``focus.NAME``: a field of ``ScoreConfig.focus``), in no order: the
table follows the dataclasses' field order."""

NOT_ON_CLI = {
    "data_range": "always 1.0 for files (anything else is refused)",
    "focus": "its fields are the focus.* options",
    "focus.boxes_file": "given as --focus boxes:FILE",
    "focus.motion_kind": "isg; ist only from the library",
    "focus.device": "the run's --device",
}
"""The fields without an option of their own, and why."""


@functools.cache
def score_options() -> tuple[Option, ...]:
    """The table: one ``Option`` per field in ``EXPOSED`` but the metric flags, in field order
    (``ScoreConfig``'s, with ``FocusConfig``'s where ``focus`` stands)."""
    config = ScoreConfig()
    rows = []
    for f in fields(ScoreConfig):
        if f.name == "focus":
            rows += [option_of(FocusConfig, getattr(config.focus, g.name), f"focus.{g.name}",
                             EXPOSED[f"focus.{g.name}"])  # type: ignore[arg-type]
                     for g in fields(FocusConfig) if f"focus.{g.name}" in EXPOSED]
        elif isinstance(EXPOSED.get(f.name), Cli):
            rows.append(option_of(ScoreConfig, getattr(config, f.name), f.name,
                                EXPOSED[f.name]))  # type: ignore[arg-type]
    return tuple(rows)


def add_options(p: argparse.ArgumentParser, paths: tuple[str, ...] | None = None,
                title: str | None = None) -> None:
    """Add the table's options of the fields ``paths`` (None: every one) to ``p``, in table
    order; ``"metrics"`` adds the metric flags (``metric_flags.add_metric_flags``) there;
    ``title``: put them in an argument group of that title."""
    where: Any = p.add_argument_group(title) if title else p
    for f in fields(ScoreConfig):
        if f.name == "metrics" and (paths is None or "metrics" in paths):
            add_metric_flags(where)
        for row in score_options():
            if row.path.partition(".")[0] == f.name and (paths is None or row.path in paths):
                where.add_argument(*row.flags, **row.kwargs)


def config_from_args(args: argparse.Namespace) -> ScoreConfig:
    """The ``ScoreConfig`` of parsed ``score``/``demo``/``prepare`` arguments: every option of
    the table the command has, read back into its field (the others keep the library's
    defaults).

    Raises:
        InputError: conflicting options (``--metrics`` with ``--no-NAME``; ``--detector``
            without ``--focus detector``), a value ``ScoreConfig`` refuses, or a metric named
            (``--flip``, ``--metrics lpips``, ``--lpips-net``) that cannot run here.
    """
    given = vars(args)
    values: dict[str, Any] = metric_values(args)
    focus: dict[str, Any] = {}
    for row in score_options():
        if row.dest in given:
            owner, _, name = row.path.rpartition(".")
            (focus if owner == "focus" else values)[name] = row.read(given[row.dest])
    source = focus.pop("source", FocusConfig.source)
    if focus.get("detector_model") and source != DetectorSource.name:
        raise InputError(f"--detector is only used with --focus detector (got --focus "
                         f"{source}): drop --detector, or pass --focus detector")
    values["focus"] = FocusConfig.parse(source, device=values.get("device", ScoreConfig.device),
                                        **focus)
    config = ScoreConfig(**values)
    named = [*(given.get("metrics") or ()), *(("lpips",) if values.get("lpips_net") else ())]
    config.require_metrics(named)  # asked for by name: refused now if it cannot run
    return config

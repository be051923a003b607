"""What a method's own run folder says it cost, where a peer tool writes it.

Read (checked against the tool's source, NeRFBaselines at ``cde53bd``, Nov 2025):

* **NeRFBaselines** writes ``info.json`` beside ``color/`` and ``gt-color/`` in every predictions
  folder (``predictions-<step>.tar.gz`` of ``nerfbaselines train``, ``nerfbaselines render``;
  ``evaluation._save_predictions_iterate``): the checkpoint's ``nb-info.json`` (``io.new_nb_info``)
  with ``nb_version``, ``total_train_time`` (seconds of ``train_iteration`` summed, rounded to
  1e-5; null when not measured) and ``resources_utilization`` (null, or the peaks sampled while
  training: ``memory`` MB of the process tree's RSS, ``gpu_memory`` MB from ``nvidia-smi``,
  ``gpu_name``). NeRFBaselines' own tables show ``total_train_time`` and ``gpu_memory`` beside
  its metrics (``results.format_duration``, ``format_memory``: MB, over 1024 as GB). They become
  ``train_minutes`` (``total_train_time / 60``) and ``memory_gb`` (``gpu_memory / 1024``); it
  writes no rendering speed there.

Not read: **nerfstudio** keeps no training time or memory in its run folder (``config.yml``,
``nerfstudio_models/``); ``ns-eval`` writes ``fps`` (frames rendered per second while its
metrics were computed) into a JSON file the user names, anywhere. The **3DGS family** writes no
figure of cost beside ``renders/`` and ``gt/``. Their figures go into SUITE.toml ``[costs]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.io.jsonfile import read_json

NERFBASELINES_INFO = "info.json"
NERFBASELINES_PRED = "color"
"""NeRFBaselines' predictions folder holds ``info.json`` beside ``color/`` (the predictions a
suite scores) and ``gt-color/``."""

RUN_COSTS = ("train_minutes", "memory_gb")
"""The costs a run folder can give (a subset of ``report.leaderboard.COSTS``)."""


@dataclass(frozen=True)
class RunCosts:
    """What one prediction folder's run says it cost."""

    costs: dict[str, float] = field(default_factory=dict)
    """``RUN_COSTS`` fields found (an absent or null figure is left out, never guessed)."""
    source: str | None = None
    """The file they were read from (None: no peer's file there)."""
    note: str | None = None
    """Why a peer's file there gave no figure (unreadable, not JSON, a value that is not a
    number >= 0), for a warning."""


def _figure(doc: dict[str, Any], keys: tuple[str, ...]) -> float | None | str:
    """The number at ``doc[keys[0]][keys[1]]...``: None when absent or null, the problem (text)
    when it is not a number >= 0."""
    value: Any = doc
    for key in keys:
        if not isinstance(value, dict) or value.get(key) is None:
            return None
        value = value[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
            or value < 0:
        return f"{'.'.join(keys)} is {value!r}, not a number >= 0"
    return float(value)


def read_run_costs(pred: str | Path) -> RunCosts:
    """The costs NeRFBaselines recorded for the predictions in ``pred`` (its ``color/`` folder,
    or the predictions folder holding it): ``info.json`` there, when it is NeRFBaselines' (has
    ``nb_version``). Never raises for the file's content: a problem is the result's ``note``."""
    pred = Path(pred)
    folder = pred.parent if pred.name == NERFBASELINES_PRED else pred
    path = folder / NERFBASELINES_INFO
    if not path.is_file():
        return RunCosts()
    try:
        doc = read_json(path, what="NeRFBaselines info file", fix="its figures are not read")
    except InputError as err:
        return RunCosts(source=str(path), note=f"{err}; its training time and memory not read")
    if not isinstance(doc, dict) or "nb_version" not in doc:
        return RunCosts()  # another tool's info.json: nothing of ours
    costs, problems = {}, []
    for name, keys, scale in (("train_minutes", ("total_train_time",), 60.0),
                              ("memory_gb", ("resources_utilization", "gpu_memory"), 1024.0)):
        value = _figure(doc, keys)
        if isinstance(value, str):
            problems.append(value)
        elif value is not None:
            costs[name] = value / scale
    note = (f"{path}: {'; '.join(problems)}: left blank" if problems else None)
    return RunCosts(costs, str(path), note)

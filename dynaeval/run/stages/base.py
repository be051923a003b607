"""The one interface of a scoring stage, and what a stage is given for a frame and a camera.

A stage is one kind of work done on every camera of a run: per-frame metrics, object presence,
temporal terms, video metrics. ``dynaeval.run.scoring.score_camera`` finds the camera's regions,
then runs every stage that ``applies`` to the plan: ``frame`` on each frame (on the worker pool),
``camera`` once the frames are done. A stage holds no state of its own (one instance serves
every run); what a camera's stages find out is in its ``CameraWork``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from dynaeval.core.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.core.outcome import VALUE_LIMIT, CameraTerm, Outcome, Status
from dynaeval.io import FramePair
from dynaeval.io.frames import gap_positions
from dynaeval.io.images import FrameCache
from dynaeval.metrics.registry import METRICS, PLUGIN_METRICS
from dynaeval.regions.focus import CameraRegions, FrameRegions

if TYPE_CHECKING:
    from dynaeval.run.executor import RunWorkers
    from dynaeval.run.plan import RunPlan

Value = tuple[str, Outcome]
"""``(result key, outcome)`` of one per-frame value (``dynaeval.core.outcome.Outcome``: the value,
``inf`` or None, and why)."""


@dataclass
class FrameWork:
    """One frame as its stages see it."""

    pair: FramePair
    pred: np.ndarray
    """``(H, W, C)`` float32 in [0, 1], as the metrics see it (``RunPlan.read_pair``)."""
    gt: np.ndarray
    """``(H, W, C)`` float32 in [0, 1], the same size as ``pred``."""
    regions: FrameRegions
    """The frame's regions fitted to its size (given-mask weights applied)."""
    row: dict[str, Any]
    """The frame's results row: a stage may add fields beside its values (presence's
    ``objects``)."""
    elapsed: dict[str, float] = field(default_factory=dict)
    """Seconds per metric or stage spent on this frame (added to the run's timing)."""


@dataclass
class CameraWork:
    """One camera once its frames are scored: what its camera stages read and find."""

    name: str
    pairs: list[FramePair]
    """Its frames in order."""
    regions: CameraRegions
    """Its regions (``frames`` in the same order), from the ground truth."""
    cache: FrameCache
    """The camera's frame cache."""
    executor: RunWorkers
    """The run's pool and timing."""
    differ: Any = None
    """The ``FramesDiffer`` of frames that differ in shape (found by the regions, or by the
    temporal stage), or None: they are no video."""
    on_pair: Callable[[], None] | None = None
    """Called after each temporal pair (progress)."""


class Stage:
    """One kind of work on every camera (subclasses override what they do)."""

    name = "stage"
    """Its name, for people (the run's timing keys are a stage's phases and metrics:
    ``temporal``, ``regions``, each metric's result key)."""

    def applies(self, plan: RunPlan) -> bool:
        """Whether the run has this stage."""
        raise NotImplementedError

    def frame_keys(self, plan: RunPlan) -> list[str]:
        """The result keys of its per-frame values, in report order."""
        return []

    def frame(self, plan: RunPlan, work: FrameWork) -> list[Value]:
        """Its values of one frame (none for a camera stage)."""
        return []

    def camera(self, plan: RunPlan, work: CameraWork) -> dict[str, CameraTerm] | None:
        """Its camera-level terms by result key, or None for a frame stage."""
        return None


def consecutive(pairs: list[FramePair]) -> bool:
    """True when the frames' indices run without a gap (none skipped): a sequence the temporal
    and video metrics can use."""
    return not gap_positions(pairs)


def metric_outcome(key: str, call: Callable[[], object]) -> Outcome:
    """The outcome of result ``key``'s value ``call()`` (a per-frame or a video metric's): a
    plugin's by ``plugin_outcome``, dynaeval's own as it is (``Outcome.of``)."""
    if METRICS[key].metric in PLUGIN_METRICS:
        return plugin_outcome(key, call)
    return Outcome.of(float(call()))  # type: ignore[arg-type]


def plugin_outcome(key: str, call: Callable[[], object]) -> Outcome:
    """The outcome of a metric plugin's value for result ``key``: ``call()``'s number, or null
    with ``PLUGIN_FAILED`` naming the plugin when it raises (but for dynaeval's own errors,
    which it may raise as dynaeval's metrics do) or returns NaN, -infinity or a magnitude beyond
    ``VALUE_LIMIT`` (merge and the leaderboard refuse those; -infinity was written as
    "+infinity"), or +infinity where it is no ideal value: +infinity is "prediction equals
    ground truth" (``Status.INFINITE``) only for a metric that is higher-is-better and
    unbounded above, as PSNR. One rule, documented in docs/architecture.md (plugins)."""
    who = f"the metric plugin of {key!r}"
    try:
        value = float(call())  # type: ignore[arg-type]
    except (EmptyRegionError, UndefinedMetricError, InputError):
        raise
    except Exception as err:  # noqa: BLE001 - the plugin's failure, named as the plugin's
        return Outcome(None, Status.PLUGIN_FAILED, f"{who} raised {type(err).__name__}: {err}")
    if math.isnan(value) or value == -math.inf or (math.isfinite(value)
                                                  and abs(value) > VALUE_LIMIT):
        return Outcome(None, Status.PLUGIN_FAILED,
                       f"{who} returned {value!r}, which a results file cannot hold")
    info = METRICS[key]
    if value == math.inf and not (info.higher_is_better and info.range[1] == math.inf):
        return Outcome(None, Status.PLUGIN_FAILED, (
            f"{who} returned inf, which is no ideal value of it ("
            + ("lower is better" if not info.higher_is_better else
               f"its range ends at {info.range[1]!r}") + ")"))
    return Outcome.of(value)


"""The one interface of a scoring stage, and what a stage is given for a frame and a camera.

A stage is one kind of work done on every camera of a run: per-frame metrics, object presence,
temporal terms, video metrics. ``dynaeval.run.scoring.score_camera`` finds the camera's regions,
then runs every stage that ``applies`` to the plan: ``frame`` on each frame (on the worker pool),
``camera`` once the frames are done. A stage holds no state of its own (one instance serves
every run); what a camera's stages find out is in its ``CameraWork``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from dynaeval.core.outcome import CameraTerm, Outcome
from dynaeval.io import FramePair
from dynaeval.io.images import FrameCache
from dynaeval.io.frames import gap_positions
from dynaeval.regions.focus import FrameRegions

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
    regions: list[FrameRegions]
    """Their regions (same order), from the ground truth."""
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

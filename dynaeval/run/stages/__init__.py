"""The stages of scoring a camera, in the order they run: per-frame metrics, presence (per
frame), temporal terms, video metrics (per camera). ``Stage`` (``dynaeval.run.stages.base``) is their
one interface; ``dynaeval.run.scoring`` runs those that apply to the plan."""

from __future__ import annotations

from typing import TYPE_CHECKING

from dynaeval.run.stages.base import CameraWork, FrameWork, Stage, Value, consecutive
from dynaeval.run.stages.frame_metrics import FrameMetrics
from dynaeval.run.stages.presence import Presence
from dynaeval.run.stages.temporal import Temporal
from dynaeval.run.stages.video import Video

if TYPE_CHECKING:
    from dynaeval.run.plan import RunPlan

__all__ = ["STAGES", "CameraWork", "FrameWork", "Stage", "Value", "active_stages",
           "consecutive", "metric_names"]

STAGES: tuple[Stage, ...] = (FrameMetrics(), Presence(), Temporal(), Video())
"""Every stage, in the order they run (the order of the values in a row and of the terms)."""


def active_stages(plan: RunPlan) -> tuple[Stage, ...]:
    """The stages ``plan`` runs, in order."""
    return tuple(s for s in STAGES if s.applies(plan))


def metric_names(plan: RunPlan) -> list[str]:
    """Result keys of the per-frame values, in report order."""
    return [k for s in active_stages(plan) for k in s.frame_keys(plan)]

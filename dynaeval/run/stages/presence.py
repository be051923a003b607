"""The presence stage: which ground-truth objects the prediction shows (``dynaeval.metrics.presence``)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from dynaeval.core.outcome import Outcome, Status
from dynaeval.metrics.presence import PRESENCE_METRICS
from dynaeval.run.stages.base import FrameWork, Stage, Value

if TYPE_CHECKING:
    from dynaeval.run.plan import RunPlan


class Presence(Stage):
    """The plan's presence step on each frame (``RunPlan.presence``, built with the region
    sources); the frame's ground-truth objects go into its row as ``objects``."""

    name = "presence"

    def applies(self, plan: RunPlan) -> bool:
        return plan.presence is not None

    def frame_keys(self, plan: RunPlan) -> list[str]:
        return list(PRESENCE_METRICS)

    def frame(self, plan: RunPlan, work: FrameWork) -> list[Value]:
        t0 = time.perf_counter()
        found, reasons, work.row["objects"] = plan.presence(work.pair, work.pred, work.gt,
                                                            work.regions)
        work.elapsed["presence"] = time.perf_counter() - t0
        # a null presence value: the frame has no ground-truth object of the class
        return [(name, Outcome.of(v, Status.NO_REGION, reasons.get(name)))
                for name, v in found.items()]

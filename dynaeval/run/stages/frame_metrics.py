"""The per-frame metrics stage: every registered frame metric over each of its region variants."""

from __future__ import annotations

import time
from functools import partial
from typing import TYPE_CHECKING

from dynaeval.core.errors import EmptyRegionError, InputError, UndefinedMetricError
from dynaeval.core.outcome import Outcome, Status
from dynaeval.metrics._common import WholeOrRegion
from dynaeval.metrics.registry import region_argument
from dynaeval.metrics.structural import reusing_whole_map
from dynaeval.run.stages.base import FrameWork, Stage, Value, metric_outcome

if TYPE_CHECKING:
    from dynaeval.run.plan import RunPlan


class FrameMetrics(Stage):
    """``fn(pred, gt, region)`` of every per-frame metric of the plan (``RunPlan.fns``), each
    timed under its result key."""

    name = "frame metrics"

    def applies(self, plan: RunPlan) -> bool:
        return True  # a run with no frame metric has no keys, nothing to do

    def frame_keys(self, plan: RunPlan) -> list[str]:
        return list(plan.fns)

    def frame(self, plan: RunPlan, work: FrameWork) -> list[Value]:
        """``(key, Outcome)`` of every per-frame metric of one frame (SSIM over the regions reads
        the whole frame's window values: ``structural.reusing_whole_map``)."""
        pair, pred, gt, regions, elapsed = work.pair, work.pred, work.gt, work.regions, work.elapsed
        values: list[Value] = []
        with reusing_whole_map():
            for name, (region, fn) in plan.fns.items():
                if pair.index % plan.every.get(name, 1):
                    continue  # not one of the frames it scores (``every``): no value, not null
                if region == "focused" and regions.boxes is None:
                    values.append((name, regions.boxes_missing or Outcome(None, Status.NO_REGION)))
                    continue
                if region == "masked" and regions.packed_mask is None:
                    values.append((name, regions.mask_missing or Outcome(None, Status.NO_REGION)))
                    continue
                kw = region_argument(region, name, plan.protocol, regions)
                if kw is None:
                    values.append((name, Outcome(None, Status.NO_REGION,
                                                 "no covisibility mask for this frame")))
                    continue
                t0 = time.perf_counter()
                try:
                    if isinstance(fn, WholeOrRegion):  # PSNR, SSIM: the region's function
                        values.append((name, Outcome.of(float(fn.on(kw)(pred, gt)))))
                    else:
                        values.append((name, metric_outcome(name, partial(fn, pred, gt, kw))))
                except EmptyRegionError as err:
                    values.append((name, Outcome(None, Status.EMPTY_REGION, str(err))))
                except UndefinedMetricError as err:  # e.g. smaller than SSIM's window
                    values.append((name, Outcome(None, Status.UNDEFINED, str(err))))
                except InputError as err:
                    raise InputError(f"{name}: {err}", path=str(pair.pred)) from err
                elapsed[name] = time.perf_counter() - t0
        return values

"""RunPlan (the run resolved once, frozen, the user's config kept as given), the RunWorkers (pool,
camera lanes, frame caches, timing) and the stages behind one interface (issue 31)."""

from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import pytest

from dynaeval.errors import InputError
from dynaeval.io.layouts import RenderLayout
from dynaeval.regions.focus import FocusConfig
from dynaeval.run.config import ScoreConfig
from dynaeval.run.evaluate import per_frame_only
from dynaeval.run.executor import RunWorkers, cameras_at_once
from dynaeval.run.plan import RunPlan, Scope, build_plan
from dynaeval.run.stages import STAGES, Stage, active_stages, metric_names

pytestmark = pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")

NONE = FocusConfig(source="none", masked=False)


def _views(**kw) -> tuple[ScoreConfig, object]:  # noqa: ANN202
    """A config and a layout of separate test views (not a video)."""
    layout = RenderLayout("folders", Path("pred"), Path("gt"), sequence=False)
    return ScoreConfig(progress=False, **kw), layout


def test_plan_keeps_the_config_as_given_and_resolves_beside_it():
    """Run.config was the config with quantize and lpips_net replaced by the protocol's; the
    plan keeps the user's and holds the resolved values in their own fields."""
    given = ScoreConfig(metrics=("psnr",), protocol="nerfbaselines", focus=NONE, progress=False)
    plan = build_plan(given)
    assert plan.config is given
    assert (given.quantize, given.lpips_net) == ("none", None)
    assert plan.quantize == given.resolved_quantize() == "truncate"
    assert plan.lpips_net == given.resolved_lpips_net()
    assert plan.settings["quantize"] == "truncate"


def test_plan_is_frozen():
    plan = build_plan(ScoreConfig(metrics=("psnr",), focus=NONE, progress=False))
    for name in ("presence", "temporal", "config", "settings"):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(plan, name, None)


def test_separate_views_change_the_plan_not_the_config():
    """Before, per_frame_only returned a copy of the config with temporal and masked off, and
    that copy was the run's config."""
    config, layout = _views(metrics=("psnr",), focus=FocusConfig(source="none", masked=True))
    scope = per_frame_only(config, layout, None)
    assert (scope.temporal, scope.masked) == (False, False)
    assert scope.sequence["skipped"] == ["temporal terms", "motion masks and masked_*"]
    plan = build_plan(config, scope=scope)
    assert plan.config is config and config.temporal and config.focus.masked
    assert plan.temporal is None and not plan.focus.masked
    assert "masked_psnr" not in plan.fns and plan.settings["sequence"] is scope.sequence


def test_separate_views_refuse_motion_focus_before_the_plan():
    config, layout = _views(focus=FocusConfig(source="motion"))
    with pytest.raises(InputError, match=r"--focus motion needs each camera's frames as a video"):
        per_frame_only(config, layout, None)


@pytest.mark.parametrize(("kw", "names"), [
    ({}, ["frame metrics", "temporal"]),
    ({"temporal": False}, ["frame metrics"]),
])
def test_active_stages_follow_the_plan(kw, names):
    plan = build_plan(ScoreConfig(metrics=("psnr",), focus=NONE, progress=False, **kw))
    assert [s.name for s in active_stages(plan)] == names
    assert metric_names(plan) == ["psnr"]


def test_presence_stage_adds_its_keys_after_the_frame_metrics():
    from dynaeval.cli import sample_dir
    from dynaeval.metrics.presence import PRESENCE_METRICS

    boxes = FocusConfig(source="boxes", boxes_file=str(sample_dir() / "boxes.json"))
    plan = build_plan(ScoreConfig(metrics=("psnr",), focus=boxes, temporal=False,
                                  progress=False))
    assert [s.name for s in active_stages(plan)] == ["frame metrics", "presence"]
    assert metric_names(plan) == ["psnr", "focused_psnr", "masked_psnr", *PRESENCE_METRICS]


def test_every_stage_has_the_one_interface():
    assert [s.name for s in STAGES] == ["frame metrics", "presence", "temporal", "video"]
    for stage in STAGES:
        assert isinstance(stage, Stage)
        assert {"applies", "frame_keys", "frame", "camera"} <= set(dir(stage))
    with pytest.raises(NotImplementedError):
        Stage().applies(build_plan(ScoreConfig(metrics=("psnr",), focus=NONE, progress=False)))


def test_scope_of_a_config_is_what_it_asks():
    config = ScoreConfig(temporal=False, focus=NONE, progress=False)
    assert Scope.of(config) == Scope(temporal=False, masked=False)
    assert isinstance(build_plan(config, scope=Scope.of(config)), RunPlan)


def test_a_run_plan_is_built_with_every_field_named():
    """Issue 41: 15 fields, several of one type (three mappings of metrics), were given by
    position; a swap built a plan that ran."""
    from dataclasses import fields

    plan = build_plan(ScoreConfig(temporal=False, focus=NONE, progress=False))
    values = {f.name: getattr(plan, f.name) for f in fields(RunPlan)}
    with pytest.raises(TypeError):
        RunPlan(*values.values())
    assert RunPlan(**values) == plan


# ------------------------------------------------------------------------------ executor


def test_executor_without_workers_runs_in_order_in_the_caller():
    ex = RunWorkers(1, cameras=4, cache_mb=8)
    assert ex.pool is None and ex.lanes == 1 and ex.window == 2
    assert ex.map(lambda x: threading.get_ident(), range(3)) == [threading.get_ident()] * 3
    assert ex.frame_cache().max_bytes == 8 * 2**20


def test_executor_shares_cache_and_window_between_lanes():
    ex = RunWorkers(4, cameras=2, cache_mb=8)
    try:
        assert ex.lanes == 2 and ex.window == 4
        assert ex.frame_cache().max_bytes == 4 * 2**20  # each camera at once: its share
        assert ex.map(lambda x: x * x, range(20)) == [x * x for x in range(20)]
        ex.map(lambda _: ex.add_time({"psnr": 0.5}), range(100))
        assert ex.timing["psnr"] == 50.0
    finally:
        ex.shutdown(completed=True)


def test_cameras_at_once_returns_in_camera_order_and_raises_the_first_failure():
    ex = RunWorkers(2, cameras=2, cache_mb=1)
    cams = {"a": [], "b": []}
    assert ex.cameras_at_once(cams, lambda c, p, stop: c) == ["a", "b"]

    def fails(cam, pairs, stop):  # noqa: ANN202
        if cam == "b":
            raise InputError("b is broken")
        stop.wait(5)  # released when b fails
        return cam

    with pytest.raises(InputError, match="b is broken"):
        ex.cameras_at_once(cams, fails)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as lanes:
        assert cameras_at_once(lanes, cams, lambda c, p, stop: c.upper()) == ["A", "B"]
    ex.shutdown(completed=True)

"""Metrics from other packages (entry-point group ``dynaeval.metrics``, issue 31): a tiny package
installed in the test (its ``.dist-info`` on ``sys.path``, as pip leaves it) shows its metric in
the CLI, the results JSON and the table; a broken plugin or one that reuses a name is a warning
naming it, and the run goes on."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from dynaeval.cli import sample_dir
from dynaeval.metrics.plugins import MetricPluginWarning, plugin_specs
from dynaeval.metrics.registry import MetricSpec

TOY = '''
import numpy as np

from dynaeval.metrics.registry import MetricSpec

SPEC = MetricSpec("toy_mae", "frame", False, (0.0, 1.0), "",
                  "mean absolute error of the [0, 1] images (a plugin's toy)",
                  default=False, build="toy_metric_pkg:build")


def build(ctx):
    def fn(pred, gt, region):
        return float(np.mean(np.abs(np.asarray(pred, np.float64) - np.asarray(gt, np.float64))))
    return fn
'''


def _install(root: Path, entry: str, code: str = TOY) -> Path:
    """A package ``toy_metric_pkg`` with its dist-info under ``root`` (what pip installs)."""
    (root / "toy_metric_pkg").mkdir(parents=True)
    (root / "toy_metric_pkg" / "__init__.py").write_text(code)
    info = root / "toy_metric_pkg-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-metric-pkg\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[dynaeval.metrics]\n{entry}\n")
    return root


def _score(site: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    s = sample_dir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run(
        [sys.executable, "-m", "dynaeval", "score", str(s / "pred" / "cam07"),
         str(s / "gt" / "cam07"), "--focus", "none", "--no-temporal", "--no-presence", "-q",
         "-o", str(out), *extra], capture_output=True, text=True, timeout=300, env=env)


def test_an_installed_plugin_metric_is_scored_and_reported(tmp_path):
    site = _install(tmp_path / "site", "toy_mae = toy_metric_pkg:SPEC")
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr", "toy_mae")
    assert run.returncode == 0, run.stderr
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["metrics"]["toy_mae"]["higher_is_better"] is False
    # an independent value: the mean over frames of the mean |pred - gt| of the files, read as
    # dynaeval hands frames to a metric (float32 / 255)
    s = sample_dir()

    def unit(path: Path) -> np.ndarray:
        return (cv2.imread(str(path)).astype(np.float32) / np.float32(255)).astype(np.float64)

    want = np.mean([np.mean(np.abs(unit(p) - unit(s / "gt" / "cam07" / p.name)))
                    for p in sorted((s / "pred" / "cam07").glob("*.png"))])
    assert doc["summary"]["toy_mae"] == pytest.approx(want, rel=1e-12)
    assert "toy_mae" in run.stdout  # the table
    off = _score(site, tmp_path / "r2.json", "--no-lpips")  # off by default: asked by its flag
    assert off.returncode == 0 and "toy_mae" not in json.loads((tmp_path / "r2.json")
                                                              .read_text())["summary"]
    flag = _score(site, tmp_path / "r3.json", "--no-lpips", "--toy-mae")
    assert flag.returncode == 0, flag.stderr
    assert "toy_mae" in json.loads((tmp_path / "r3.json").read_text())["summary"]


def test_a_broken_plugin_is_one_warning_and_the_run_goes_on(tmp_path):
    site = _install(tmp_path / "site", "toy_mae = toy_metric_pkg:NO_SUCH_SPEC")
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr")
    assert run.returncode == 0, run.stderr
    assert run.stderr.count("MetricPluginWarning") == 1
    assert "metric plugin 'toy_mae' (toy_metric_pkg:NO_SUCH_SPEC, package toy-metric-pkg) could " \
           "not be loaded and is skipped: AttributeError" in run.stderr
    assert "Traceback" not in run.stderr


class _EntryPoint:
    """What ``importlib.metadata.entry_points`` yields, for the checks of ``plugin_specs``."""

    def __init__(self, name: str, obj: object) -> None:
        self.name, self.value, self.obj, self.dist = name, f"pkg:{name}", obj, None

    def load(self) -> object:
        if isinstance(self.obj, Exception):
            raise self.obj
        return self.obj


def _spec(name: str, regions: tuple[str, ...] = ("whole",)) -> MetricSpec:
    return MetricSpec(name, "frame", True, (0.0, 1.0), "", "toy", regions=regions,
                      build="x:y")


def _keys(spec: MetricSpec) -> list[str]:
    return [spec.name, *(spec.key(r) for r in spec.regions)]


def test_plugin_reusing_a_name_or_key_is_refused_naming_both():
    taken = {"psnr": "dynaeval's psnr", "focused_psnr": "dynaeval's psnr"}
    found = [_EntryPoint("a", _spec("psnr")), _EntryPoint("b", [_spec("good"), _spec("good2")]),
             _EntryPoint("c", lambda: _spec("psnr2", ("whole", "focused"))),
             _EntryPoint("d", _spec("good"))]
    with pytest.warns(MetricPluginWarning) as caught:
        specs = plugin_specs(MetricSpec, taken, _keys, found=lambda: found)
    assert [s.name for s in specs] == ["good", "good2", "psnr2"]
    messages = [str(w.message) for w in caught]
    assert messages == [
        "metric plugin 'a' (pkg:a) declares the metric 'psnr', which is refused: its key 'psnr' "
        "is taken by dynaeval's psnr (rename it in the plugin)",
        "metric plugin 'd' (pkg:d) declares the metric 'good', which is refused: its key 'good' "
        "is taken by metric plugin 'b' (pkg:b) (rename it in the plugin)"]


@pytest.mark.parametrize("obj,message", [
    (ImportError("No module named 'torch'"), "ImportError: No module named 'torch'"),
    ("psnr", "TypeError: expected a MetricSpec or a list of them, got a str"),
    (["psnr"], "TypeError: expected a MetricSpec or a list of them, got ['str']"),
    ([], "TypeError: expected a MetricSpec or a list of them, got nothing"),
])
def test_a_plugin_that_is_not_a_metric_spec_is_skipped(obj, message):
    with pytest.warns(MetricPluginWarning, match=re.escape(
            "metric plugin 'x' (pkg:x) could not be loaded and is skipped: " + message)):
        assert plugin_specs(MetricSpec, {}, _keys, found=lambda: [_EntryPoint("x", obj)]) == []


def test_a_plugin_metric_named_like_a_results_field_or_of_an_unknown_kind_is_refused():
    """Issue 43 item 3: a plugin metric named `gt` or `n_frames` overwrote each frame's `gt`
    path and `summary.n_frames`; an unknown kind got a flag that then raised TypeError."""
    from dynaeval.metrics.registry import KINDS, RESULTS_FIELDS
    from dynaeval.report.results_check import FRAME_FIELDS

    assert set(FRAME_FIELDS) <= set(RESULTS_FIELDS)
    taken = dict(RESULTS_FIELDS)
    odd = MetricSpec("odd", "video", True, (0.0, 1.0), "", "toy", build="x:y")
    found = [_EntryPoint("a", _spec("gt")), _EntryPoint("b", _spec("n_frames")),
             _EntryPoint("c", odd), _EntryPoint("d", _spec("fine"))]
    with pytest.warns(MetricPluginWarning) as caught:
        specs = plugin_specs(MetricSpec, taken, _keys, found=lambda: found, kinds=KINDS)
    assert [s.name for s in specs] == ["fine"]
    messages = [str(w.message) for w in caught]
    assert "its key 'gt' is taken by the frame rows' field 'gt'" in messages[0]
    assert "its key 'n_frames' is taken by the field 'n_frames' of summary" in messages[1]
    assert "of kind 'video', which is refused: dynaeval has no such kind" in messages[2]


def test_a_plugin_that_exits_on_import_is_skipped_and_every_command_still_runs(tmp_path):
    """Issue 43 item 3: a plugin calling sys.exit(3) on import made every command, --version
    included, exit 3 silently."""
    site = _install(tmp_path / "site", "toy_mae = toy_metric_pkg:SPEC",
                    code="import sys\nsys.exit(3)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    version = subprocess.run([sys.executable, "-m", "dynaeval", "--version"], capture_output=True,
                             text=True, timeout=120, env=env)
    assert version.returncode == 0 and "dynaeval" in version.stdout
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr")
    assert run.returncode == 0, run.stderr
    assert "could not be loaded and is skipped: SystemExit: 3" in run.stderr


BAD = '''
import math

from dynaeval.metrics.registry import MetricSpec

SPEC = MetricSpec("toy_bad", "frame", False, (0.0, 1.0), "", "a plugin that misbehaves",
                  default=False, build="toy_metric_pkg:build")
VALUES = iter([-math.inf, math.nan, 1e301, "raise", 0.25, 0.5, 0.75, 1.0])


def build(ctx):
    def fn(pred, gt, region):
        value = next(VALUES)
        if value == "raise":
            raise ZeroDivisionError("the plugin divided by zero")
        return value
    return fn
'''


def test_a_plugins_bad_values_and_exceptions_are_its_own_nulls_not_dynaevals_bug(tmp_path):
    """Issue 43 item 3: a plugin's -inf was recorded as "+infinity" (merge restored +inf), NaN
    and an exception were "internal error (a bug)", a value beyond 1e300 was written and then
    refused by merge and the leaderboard. Each is now a null with status plugin-failed naming
    the plugin and what it did; the run exits 0 and its file reads back."""
    from dynaeval.report.results import load_results

    site = _install(tmp_path / "site", "toy_bad = toy_metric_pkg:SPEC", code=BAD)
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr", "toy_bad")
    assert run.returncode == 0, run.stderr
    assert "internal error" not in run.stderr and "Traceback" not in run.stderr
    doc = load_results(tmp_path / "r.json")
    assert [f["toy_bad"] for f in doc["frames"]] == [None] * 4 + [0.25, 0.5, 0.75, 1.0]
    failed = [w for w in doc["warnings"] if w.get("metric") == "toy_bad"]
    assert [w["status"] for w in failed] == ["plugin-failed"] * 4
    reasons = " ".join(w["reason"] for w in failed)
    for said in ("returned -inf", "returned nan", "returned 1e+301", "raised ZeroDivisionError"):
        assert f"the metric plugin of 'toy_bad' {said}" in reasons
    assert doc["summary"]["toy_bad"] == 0.625


@pytest.mark.parametrize("name,default,flag", [("workers", False, "--workers"),
                                               ("masked", True, "--no-masked")])
def test_a_plugin_flag_never_takes_one_of_dynaevals_options(monkeypatch, name, default, flag):
    """Issue 43: a plugin metric named ``workers`` (flag ``--workers``) broke every command with
    an argparse traceback. Its metric is skipped on the command line with one warning naming
    the plugin; every command keeps its own options, a plugin metric that fits keeps its flag."""
    from dynaeval.cli import build_parser
    from dynaeval.cli.options import config_from_args
    from dynaeval.metrics import registry

    for plugin in (name, "toy_fine"):
        monkeypatch.setitem(registry.SPECS, plugin, MetricSpec(
            plugin, "frame", True, (0.0, 1.0), "", "toy", default=default, build="x:y"))
        monkeypatch.setitem(registry.PLUGIN_METRICS, plugin, f"metric plugin {plugin!r} (pkg:x)")
    with pytest.warns(MetricPluginWarning) as caught:
        parser = build_parser()
    assert [str(w.message) for w in caught] == [
        f"metric plugin {name!r} (pkg:x) declares the metric {name!r}, whose flag ({flag}) is one "
        "of dynaeval's own options: it is skipped on the command line (rename it in the plugin; "
        "the library still computes it by name)"]
    args = parser.parse_args(["score", "p", "g", "--workers", "3", "--no-masked"])
    assert args.workers == 3 and args.no_masked is True
    assert name not in config_from_args(args).metrics  # not even on by default
    assert ("toy_fine" in config_from_args(args).metrics) == default
    toy = "--no-toy-fine" if default else "--toy-fine"
    assert parser.parse_args(["demo", toy, "--metrics", "psnr", "toy_fine"]).metrics == [
        "psnr", "toy_fine"]
    with pytest.raises(SystemExit):
        parser.parse_args(["score", "p", "g", "--metrics", name])
    assert parser.parse_args(["merge", "a.json", "-o", "m.json"]).command == "merge"


VIDEO = '''
import math

from dynaeval.metrics.registry import MetricSpec

SPEC = MetricSpec("toy_video", "camera", True, (0.0, 1.0), "", "a video plugin that fails",
                  default=False, build="toy_metric_pkg:build")


def build(ctx):
    def fn(pred, gt, fps, region):
        return math.nan
    return fn
'''


def test_a_video_plugins_nan_is_its_own_null_by_the_frame_metrics_rule(tmp_path):
    """Issue 43: a plugin of kind ``camera`` (a video metric) returning NaN was written as null
    silently, without a status or a word: the rule of the per-frame plugins applies to it."""
    from dynaeval.report.results import load_results

    site = _install(tmp_path / "site", "toy_video = toy_metric_pkg:SPEC", code=VIDEO)
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr", "toy_video")
    assert run.returncode == 0, run.stderr
    doc = load_results(tmp_path / "r.json")
    assert doc["summary"]["toy_video"] is None
    failed = [w for w in doc["warnings"] if w.get("metric") == "toy_video"]
    assert [w["status"] for w in failed] == ["plugin-failed"] * 2  # the camera's, the summary's
    assert "the metric plugin of 'toy_video' returned nan" in failed[0]["reason"]
    assert "returned nan" in run.stderr


INF = '''
import math

from dynaeval.metrics.registry import MetricSpec

SPECS = [MetricSpec("toy_lower", "frame", False, (0.0, math.inf), "", "lower is better",
                    default=False, build="toy_metric_pkg:build"),
         MetricSpec("toy_higher", "frame", True, (0.0, math.inf), "dB", "higher is better",
                    default=False, build="toy_metric_pkg:build")]


def build(ctx):
    def fn(pred, gt, region):
        return math.inf
    return fn
'''


def test_plus_infinity_is_the_ideal_only_of_a_higher_is_better_plugin(tmp_path):
    """Issue 43: +infinity from a lower-is-better plugin was recorded as "prediction equals
    ground truth": that is +infinity's meaning for PSNR-like metrics only (higher is better,
    unbounded above); for the others it is the plugin's failure."""
    from dynaeval.report.results import load_results

    site = _install(tmp_path / "site", "toy = toy_metric_pkg:SPECS", code=INF)
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr", "toy_lower", "toy_higher")
    assert run.returncode == 0, run.stderr
    doc = load_results(tmp_path / "r.json")
    lower = [w for w in doc["warnings"] if w.get("metric") == "toy_lower"]
    higher = [w for w in doc["warnings"] if w.get("metric") == "toy_higher"]
    assert lower and {w["status"] for w in lower} == {"plugin-failed"}, lower
    assert "the metric plugin of 'toy_lower' returned inf" in lower[0]["reason"]
    assert "lower is better" in lower[0]["reason"]
    assert higher and {w["status"] for w in higher} == {"infinite"}, higher


HOOKS = '''
from dynaeval.metrics.registry import MetricSpec

SPEC = MetricSpec("toy_bad", "frame", False, (0.0, 1.0), "", "a plugin whose set-up fails",
                  default=False, build="toy_metric_pkg:build", {hook}="toy_metric_pkg:broken")


def build(ctx):
    def fn(pred, gt, region):
        return 0.5
    return fn


def broken(*args):
    raise KeyError("net")
'''


@pytest.mark.parametrize("hook", ["build", "settings", "requires"])
def test_a_plugin_whose_set_up_raises_is_named_as_the_plugins_failure(tmp_path, hook):
    """Issue 43: a plugin whose build, settings or requires function raised ended as "internal
    error (a bug)". Its build or settings raising leaves its metric out with one warning
    (plugin-failed) naming the plugin and what raised, as a plugin that fails to load is
    skipped; its requires raising says the metric cannot run here, and a metric asked for by
    name that cannot run is refused before any work (exit 2)."""
    code = HOOKS.replace("{hook}", hook) if hook != "build" else HOOKS.replace(
        ', {hook}="toy_metric_pkg:broken"', "").replace('build="toy_metric_pkg:build"',
                                                        'build="toy_metric_pkg:broken"')
    site = _install(tmp_path / "site", "toy_bad = toy_metric_pkg:SPEC", code=code)
    run = _score(site, tmp_path / "r.json", "--metrics", "psnr", "toy_bad")
    assert "internal error" not in run.stderr and "Traceback" not in run.stderr, run.stderr
    said = (f"metric plugin 'toy_bad' (toy_metric_pkg:SPEC, package toy-metric-pkg): its {hook} "
            "function 'toy_metric_pkg:broken' raised KeyError: 'net'")
    assert said in run.stderr
    if hook == "requires":
        assert run.returncode == 2 and not (tmp_path / "r.json").exists()
        return
    assert run.returncode == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    assert "toy_bad" not in doc["summary"] and doc["summary"]["psnr"] > 20
    failed = [w for w in doc["warnings"] if w.get("metric") == "toy_bad"]
    assert [w["status"] for w in failed] == ["plugin-failed"] and said in failed[0]["reason"]


@pytest.fixture
def registered(monkeypatch):
    """``_with_plugins`` (what the registry does when it is imported) over the given entry
    points, read through a monkeypatched ``importlib.metadata.entry_points``."""
    from dynaeval.metrics import plugins, registry

    own = {n: s for n, s in registry.SPECS.items() if n not in registry.PLUGIN_METRICS}
    monkeypatch.setattr(registry, "PLUGIN_METRICS", {})

    def register(*found: _EntryPoint) -> dict[str, MetricSpec]:
        monkeypatch.setattr(plugins, "entry_points", lambda group: list(found))
        return registry._with_plugins(own)
    return register


@pytest.mark.parametrize("make,message", [
    (lambda: MetricSpec("t", "pair", True, (0.0, 1.0), "", "toy", build="x:y"),
     "declares the metric 't' of kind 'pair', which is refused: dynaeval's own engines compute "
     "the metrics of that kind; a plugin's metric is of kind frame (fn(pred, gt, region) per "
     "frame) or camera (fn(pred_frames, gt_frames, fps, region) per camera)"),
    (lambda: MetricSpec("t", "object", True, (0.0, 1.0), "", "toy", classes=("person",),
                        regions=(), build="x:y"),
     "declares the metric 't' of kind 'object', which is refused: dynaeval's own engines"),
    (lambda: MetricSpec("t", "video", True, (0.0, 1.0), "", "toy", build="x:y"),
     "declares the metric 't' of kind 'video', which is refused: dynaeval has no such kind"),
    (lambda: MetricSpec("t", "frame", True, (0.0, 1.0), "", "toy"),
     "declares the metric 't', which is refused: it has no build ('module:function' returning "
     "the metric's function), so nothing would compute it"),
])
def test_a_plugin_metric_of_a_kind_it_cannot_have_is_refused_at_registration(registered, make,
                                                                             message):
    """Issue 43: a plugin metric of kind pair or object was accepted, got its flag, and then
    failed with a TypeError in the run (called as a video metric): refused when registered,
    one warning naming the plugin; its other metrics are kept."""
    with pytest.warns(MetricPluginWarning, match=re.escape(f"metric plugin 'x' (pkg:x) {message}")):
        specs = registered(_EntryPoint("x", [make(), _spec("fine")]))
    assert "t" not in specs and "fine" in specs


@pytest.mark.parametrize("name,owner", [
    ("read", "the timing phase 'read'"), ("total_s", "the timing phase 'total_s'"),
    ("protocol", "the settings section 'protocol'"), ("focus", "the settings section 'focus'"),
    ("gt", "the frame rows' field 'gt'"),
])
def test_a_plugin_metric_named_like_a_timing_phase_or_settings_section_is_refused(
        registered, name, owner):
    """Issue 43: the hand-made list of results fields missed the timing phases (``read``,
    ``regions``, ...) and the settings sections (``protocol``, ``focus``, ...): a plugin metric
    so named overwrote them. The names are read from the results schema, which lists them."""
    with pytest.warns(MetricPluginWarning) as caught:
        specs = registered(_EntryPoint("x", [_spec(name), _spec("fine")]))
    assert name not in specs and "fine" in specs
    assert [str(w.message) for w in caught] == [
        f"metric plugin 'x' (pkg:x) declares the metric {name!r}, which is refused: its key "
        f"{name!r} is taken by {owner} (rename it in the plugin)"]


def test_the_schema_names_every_timing_phase_and_settings_section_a_run_writes(tmp_path):
    """What the registry refuses is read from the schema: hold the schema to what a run writes
    (every timing key and settings section that is not a metric's)."""
    import dynaeval
    from dynaeval.core.schemas import results_fields
    from dynaeval.metrics.registry import METRICS, SPECS

    s = sample_dir()
    doc = dynaeval.score(s / "pred", s / "gt", progress=False, metrics=("psnr", "ssim"),
                         focus=dynaeval.FocusConfig.parse("motion"))
    fields = results_fields()
    assert {"read", "regions", "temporal", "total_s"} <= set(doc["timing"])
    assert [k for k in doc["timing"] if k not in METRICS and k not in fields] == []
    assert [k for k in doc["settings"] if k not in SPECS and k not in fields] == []

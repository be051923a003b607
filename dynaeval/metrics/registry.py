"""The one registry of metrics: every number dynaeval reports is declared here, once.

A ``MetricSpec`` says what a metric is (direction, range, unit, display precision, meaning), which
variants it has (regions ``whole`` / ``focused`` / ``masked``, or object classes) and so which
result keys it writes, whether it runs by default, which extra it needs and — for per-frame
metrics — how to build its function for a run (``build``) and which settings it records
(``settings``). ``evaluate``, ``ImageMetrics``, the results, tables, leaderboard and the CLI all
read it: adding a per-frame metric is its module, its entry in ``SPECS``, its test and its section
in docs/metrics.md (docs/architecture.md walks through it).

Result keys are made here and nowhere else: ``result_key("ssim", "focused") == "focused_ssim"``,
``result_key("presence", cls="ball") == "presence_ball"``. ``METRICS`` maps every result key to
its ``MetricInfo``; a key in a results file that is not in ``METRICS`` is a bug (a test scores the
sample with everything on and checks).

Kinds:

* ``frame``: a pure function of one (prediction, ground truth) image pair, per region variant;
  ``build(ctx) -> fn(pred, gt, region)`` where ``region`` is ``{}`` (whole frame),
  ``{"boxes": (N, 4)}`` (focused) or ``{"mask": (H, W) bool}`` (masked).
* ``pair``: a temporal term of two consecutive frames (its value sits in the later frame's row).
* ``camera``: one value per camera sequence (``flicker``, ``jod``); summaries are means over
  cameras. Those with a ``build`` (``jod``) are video metrics chosen like frame metrics
  (``--jod``): ``build(ctx) -> fn(pred_frames, gt_frames, fps, region)`` with ``region`` ``{}``
  or ``{"boxes": [per-frame boxes or None]}``; the others come from the temporal engine.
* ``object``: per ground-truth object class, per frame (``presence_*``, ``tight_psnr_*``).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dynaeval.core.deps import MissingDependency
from dynaeval.core.errors import (
    InputError,
    PluginError,
    WeightsUnavailableError,
    did_you_mean,
)
from dynaeval.core.schemas import results_fields
from dynaeval.metrics.plugins import plugin_specs
from dynaeval.metrics.protocols import get_protocol

REGIONS: dict[str, str] = {"whole": "", "focused": "focused_", "masked": "masked_",
                           "covisible": "m"}
"""Region variant -> prefix of its result key. ``covisible`` is DyCheck's reduction over its
covisibility mask (``mpsnr``, ``mssim``, ``mlpips``), computed under ``--protocol dycheck``
only (``dynaeval.metrics.protocol_dycheck``)."""

REGION_RULES: dict[str, str] = {
    "focused": "SSIM/LPIPS: box-area-weighted mean over crops of the merged boxes; "
    "PSNR: over the union of the boxes",
    "masked": "PSNR: over the mask's pixels; SSIM/LPIPS: mean of the full-frame map over them",
}
"""How the region variants reduce a per-frame metric (written into the results' settings)."""

COVISIBLE_RULE = ("DyCheck's: PSNR of masked_mean(squared error); SSIM of partial convolutions, "
                  "mean over the whole map; LPIPS: masked mean of the spatial map of the masked "
                  "images")
"""How the ``covisible`` variant reduces (in the settings of a run that computes it)."""

KINDS = ("frame", "pair", "camera", "object")

PLUGIN_KINDS = {"frame": "fn(pred, gt, region) per frame",
                "camera": "fn(pred_frames, gt_frames, fps, region) per camera"}
"""The kinds a plugin's metric may have (``MetricSpec.build`` returns that function); ``pair``
and ``object`` metrics are computed by dynaeval's own engines (temporal, presence)."""

PRESENCE_CLASSES = ("person", "ball")
"""Object classes the presence check reports (``presence_<class>``, ``tight_psnr_<class>``)."""

FrameFn = Callable[[np.ndarray, np.ndarray, dict[str, Any]], float]
"""``fn(pred, gt, region) -> value``: (H, W, C) float images, region ``{}``, ``{"boxes": ...}``
or ``{"mask": ...}``."""


@dataclass(frozen=True)
class FrameContext:
    """What a per-frame metric may need from the run to build its function."""

    data_range: float = 1.0
    """Peak value of the images (1.0 for [0, 1])."""
    protocol: Any = None
    """``dynaeval.metrics.protocols.Protocol`` whose whole-frame variants to use; None: dynaeval's."""
    device: str = "cpu"
    """Resolved torch device (``cpu``, ``cuda[:i]``) for metrics that run a network."""
    lpips_net: str = "alex"
    """LPIPS backbone: ``alex`` or ``vgg``."""
    lpips_backend: str = "torch"
    """LPIPS runtime: ``torch`` or ``onnxruntime``."""
    pretrained_backbone: bool = True
    """False only in tests: networks with random backbones (see ``load_lpips``)."""
    fps: float = 30.0
    """Frame rate of cameras given as image files (``ScoreConfig.fps``; video metrics)."""
    options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """Per-metric options of the run, ``{metric: {option: value}}`` (``ScoreConfig.metric_options``;
    each metric declares its own in ``MetricSpec.options``)."""

    def option(self, metric: str, name: str, default: Any) -> Any:
        """The run's value of ``metric``'s option ``name``, else ``default``."""
        return self.options.get(metric, {}).get(name, default)

    def whole(self) -> Any:
        """The protocol (dynaeval's when None)."""
        if self.protocol is not None:
            return self.protocol

        return get_protocol("dynaeval")


@dataclass(frozen=True)
class MetricInfo:
    """What one reported number (one result key) means."""

    name: str
    """Key in the results (``frames[i][name]``, ``summary[name]``)."""
    higher_is_better: bool
    """True for PSNR/SSIM, False for LPIPS and the temporal errors."""
    range: tuple[float, float]
    """Possible values (lo, hi); ``math.inf`` where unbounded (PSNR of identical images is inf)."""
    unit: str
    """Unit of the value ("dB", "" for unitless)."""
    description: str
    """One line: what is measured and over which pixels."""
    metric: str = ""
    """Name of the ``MetricSpec`` it comes from (``psnr`` for ``focused_psnr``)."""
    variant: str = "whole"
    """Region (``whole``, ``focused``, ``masked``) or object class (``person``, ``ball``)."""
    kind: str = "frame"
    """``frame``, ``pair``, ``camera`` or ``object`` (see the module docstring)."""
    precision: int = 4
    """Decimals in the terminal table."""

    @property
    def direction(self) -> str:
        """``"higher"`` or ``"lower"`` (is better)."""
        return "higher" if self.higher_is_better else "lower"


@dataclass(frozen=True)
class MetricSpec:
    """One metric, declared once: everything else reads this."""

    name: str
    """Base name (``psnr``); result keys are made by ``key``."""
    kind: str
    """``frame``, ``pair``, ``camera`` or ``object``."""
    higher_is_better: bool
    """Direction: True when a higher value is better."""
    range: tuple[float, float]
    """Possible values (lo, hi); ``math.inf`` where unbounded."""
    unit: str
    """Unit ("dB", "JOD", "" for unitless)."""
    description: str
    """One line: what is measured (the region is added per variant)."""
    regions: tuple[str, ...] = ("whole",)
    """Region variants it is reported for (keys of ``REGIONS``); empty for object metrics."""
    classes: tuple[str, ...] = ()
    """Object metrics: the classes it is reported for (``presence_<class>``)."""
    precision: int = 4
    """Decimals in the terminal table (dB values: 3)."""
    label: str = ""
    """Name in messages ("LPIPS"); default the upper-case name."""
    default: bool = True
    """Runs unless switched off (CLI ``--no-NAME``); False: only when asked for (``--NAME``)."""
    extra: str | None = None
    """The ``pip install 'dynaeval[EXTRA]'`` it needs, or None."""
    build: str | None = None
    """Frame metrics (and video metrics of kind ``camera``): ``"module:function"``,
    ``function(ctx: FrameContext) -> FrameFn`` (a video metric's ``fn(pred_frames, gt_frames,
    fps, region)``). It may raise ``WeightsUnavailableError`` or ``ImportError``: the metric is
    then reported unavailable with the message, and the run goes on."""
    requires: str | None = None
    """``"module:function"``, ``function(ctx: FrameContext) -> str | None``: why the metric cannot
    run on this machine (a package or weights absent), with what to install, else None. Found
    without running or importing the metric (``importlib.util.find_spec``), so a run that asks
    for the metric by name is refused in a moment, before any work (``require_available``)."""
    settings: str | None = None
    """``"module:function"``, ``function(ctx, enabled: bool, unavailable: str | None) -> dict |
    None``: what the metric records in the results' ``settings[name]`` (None: nothing)."""
    ignored_settings: tuple[str, ...] = ()
    """Fields of ``settings[name]`` that never change a number (device, whether it ran): the
    leaderboard does not compare them."""
    doc: str = ""
    """Heading of its section in docs/metrics.md."""
    options: tuple[tuple[str, Callable[[Any], Any], str], ...] = ()
    """Frame and video metrics: the options a run may set (``ScoreConfig.metric_options``, CLI
    ``--metric-option NAME.OPTION=VALUE``), as ``(option, type, meaning)`` (``type`` converts
    the value and raises ``ValueError``/``TypeError`` for a bad one); its ``build`` reads them
    with ``ctx.option(name, option, default)`` and its ``settings`` record them. A frame
    metric's option ``every`` (a positive integer K) scores only frames whose index is a
    multiple of K: the others have no value (not null), summaries count the scored ones."""
    region_rules: tuple[tuple[str, str], ...] = ()
    """Frame metrics: how its focused / masked variants reduce, ``(("focused", rule), ...)``;
    empty: the rules of PSNR, SSIM and LPIPS (``REGION_RULES``)."""

    def rule(self, region: str) -> str | None:
        """How the ``region`` variant is reduced (None for the whole frame)."""
        if region == "covisible":
            return COVISIBLE_RULE
        return dict(self.region_rules or REGION_RULES.items()).get(region)

    def key(self, variant: str = "whole") -> str:
        """Result key of a variant: a region (``focused`` -> ``focused_psnr``) or a class."""
        if self.classes:
            if variant not in self.classes:
                raise KeyError(f"{self.name} has no class {variant!r} (classes: {self.classes})")
            return f"{self.name}_{variant}"
        if variant not in self.regions:
            raise KeyError(f"{self.name} has no region variant {variant!r} ({self.regions})")
        return REGIONS[variant] + self.name

    def keys(self) -> list[str]:
        """Every result key of the metric, in report order."""
        return [self.key(v) for v in (self.classes or self.regions)]

    def load(self, attr: str) -> Callable[..., Any] | None:
        """The function named by ``build`` or ``settings`` (imported on first use)."""
        target = getattr(self, attr)
        if target is None:
            return None
        module, _, name = target.partition(":")
        return getattr(importlib.import_module(module), name)

    @property
    def title(self) -> str:
        return self.label or self.name.upper()

    @property
    def switch_on(self) -> str:
        """How a CLI run computes it, for messages: ``add --jod`` (or ``drop --no-lpips``)."""
        return f"drop {self.flag}" if self.default else f"add {self.flag}"

    @property
    def flag(self) -> str:
        """The CLI flag that switches it: ``--no-NAME`` for one on by default, else ``--NAME``."""
        name = self.name.replace("_", "-")
        return f"--no-{name}" if self.default else f"--{name}"


def positive_int(value: Any) -> int:
    """An option value as an integer >= 1 (``"10"`` -> 10); ValueError otherwise."""
    if isinstance(value, bool) or (isinstance(value, float) and not value.is_integer()):
        raise ValueError(value)
    out = int(value)
    if out < 1:
        raise ValueError(value)
    return out


positive_int.__name__ = "positive integer"

_UNBOUNDED = (0.0, math.inf)
_FRAME_REGIONS = ("whole", "focused", "masked")
_DYCHECK_REGIONS = (*_FRAME_REGIONS, "covisible")

SPECS: dict[str, MetricSpec] = {
    s.name: s
    for s in (
        MetricSpec(
            "psnr", "frame", True, _UNBOUNDED, "dB",
            "peak signal-to-noise ratio, 10 log10(L^2 / MSE), float64 MSE",
            regions=_DYCHECK_REGIONS, precision=3,
            build="dynaeval.metrics.pixel:build_psnr", doc="PSNR",
        ),
        MetricSpec(
            "ssim", "frame", True, (-1.0, 1.0), "",
            "SSIM (Wang et al. 2004), Gaussian window 11, sigma 1.5, valid windows",
            regions=_DYCHECK_REGIONS,
            build="dynaeval.metrics.structural:build_ssim",
            settings="dynaeval.metrics.structural:ssim_settings", doc="SSIM",
        ),
        MetricSpec(
            "lpips", "frame", False, _UNBOUNDED, "",
            "LPIPS v0.1 of the lpips package (AlexNet backbone unless lpips_net = vgg)",
            regions=_DYCHECK_REGIONS, extra="lpips",
            build="dynaeval.metrics.perceptual:build_lpips",
            requires="dynaeval.metrics.perceptual:missing_package",
            settings="dynaeval.metrics.perceptual:lpips_settings",
            ignored_settings=("enabled", "device", "backend", "unavailable"), doc="LPIPS",
        ),
        MetricSpec(
            "flip", "frame", False, (0.0, 1.0), "",
            "mean of the LDR-FLIP error map (NVIDIA's flip-evaluator, ground truth as the "
            "reference, FLIP's default observer: 67.02 pixels per degree)",
            regions=_FRAME_REGIONS, default=False, extra="video",
            build="dynaeval.metrics.flip:build_flip",
            requires="dynaeval.metrics.flip:missing_package",
            settings="dynaeval.metrics.flip:flip_settings",
            ignored_settings=("enabled", "unavailable"), doc="FLIP",
            options=(("pixels_per_degree", float,
                      "the observer's pixels per degree of visual angle (default 67.02: 0.7 m "
                      "from a 0.7 m wide 3840-px monitor)"),
                     ("every", positive_int,
                      "score every K-th frame only (frame index % K == 0; K-Planes uses 10; "
                      "CLI --flip-every K; default 1)")),
            region_rules=(
                ("focused", "mean of the whole frame's FLIP map over the union of the boxes"),
                ("masked", "mean of the whole frame's FLIP map over the mask's pixels"),
            ),
        ),
        MetricSpec(
            "msssim", "frame", True, (0.0, 1.0), "",
            "MS-SSIM as torchmetrics 1.9 computes it (5 scales, Gaussian 11 taps, sigma 1.5, "
            "reflect padding, relu-normalised), as K-Planes logs it",
            regions=("whole",), default=False, label="MS-SSIM",
            build="dynaeval.metrics.multiscale:build_msssim",
            settings="dynaeval.metrics.multiscale:msssim_settings", doc="MS-SSIM and D-SSIM",
        ),
        MetricSpec(
            "dssim", "frame", False, (0.0, 0.5), "",
            "D-SSIM = (1 - MS-SSIM) / 2, as the DyNeRF-benchmark tables report it",
            regions=("whole",), default=False, label="D-SSIM",
            build="dynaeval.metrics.multiscale:build_dssim",
            settings="dynaeval.metrics.multiscale:msssim_settings", doc="MS-SSIM and D-SSIM",
        ),
        MetricSpec(
            "presence", "object", True, (0.0, 1.0), "",
            "fraction of the frame's ground-truth objects of the class the prediction shows "
            "(tight-box NCC and PSNR against calibrated thresholds, plus the detector when it "
            "made the boxes)",
            regions=(), classes=PRESENCE_CLASSES, doc="Presence",
        ),
        MetricSpec(
            "tight_psnr", "object", True, _UNBOUNDED, "dB",
            "PSNR over the union of the class's objects' tight boxes (raw boxes grown by the "
            "presence margin, not the expanded focus boxes)",
            regions=(), classes=PRESENCE_CLASSES, precision=3, doc="Presence",
        ),
        MetricSpec(
            "warp_error", "pair", False, _UNBOUNDED, "",
            "|E(pred) - E(gt)|, E the error between a frame and the previous one warped by the "
            "ground truth's optical flow",
            regions=("whole", "focused"), doc="Temporal",
        ),
        MetricSpec(
            "tof", "pair", False, _UNBOUNDED, "",
            "tOF: difference of the optical flow of prediction and ground truth, pixels",
            regions=("whole", "focused"), doc="Temporal",
        ),
        MetricSpec(
            "tlp", "pair", False, _UNBOUNDED, "",
            "tLP: difference of LPIPS between consecutive frames, prediction vs ground truth",
            regions=("whole", "focused"), doc="Temporal",
        ),
        MetricSpec(
            "flicker", "camera", False, _UNBOUNDED, "",
            "temporal flicker of static pixels compared with the ground truth",
            regions=("whole", "focused"), doc="Temporal",
        ),
        MetricSpec(
            "jod", "camera", True, (-math.inf, 10.0), "JOD",
            "JOD of the camera's video (ColorVideoVDP unless jod.model = fvvdp; display model "
            "standard_fhd unless jod.display is set), 10 = identical",
            regions=("whole", "focused"), precision=3, default=False, extra="video",
            build="dynaeval.metrics.jod:build_jod",
            requires="dynaeval.metrics.jod:missing_package",
            settings="dynaeval.metrics.jod:jod_settings",
            ignored_settings=("enabled", "unavailable"), doc="JOD",
            options=(("model", str, "cvvdp (ColorVideoVDP, default) or fvvdp (FovVideoVDP, "
                                    "as K-Planes' evaluation)"),
                     ("display", str, "the package's display model (default standard_fhd)"),
                     ("min_window", int, "smallest side of the focused window, px (default 64)")),
            region_rules=(("focused", "a fixed window per camera: the bounding box of the "
                                      "union of its focus boxes over the clip, grown to "
                                      "jod.min_window px, inside the frame"),),
        ),
    )
}
"""Every metric, by base name, in report order."""

_WHERE = {
    "whole": "whole frame",
    "focused": "boxes around players and ball",
    "masked": "moving pixels of the motion mask (or the given masks)",
    "covisible": "covisibility mask (DyCheck)",
}


def _keys_of(spec: MetricSpec) -> list[str]:
    """A spec's base name and every result key it makes."""
    return [spec.name, *(spec.key(r) for r in spec.regions), *(spec.key(c) for c in spec.classes)]


RESULTS_FIELDS = results_fields()
"""Names the results document uses for its own fields, read from its schema (a frame row's
``camera`` ... ``objects``, ``n_frames`` of a camera and the summary, the timing phases
``read`` ..., the settings sections ``protocol`` ..., the document's keys) -> how a message names
each: no metric may take one (a plugin metric named ``gt`` overwrote each row's ground-truth
path, one named ``read`` the timing of reading)."""


def _with_plugins(specs: dict[str, MetricSpec]) -> dict[str, MetricSpec]:
    """``specs`` and, after them, the metrics of installed plugins (entry-point group
    ``dynaeval.metrics``: ``dynaeval.metrics.plugins``)."""
    taken = {key: f"dynaeval's {s.name}" for s in specs.values() for key in _keys_of(s)}
    for key, where in RESULTS_FIELDS.items():
        taken.setdefault(key, where)
    extra = plugin_specs(MetricSpec, taken, _keys_of, kinds=KINDS, plugin_kinds=PLUGIN_KINDS)
    PLUGIN_METRICS.update({s.name: taken[s.name] for s in extra})
    return {**specs, **{s.name: s for s in extra}}


PLUGIN_METRICS: dict[str, str] = {}
"""Name of each metric an installed plugin declares (``dynaeval.metrics.plugins``) -> the plugin,
as messages name it (``metric plugin 'toy' (toy_pkg:SPEC, package toy-pkg)``): its values are
checked as they are computed (``run.stages.base.plugin_outcome``)."""
SPECS = _with_plugins(SPECS)


def _ordered(specs: list[MetricSpec]) -> list[tuple[MetricSpec, str]]:
    """(spec, variant) in report order: region-major (every whole-frame key, then every focused
    one, ...), then the object metrics spec by spec."""
    regional = [(s, r) for r in REGIONS for s in specs if r in s.regions]
    return regional + [(s, c) for s in specs for c in s.classes]


def _infos() -> dict[str, MetricInfo]:
    out: dict[str, MetricInfo] = {}
    for spec, variant in _ordered(list(SPECS.values())):
        key = spec.key(variant)
        where = f"class {variant}" if spec.classes else f"over the {_WHERE[variant]}"
        if spec.build is not None and spec.rule(variant):
            where += f" ({spec.rule(variant)})"
        out[key] = MetricInfo(key, spec.higher_is_better, spec.range, spec.unit,
                              f"{spec.description}; {where}", spec.name, variant, spec.kind,
                              spec.precision)
    return out


METRICS: dict[str, MetricInfo] = _infos()
"""Every result key -> what it means."""


def spec(name: str) -> MetricSpec:
    """The spec of a base name (``psnr``) or of a result key (``focused_psnr``).

    Raises:
        KeyError: no such metric.
    """
    if name in SPECS:
        return SPECS[name]
    if name in METRICS:
        return SPECS[METRICS[name].metric]
    raise KeyError(f"unknown metric {name!r}{did_you_mean(name, METRICS)}; registered: "
                   f"{', '.join(SPECS)}")


def result_key(metric: str, region: str = "whole", *, cls: str | None = None) -> str:
    """The result key of a metric's variant: ``result_key("ssim", "masked") == "masked_ssim"``,
    ``result_key("presence", cls="ball") == "presence_ball"``."""
    return SPECS[metric].key(cls if cls is not None else region)


def keys_of(*kinds: str, region: str | None = None) -> list[str]:
    """Result keys of every metric of the given kinds (optionally one region variant), in report
    order: ``keys_of("pair", "camera")`` is ``warp_error, tof, tlp, flicker, focused_warp_error,
    ...``."""
    bad = [k for k in kinds if k not in KINDS]
    if bad or not kinds:
        raise KeyError(f"kinds must be among {KINDS}, got {kinds}")
    specs = [s for s in SPECS.values() if s.kind in kinds]
    return [s.key(v) for s, v in _ordered(specs) if region is None or v == region]


def frame_specs(names: tuple[str, ...] | list[str] | None = None) -> list[MetricSpec]:
    """The per-frame metric specs, all or those named, in registry order.

    Raises:
        KeyError: a name that is not a per-frame metric.
    """
    return _named([s for s in SPECS.values() if s.kind == "frame"], names, "per-frame metric")


def _named(specs: list[MetricSpec], names: tuple[str, ...] | list[str] | None,
           what: str) -> list[MetricSpec]:
    """``specs``, or those of them ``names`` lists (registry order); KeyError for another name."""
    if names is None:
        return specs
    known = {s.name for s in specs}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise KeyError(f"unknown {what}(s) {unknown}{did_you_mean(unknown[0], known)}; "
                       f"registered: {sorted(known)}")
    return [s for s in specs if s.name in names]


def selectable_specs(names: tuple[str, ...] | list[str] | None = None) -> list[MetricSpec]:
    """The metrics a run chooses (``ScoreConfig.metrics``, ``--NAME`` / ``--no-NAME``): those
    with a ``build`` (per-frame metrics and video metrics such as ``jod``), all or those named,
    in registry order.

    Raises:
        KeyError: a name that is not such a metric.
    """
    return _named([s for s in SPECS.values() if s.build is not None], names, "metric")


def call_hook(spec: MetricSpec, attr: str, *args: Any) -> Any:
    """``spec``'s ``build``, ``settings`` or ``requires`` function called with ``args`` (None
    when it has none).

    Raises:
        PluginError: a plugin's function that cannot be imported or raises, naming the plugin,
            the function and what it raised (it was "internal error (a bug)"); but for a
            ``build`` raising ``WeightsUnavailableError`` or ``ImportError``, which says the
            metric cannot run here, as for dynaeval's own metrics.
    """
    target = getattr(spec, attr)
    if target is None:
        return None
    if spec.name not in PLUGIN_METRICS:
        return spec.load(attr)(*args)
    try:
        return spec.load(attr)(*args)
    except (Exception, SystemExit) as err:  # noqa: BLE001 - the plugin's failure, named
        if attr == "build" and isinstance(err, (WeightsUnavailableError, ImportError)):
            raise
        raise PluginError(f"{PLUGIN_METRICS[spec.name]}: its {attr} function {target!r} raised "
                          f"{type(err).__name__}: {err}") from err


def cannot_run(spec: MetricSpec, ctx: FrameContext) -> str | None:
    """Why ``spec`` cannot run on this machine (its ``requires`` says so, or, a plugin's, it
    raised: ``PluginError``'s message), else None."""
    try:
        return call_hook(spec, "requires", ctx)
    except PluginError as err:
        return str(err)


def require_available(names: tuple[str, ...] | list[str], ctx: FrameContext) -> None:
    """Refuse, before any work, a metric asked for by name that cannot run on this machine (its
    ``requires`` says why): an explicitly requested metric is never silently left out.

    Raises:
        InputError: naming the metric, what is missing, the install line, and how to score
            without it.
    """
    for s in selectable_specs(list(names)):
        why = cannot_run(s, ctx)
        if why:
            without = s.flag if s.default else f"drop {s.flag}"
            raise InputError(f"{s.title} was asked for but cannot run here: {why}; or score "
                             f"without {s.title} ({without}; in the library, leave {s.name!r} "
                             "out of metrics)")


def temporal_keys(region: str | None = None) -> list[str]:
    """Result keys the temporal engine (``dynaeval.metrics.temporal``) computes: the ``pair``
    and ``camera`` metrics without a ``build`` (``warp_error, tof, tlp, flicker`` and their
    focused variants), in report order."""
    specs = [s for s in SPECS.values() if s.kind in ("pair", "camera") and s.build is None]
    return [s.key(v) for s, v in _ordered(specs) if region is None or v == region]


def default_frame_metrics() -> tuple[str, ...]:
    """Names of the chosen metrics that run unless switched off (``psnr``, ``ssim``,
    ``lpips``)."""
    return tuple(s.name for s in selectable_specs() if s.default)


@dataclass
class BuiltMetrics:
    """The per-frame functions of a run, by result key, and what the metrics record."""

    fns: dict[str, tuple[str, FrameFn]] = field(default_factory=dict)
    """Result key -> (region variant, ``fn(pred, gt, region)``), in report order."""
    settings: dict[str, dict] = field(default_factory=dict)
    """Metric name -> its settings section."""
    unavailable: dict[str, str] = field(default_factory=dict)
    """Metric name -> why it could not run (weights or packages absent)."""
    failed: dict[str, str] = field(default_factory=dict)
    """Metric name -> how its plugin failed (its build or settings function raised:
    ``PluginError``); the metric is left out."""
    every: dict[str, int] = field(default_factory=dict)
    """Result key -> K for a frame metric scored on every K-th frame only (option ``every``)."""
    camera_fns: dict[str, tuple[str, Callable[..., float]]] = field(default_factory=dict)
    """Video metrics (kind ``camera`` with a build): result key -> (region variant,
    ``fn(pred_frames, gt_frames, fps, region)``)."""


def build_frame_metrics(
    ctx: FrameContext, names: tuple[str, ...] | list[str], regions: tuple[str, ...] = ("whole",)
) -> BuiltMetrics:
    """Build the functions of the chosen metrics ``names`` (per-frame, and video metrics into
    ``camera_fns``) for the region variants ``regions``.

    A metric whose ``build`` raises ``WeightsUnavailableError`` or ``ImportError`` is left out
    with the reason in ``unavailable`` (and its settings say so); a plugin's metric whose build
    or settings function raises otherwise is left out with the reason in ``failed`` (a settings
    section it cannot write would leave its numbers unexplained). Every per-frame metric's
    settings function is called, so a default metric switched off records ``enabled: false``.
    """
    out = BuiltMetrics()
    built: dict[str, FrameFn] = {}
    wanted = {s.name for s in selectable_specs(list(names))}
    for s in selectable_specs():
        unavailable = None
        try:
            if s.name in wanted:
                try:
                    built[s.name] = call_hook(s, "build", ctx)
                except (WeightsUnavailableError, ImportError) as err:
                    hint = (f" (pip install 'dynaeval[{s.extra}]')" if isinstance(err, ImportError)
                            and s.extra and not isinstance(err, MissingDependency) else "")
                    unavailable = f"{err}{hint}"
                    out.unavailable[s.name] = unavailable
            section = call_hook(s, "settings", ctx, s.name in built, unavailable)
        except PluginError as err:
            if built.pop(s.name, None) is not None or s.name in wanted:  # (not asked: no word)
                out.failed[s.name] = str(err)
            continue
        if section is not None:
            out.settings[s.name] = section
    for region in regions:
        for name, fn in built.items():
            s = SPECS[name]
            if region in s.regions:
                (out.fns if s.kind == "frame" else out.camera_fns)[s.key(region)] = (region, fn)
                every = ctx.option(name, "every", 1) if s.kind == "frame" else 1
                if every != 1:
                    out.every[s.key(region)] = every
    return out


def region_argument(region: str, key: str, protocol: Any, frame: Any) -> dict[str, Any] | None:
    """The ``region`` argument of result ``key``'s function (variant ``region``) on one frame.

    ``{"boxes": ...}`` (focused), ``{"mask": ...}`` (masked), ``{"weights": ...}`` (DyCheck's
    covisible variant; None when the frame has no weights), ``{}`` for the whole frame, or the
    given mask's ``{"weights": ...}`` there when ``protocol`` scores the whole frame with it
    (``Protocol.weighs_whole_frame``) and the metric is one of the protocol's (it has a
    ``covisible`` variant).
    ``frame``: anything with ``boxes``, ``mask`` and ``weights`` (``FrameRegions``), each read
    only when the variant needs it (a packed mask is not unpacked for whole-frame metrics).
    """
    if region == "focused":
        return {"boxes": frame.boxes}
    if region == "masked":
        return {"mask": frame.mask}
    if region == "covisible":
        return None if frame.weights is None else {"weights": frame.weights}
    if (frame.weights is not None and protocol is not None
            and protocol.weighs_whole_frame() and "covisible" in spec(key).regions):
        return {"weights": frame.weights}
    return {}

"""``ScoreConfig``: every setting of a scoring run, checked when it is made.

The defaults are those of ``dynaeval score PRED GT`` (the CLI reads them from here), so
``dynaeval.score(pred, gt)`` and the command give the same numbers. Every setting that changes a
number is written into the results' ``settings``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.io.frames import parse_shard
from dynaeval.metrics.flow import FlowConfig
from dynaeval.metrics.jod import check_fps
from dynaeval.metrics.perceptual import LPIPS_BACKENDS, LPIPS_NETS
from dynaeval.metrics.pixel import QUANTIZE_MODES
from dynaeval.metrics.protocols import PROTOCOL_NAMES, get_protocol
from dynaeval.metrics.registry import (
    SPECS,
    FrameContext,
    default_frame_metrics,
    require_available,
    selectable_specs,
)
from dynaeval.regions.focus import FocusConfig
from dynaeval.regions.sources import focus_source

BACKGROUNDS = ("white", "black")
DEVICES = ("cpu", "cuda", "auto")
KIND_NAMES = {int: "an integer", float: "a number", str: "a string"}
"""How a refusal names the type a metric option is declared with."""


@dataclass
class ScoreConfig:
    """Every setting of a scoring run (checked in ``__post_init__``: a bad value raises
    ``InputError`` before any frame is read)."""

    method: str | None = None
    """Name of the method whose predictions are scored (leaderboard row); default: PRED's name,
    or the render folder's for a known layout."""
    scene: str | None = None
    """Name of the scene (leaderboard column); default: GT's folder name, or the render folder's."""
    metrics: tuple[str, ...] = field(default_factory=default_frame_metrics)
    """Metrics to compute (registry names, ``dynaeval.metrics.registry``): per-frame ones, each
    over the whole frame, the focus boxes and the motion mask, and video ones (``jod``, per
    camera). Default: those the registry runs by default (``psnr``, ``ssim``, ``lpips``); e.g.
    ``("psnr", "ssim")`` skips LPIPS (no torch), ``("psnr", "jod")`` adds JOD."""
    metric_options: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Options of single metrics, ``{metric: {option: value}}``, as each declares them in the
    registry (``MetricSpec.options``), e.g. ``{"flip": {"pixels_per_degree": 40.0}}``; recorded in
    that metric's settings."""
    fps: float = 30.0
    """Frame rate (frames per second) of cameras given as image files, for the video metrics
    (``jod``); a video file's own rate is used instead."""
    lpips_net: str | None = None
    """LPIPS backbone: ``alex`` (as most NeRF papers report) or ``vgg``; None (default): the
    protocol's (``alex``; ``vgg`` for ``3dgs`` and ``4dgaussians``), ``resolved_lpips_net()``."""
    lpips_backend: str = "torch"
    """Runtime of the LPIPS network: ``torch`` (the lpips package) or ``onnxruntime`` (the same
    network exported, ~1.2x faster on CPU, equal to 1e-6: docs/benchmarks.md)."""
    data_range: float = 1.0
    """Value range of the images after reading: always 1.0, since files are mapped to [0, 1] by
    their dtype (uint8 / 255, uint16 / 65535, floats as stored); another value is refused (255
    would add 48 dB to every PSNR). Recorded in the results. To score 0-255 arrays, call the
    metric functions with ``data_range=255``."""
    quantize: str = "none"
    """Quantise both images to 8 bit before scoring: ``none`` (or the protocol's), ``round`` or
    ``truncate`` (``floor(x*255)``), to reproduce evaluators that save renders as 8-bit files."""
    background: str = "white"
    """Colour RGBA frames are composited over: ``white`` (Blender/NeRF-synthetic convention) or
    ``black``."""
    allow_missing: bool = False
    """Score the frames present when a camera misses some predictions (else an error)."""
    focus: FocusConfig | str = field(default_factory=FocusConfig)
    """Regions for ``focused_*`` and ``masked_*`` metrics: a ``FocusConfig``, or the CLI's string
    (``"detector"``, ``"motion"``, ``"none"``, ``"boxes:FILE"``), read as ``--focus`` reads it
    (``FocusConfig.parse``, the other focus settings at their defaults, the detector on
    ``device``). Default: the shipped detector's boxes, expanded as in the seed study, and
    motion masks."""
    presence: bool = True
    """Decide per ground-truth object whether the prediction shows it: ``presence_person``,
    ``presence_ball``, ``tight_psnr_*`` and ``objects`` per frame (``dynaeval.metrics.presence``).
    Needs boxes with classes: focus ``detector`` or ``boxes``."""
    temporal: bool = True
    """Compute the temporal terms (warp_error, tof, tlp, flicker) per camera."""
    flow: str = "dis"
    """Optical flow for the temporal terms: ``dis``, ``farneback`` or ``tvl1``."""
    workers: int = 1
    """Threads scoring frames and temporal pairs; with several cameras, also how many cameras
    are scored at a time. With more than one, OpenCV runs on one thread in each
    (``dynaeval.core.runtime.opencv_threads``). Never changes a number."""
    device: str = "cpu"
    """Torch device for LPIPS: ``cpu``, ``cuda[:i]`` or ``auto`` (``dynaeval.core.runtime``)."""
    progress: bool = True
    """Show a progress bar on stderr."""
    cache_mb: int = 1024
    """Decoded frames kept for reuse (MiB, shared by the cameras scored at a time), so the passes
    over a camera (regions, metrics, temporal) decode each file once where it fits. Never changes a
    number."""
    shard: tuple[int, int] | None = None
    """Score only slice ``(I, N)`` (or ``"I/N"``) of the cameras (``dynaeval.io.frames.select_shard``); the
    shards' results combine with ``dynaeval merge`` into exactly the unsharded numbers."""
    protocol: str = "dynaeval"
    """Whose whole-frame PSNR/SSIM and 8-bit step to reproduce: ``dynaeval``, ``nerfbaselines``,
    ``nerfstudio`` (nerfacto and siblings), ``nerfstudio-splatfacto``, ``3dgs``, ``4dgaussians``,
    ``kplanes`` or ``dycheck`` (``dynaeval.metrics.protocols``; ``quantize`` then defaults to the protocol's;
    ``kplanes`` also computes ``msssim`` and ``dssim``, ``dycheck`` its mPSNR/mSSIM/mLPIPS over
    covisibility masks)."""
    iteration: int | None = None
    """3DGS-family render folders (``MODEL/<split>/ours_<N>``): the ``<N>`` to score; default
    the latest rendered (the others are listed in the warnings)."""
    split: str | None = None
    """3DGS-family render folders: the split to score from ``MODEL`` (default ``test``)."""
    masks: str | None = None
    """Folder of given masks, one grey PNG per ground-truth frame at the same relative path, or
    a DyCheck dataset folder (its ``covisible/<factor>x/<split>/``; ``dynaeval.io.masks``).
    ``masked_*`` are then computed over them (weights > 0.5) instead of the motion masks; the
    protocol uses their weights as its source does (``nerfbaselines``: whole-frame metrics of
    the mask-multiplied images; ``dycheck``: ``mpsnr``/``mssim``/``mlpips``). None: a
    NeRFBaselines render folder's ``mask/`` or DyCheck's ``covisible/`` when found, else none."""
    frames_are_video: bool | None = None
    """Whether each camera's frames are one video (consecutive time steps), which the temporal
    terms and motion masks need. None (default): the layout decides: render folders of separate
    test views (NeRFBaselines, ns-render, gaussian-splatting, a K-Planes PNG set:
    ``RenderLayout.sequence`` False) are scored per frame only (no temporal terms, no motion
    masks or ``masked_*`` over them), ordinary folders and videos as videos; True: scored as a
    video whatever the layout (``--frames-are-video``); False: per frame only. Recorded as
    ``settings["sequence"]`` when the layout's frames are not a video or this is set."""
    prepared: str | None = None
    """A prepared ground truth (``dynaeval prepare GT -o PREP``, ``dynaeval.run.prepare``): its
    regions and ground-truth flows are read instead of computed. Checked against the ground-truth
    files (content hashes) and the settings before the work starts; never changes a number.
    Recorded as ``settings["prepared"]`` (path and id)."""

    def __post_init__(self) -> None:
        self.metrics = _check_metrics(self.metrics)
        self.metric_options = _check_metric_options(self.metric_options, self.metrics)

        self.fps = check_fps(self.fps)  # refusals name the key, the value and what it must be
        _check_data_range(self.data_range)
        _check_choice("quantize", self.quantize, QUANTIZE_MODES)
        _check_choice("background", self.background, BACKGROUNDS)
        _check_choice("lpips_backend", self.lpips_backend, LPIPS_BACKENDS)
        if self.lpips_net is not None:
            _check_choice("lpips_net", self.lpips_net, LPIPS_NETS)
        _check_render_folder(self.iteration, self.split)
        if not (self.device in DEVICES or (isinstance(self.device, str)
                                           and re.fullmatch(r"cuda:\d+", self.device))):
            raise InputError(f"device must be cpu, cuda, cuda:N or auto, got {self.device!r}")
        self._check_switches_names_and_counts()
        self.focus = _checked_focus(self.focus, self.device)

        FlowConfig(method=self.flow)  # raises InputError for an unknown method
        if self.frames_are_video is not None and not isinstance(self.frames_are_video, bool):
            raise InputError(f"frames_are_video must be True, False or None (the layout "
                             f"decides), got {self.frames_are_video!r}")
        if self.masks is not None and not isinstance(self.masks, (str, PathLike)):
            raise InputError(f"masks must be a folder path or None, got {self.masks!r}")
        self._check_protocol()
        self.prepared = _checked_prepared(self.prepared)
        self.shard = _checked_shard(self.shard)
        self.require_metrics()  # last: the values it reads are checked

    def _check_switches_names_and_counts(self) -> None:
        """None; raises InputError unless the switches are booleans, ``method`` and ``scene``
        non-empty strings or None, and ``workers`` and ``cache_mb`` integers at least 1 and 0."""
        for name in ("allow_missing", "presence", "temporal", "progress"):
            value = getattr(self, name)
            if not isinstance(value, bool):  # "false" or "no" read as true before
                raise InputError(f"{name} must be true or false (a boolean), got {value!r} "
                                 f"({type(value).__name__})")
            setattr(self, name, bool(value))
        for name in ("method", "scene"):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, str) or not value.strip()):
                # "" fell back to the folder's name silently
                raise InputError(f"{name} must be a name (a non-empty string) or None, got "
                                 f"{value!r} ({type(value).__name__})")
        for name, low in (("workers", 1), ("cache_mb", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise InputError(f"{name} must be an integer >= {low}, got {value!r}")

    def _check_protocol(self) -> None:
        """None; raises InputError for an unknown protocol or an LPIPS net, background or 8-bit
        step the protocol fixes otherwise."""
        _check_choice("protocol", self.protocol, PROTOCOL_NAMES)
        protocol = get_protocol(self.protocol)
        protocol.check_lpips_net(self.resolved_lpips_net())
        protocol.check_background(self.background)
        self.resolved_quantize()  # raises when the protocol fixes another 8-bit step

    def require_metrics(self, names: tuple[str, ...] | list[str] | None = None) -> None:
        """Refuse, before any work, metrics asked for by name that cannot run on this machine
        (a package or weights absent; ``registry.require_available``). ``names``: default those
        of ``metrics`` that are off by default (``flip``, ``jod``) or given options; the CLI adds
        ``--metrics NAME`` and ``--lpips-net``. A default metric not named (LPIPS without torch)
        is reported unavailable by the run instead, which goes on.

        Raises:
            InputError: the metric, what is missing and the install line.
        """
        if names is None:
            names = [n for n in self.metrics if not SPECS[n].default or n in self.metric_options]
        require_available([n for n in names if n in self.metrics],
                          FrameContext(lpips_net=self.resolved_lpips_net(),
                                       options=self.metric_options))

    def resolved_lpips_net(self) -> str:
        """The LPIPS backbone of the run: the one asked for, else the protocol's."""
        return get_protocol(self.protocol).resolve_lpips_net(self.lpips_net)

    def resolved_quantize(self) -> str:
        """The 8-bit step of the run: the protocol's unless a compatible one was asked for."""
        return get_protocol(self.protocol).resolve_quantize(self.quantize)


def _check_data_range(data_range: object) -> None:
    """None; raises InputError unless ``data_range`` is 1.0 (files are read into [0, 1])."""
    if isinstance(data_range, bool) or data_range != 1.0:
        raise InputError(
            f"data_range must be 1.0 when scoring files, got {data_range!r}: dynaeval "
            "reads every frame into [0, 1] (uint8 / 255, uint16 / 65535, float files as "
            "stored); to score 0-255 arrays, call the metric functions with data_range=255 "
            "(dynaeval.metrics.psnr(pred, gt, data_range=255))")


def _check_render_folder(iteration: object, split: object) -> None:
    """None; raises InputError unless the 3DGS-family render folder's ``iteration`` is an
    integer >= 0 or None and its ``split`` a folder name or None."""
    if iteration is not None and (isinstance(iteration, bool) or not isinstance(
            iteration, int) or iteration < 0):
        raise InputError(f"iteration must be an integer >= 0 or None, got {iteration!r}")
    if split is not None and (not isinstance(split, str) or "/" in split
                              or split in ("", ".", "..")):
        raise InputError(f"split must be a folder name such as 'test' or 'train', got "
                         f"{split!r}")


def _checked_focus(focus: object, device: str) -> FocusConfig:
    """The focus as a ``FocusConfig`` (the CLI's string read as ``--focus`` reads it, the
    detector on ``device``); raises InputError for anything else or an unknown source."""
    if isinstance(focus, str):  # the CLI's form, read as the CLI reads it
        focus = FocusConfig.parse(focus, option="focus", device=device)
    if not isinstance(focus, FocusConfig):
        raise InputError(f"focus must be a FocusConfig or one of the CLI's strings detector, "
                         f"motion, none, boxes:FILE, got {focus!r} "
                         f"({type(focus).__name__})")
    focus_source(focus.source)
    return focus


def _checked_prepared(prepared: object) -> str | None:
    """The prepared folder as a string, or None; raises InputError for a path that is not a
    folder written by ``dynaeval prepare``."""
    if prepared is None:
        return None
    if not isinstance(prepared, str | Path) or not (Path(prepared) / "manifest.json").is_file():
        raise InputError(f"prepared must be a folder written by 'dynaeval prepare' (with a "
                         f"manifest.json), got {prepared!r}")
    return str(prepared)


def _checked_shard(shard: object) -> tuple[int, int] | None:
    """``(I, N)`` of a shard given as ``"I/N"`` or a pair (``parse_shard``), or None."""
    if shard is None:
        return None
    if not isinstance(shard, str | tuple | list):
        raise InputError(f"shard must be 'I/N' or (I, N), got {shard!r} "
                         f"({type(shard).__name__})")
    spec = shard if isinstance(shard, str) else "/".join(map(str, shard))
    return parse_shard(spec)


def _check_choice(name: str, value: object, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise InputError(f"{name} must be one of {', '.join(choices)}, got {value!r}"
                         f"{did_you_mean(value, choices)}")


def _check_metrics(names: object) -> tuple[str, ...]:
    given = tuple(names) if isinstance(names, Iterable) and not isinstance(names, str) else None
    if given is None or not all(isinstance(n, str) for n in given):
        raise InputError(f"metrics must be a sequence of metric names, got {names!r}")
    names = tuple(dict.fromkeys(given))
    try:
        selectable_specs(names)
    except KeyError as err:
        raise InputError(str(err).strip("\"'")) from None
    return names


def _option_value(kind: Any, value: object) -> Any:
    """A metric option's ``value`` as its declared ``kind``: text as the CLI gives it, or a value
    of that kind. Never a boolean, a float for a whole number or a number for a text (``True``
    read as 1.0, ``64.5`` as 64, ``5`` as ``"5"`` before). Raises ValueError otherwise."""
    if isinstance(value, bool) or not isinstance(value, str | int | float) or (
            isinstance(value, float) and kind is not float) or (
            kind is str and not isinstance(value, str)):
        raise ValueError(value)
    return kind(value)


def _check_metric_options(options: object, metrics: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """``{metric: {option: value}}`` checked against the options each metric declares, for
    metrics in ``metrics`` only (an option of a metric not computed is refused, never silently
    unused); values converted to the declared type."""
    if not isinstance(options, dict):
        raise InputError(f"metric_options must be a dict {{metric: {{option: value}}}}, got {options!r}")
    out: dict[str, dict[str, Any]] = {}
    for metric, given in options.items():
        declared = {name: (kind, meaning) for name, kind, meaning in
                    (SPECS[metric].options if metric in SPECS else ())}
        if not declared:
            with_options = [s.name for s in SPECS.values() if s.options]
            raise InputError(f"metric {metric!r} has no options (metrics with options: "
                             f"{', '.join(with_options) or 'none'})")
        if not isinstance(given, dict):
            raise InputError(f"metric_options[{metric!r}] must be a dict, got {given!r}")
        out[metric] = {}
        for name, value in given.items():
            if name not in declared:
                raise InputError(f"{metric} has no option {name!r}; its options: "
                                 f"{', '.join(declared)}")
            kind = declared[name][0]
            try:
                out[metric][name] = _option_value(kind, value)
            except (TypeError, ValueError, InputError):
                what = KIND_NAMES.get(kind, f"a {kind.__name__}")
                raise InputError(f"{metric}.{name} must be {what}, got {value!r} "
                                 f"({type(value).__name__})") from None
        if metric not in metrics:  # checked last: a misspelt option is the clearer message
            raise InputError(f"metric_options[{metric!r}] sets options of {SPECS[metric].title}, "
                             f"which is not computed: add {metric!r} to metrics "
                             f"(CLI: {SPECS[metric].switch_on}), or drop the options")
    return out

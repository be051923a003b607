"""Regions of one camera for scoring: boxes (detector, boxes file or motion) and motion masks.

Regions come from the **ground truth only**, so that every method scored on a scene is scored on
the same pixels. ``camera_regions`` returns a camera's ``CameraRegions``: one ``FrameRegions`` per
frame (a frame with no box, or no moving pixel, carries the reason instead, and its focused
(masked) metrics are null) and the facts of the camera as a whole (no video, its static check).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.boxes import clip_boxes
from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.core.outcome import Outcome, Status, note
from dynaeval.core.runtime import file_sha256
from dynaeval.core.terminal import raw_stream
from dynaeval.io import find_frames
from dynaeval.io.images import FrameCache
from dynaeval.regions.boxes_file import frame_key, read_boxes_file, records_to_boxes
from dynaeval.regions.detector import (
    DEFAULT_DETECTOR,
    Detector,
    DetectorConfig,
    detector_warnings,
)
from dynaeval.regions.expand import ExpandConfig, expand_boxes
from dynaeval.regions.motion import LazyFrames, MotionConfig, iter_motion_masks, mask_boxes
from dynaeval.regions.packed import PackedMask
from dynaeval.regions.sources import (
    BOXES_FILE_PREFIX,
    SOURCE_KINDS,
    BoxesFileSource,
    FocusSource,
    focus_source,
)
from dynaeval.regions.static_camera import CameraMotion, static_check

FOCUS_SOURCES = tuple(SOURCE_KINDS)
"""The names of the focus sources (``dynaeval.regions.sources``), in ``--focus`` order."""
BOXES_SOURCES = tuple(n for n, k in SOURCE_KINDS.items() if k.detects or k.from_motion)
"""The sources ``detect_ground_truth`` (``dynaeval detect --source``) makes boxes from."""
MIN_MOTION_FRAMES = 3
"""Motion masks compare a frame with the temporal median: fewer frames give no stable median."""
NOT_A_VIDEO = "not a video: frames differ in size/channels"
"""Why a camera whose frames differ in shape (a static scene's test set, photos) has no motion
mask and no temporal term: its per-frame metrics are scored, frame by frame."""


class FramesDiffer(Exception):
    """Frame ``index`` of a camera has another shape than frame 0: the camera is no video.

    Not an error of the input: ``camera_regions`` and ``dynaeval.run.scoring`` catch it and score
    the frames one by one (motion masks and temporal terms null with ``NOT_A_VIDEO``).
    """

    def __init__(self, index: int, shape: tuple[int, ...], first: tuple[int, ...]) -> None:
        self.index, self.shape, self.first = index, tuple(shape), tuple(first)
        super().__init__(f"frame {index} is {_hwc(self.shape)}, frame 0 is {_hwc(self.first)}")

    def reason(self) -> str:
        """``NOT_A_VIDEO`` with the two shapes."""
        return f"{NOT_A_VIDEO} ({self})"


def _hwc(shape: tuple[int, ...]) -> str:
    h, w = shape[:2]
    c = shape[2] if len(shape) > 2 else 1
    return f"{w}x{h} px, {c} channel(s)"


def same_shape(load: Callable[[int], np.ndarray], first: tuple[int, ...]) -> Callable[[int], np.ndarray]:
    """``load`` that raises ``FramesDiffer`` when frame ``i``'s shape is not ``first``."""
    def checked(i: int) -> np.ndarray:
        frame = load(i)
        if frame.shape != first:
            raise FramesDiffer(i, frame.shape, first)
        return frame

    return checked


@dataclass(frozen=True)
class FocusConfig:
    """Where focused and masked metrics look (all of it goes into the results' settings)."""

    source: str = "detector"
    """Boxes for ``focused_*``: ``detector`` (ONNX detector on the ground truth), ``motion``
    (connected components of the motion masks), ``boxes`` (a boxes file) or ``none``."""
    boxes_file: str | None = None
    """With ``source="boxes"``: the boxes file (``dynaeval detect`` or the scene generator)."""
    detector_model: str | None = None
    """ONNX detector file; None: the detector shipped with dynaeval."""
    classes: tuple[str | int, ...] | None = None
    """The detector's classes to keep, by name or integer class id (``DetectorConfig.classes``;
    None: its default, person and sports ball). Only with ``source="detector"``."""
    expand: str = "paper"
    """Box expansion rule applied to boxes from any source: ``paper`` (width x7, height x2.5,
    the seed study's rule), ``margin`` or ``none``; expanded boxes are clipped and merged."""
    masked: bool = True
    """Compute motion masks of each (static) camera and the ``masked_*`` metrics over them."""
    motion_kind: str = "isg"
    """Motion weights: ``isg`` (difference to the temporal median) or ``ist``."""
    device: str = "cpu"
    """Device for the detector (onnxruntime execution provider)."""

    def __post_init__(self) -> None:
        kind = SOURCE_KINDS.get(self.source)
        if self.classes is not None and kind is not None and not kind.detects:
            raise InputError(f"classes select the detector's classes and need focus 'detector', "
                             f"got focus {self.source!r}: drop --classes, or pass --focus detector")

    @property
    def kind(self) -> FocusSource:
        """The kind of ``source`` (``dynaeval.regions.sources``; InputError for an unknown one)."""
        return focus_source(self.source)

    def detector_config(self, **kwargs: Any) -> Any:
        """The ``DetectorConfig`` of this focus (model, device, classes)."""
        extra = {} if self.classes is None else {"classes": tuple(self.classes)}
        return DetectorConfig(model=self.detector_model, device=self.device, **extra, **kwargs)

    @staticmethod
    def parse(spec: str, *, option: str = "--focus", **kwargs: Any) -> FocusConfig:
        """Build from the CLI form: ``detector``, ``motion``, ``none`` or ``boxes:FILE``.

        ``option``: how messages name the setting (``"--focus"`` for the CLI, ``"focus"`` for
        ``ScoreConfig(focus="motion")`` / ``dynaeval.score(..., focus="motion")``); ``kwargs``:
        the other ``FocusConfig`` fields.
        """
        if spec.startswith(BOXES_FILE_PREFIX):
            path = spec[len(BOXES_FILE_PREFIX):]
            if not path:
                raise InputError(f"{option} boxes:FILE needs a file name after 'boxes:'")
            return FocusConfig(source=BoxesFileSource.name, boxes_file=path, **kwargs)
        if spec not in SOURCE_KINDS or SOURCE_KINDS[spec].reads_file:
            more = "" if option.startswith("-") else (
                "; or a FocusConfig (dynaeval.regions.focus) to set expand, classes, "
                "detector_model or masked as well")
            raise InputError(
                f"{option} must be detector, motion, none or boxes:FILE, got {spec!r}"
                f"{did_you_mean(spec, [k.spec for k in SOURCE_KINDS.values()])}{more}"
            )
        return FocusConfig(source=spec, **kwargs)


@dataclass
class FrameRegions:
    """The regions of one frame: boxes to focus on and the motion mask (or why there is none)."""

    boxes: np.ndarray | None = None
    """(N, 4) int64 expanded, clipped and merged boxes; None when there is no box."""
    boxes_missing: Outcome | None = None
    """Why ``boxes`` is None: a null ``Outcome`` (status ``NO_REGION``, ``DISABLED``, ...; detail
    the words for people), the very outcome a focused metric of the frame gets; None with boxes."""
    packed_mask: PackedMask | None = None
    """The motion mask, or the given mask (``dynaeval.regions.given``), bit-packed (a camera's
    frames keep theirs until its temporal pass ends: 1/8 of the bool masks); None when there
    is none. ``mask`` unpacks it."""
    mask_missing: Outcome | None = None
    """Why ``mask`` is None: a null ``Outcome`` (``EMPTY_REGION``, ``NOT_A_VIDEO``, ...), what a
    masked metric of the frame gets; None with a mask."""
    raw_boxes: np.ndarray | None = None
    """(N, 4) boxes as found, before expansion (for reports)."""
    records: list[dict] | None = None
    """The objects behind ``raw_boxes`` with their classes (boxes-file or detector records
    ``{class, id, box, ...}``); None for motion boxes, which have no class."""
    size: tuple[int, int] | None = None
    """(H, W) that ``raw_boxes`` were clipped and ``boxes`` expanded to (the frame's size when
    it was read; frame 0's for a boxes file, see ``fit_to``)."""
    weights: np.ndarray | None = None
    """(H, W) float32 weights in [0, 1] of a given mask (``dynaeval.regions.given``), for the
    protocols that use them (``Protocol.masks``); None without given masks."""

    @property
    def mask(self) -> np.ndarray | None:
        """(H, W) bool motion (or given) mask, unpacked from ``packed_mask`` on each access (a
        new array); None when there is none."""
        return None if self.packed_mask is None else self.packed_mask.unpack()


@dataclass
class CameraRegions:
    """The regions of one camera: each frame's, and the facts of the camera as a whole."""

    frames: list[FrameRegions]
    """One ``FrameRegions`` per frame, in the camera's frame order."""
    not_video: FramesDiffer | None = None
    """The camera's frames differ in shape (the first difference; its ``reason()`` is the
    text): no motion mask, no temporal term; None for a video."""
    motion: CameraMotion | None = None
    """The camera's static check (``static_camera.static_check``), made when it gets motion
    masks or given ones (a video of at least ``MIN_MOTION_FRAMES`` frames); None otherwise."""


@dataclass
class RegionSources:
    """Per-run state shared by all cameras: the opened detector or the boxes file."""

    config: FocusConfig
    detector: Any = None
    """The detector of ``--focus detector``, or the one that wrote the boxes file (``dynaeval
    detect``), re-opened so presence runs the same detector test on the prediction; or None."""
    boxes: dict[str, list[dict]] | None = None
    classes: tuple[str, ...] = ()
    """Classes the boxes are counted under in ``regions_summary`` (the detector's selection;
    person and ball for a boxes file)."""
    settings: dict[str, Any] = field(default_factory=dict)
    warnings: list[dict] = field(default_factory=list)
    """Run-level warnings about the sources (``dynaeval.core.outcome.note``): the bundled detector on
    footage it was not trained for, output names overruled by dtypes."""
    detector_note: str | None = None
    """Why a detector's boxes file does not re-run its detector (its model is not here)."""
    given_masks: bool = False
    """The run's masks are given (``--masks``; ``dynaeval.regions.given``): they replace the
    motion masks wherever a mask is used, so motion masks are found only for ``--focus motion``
    boxes (a camera still gets its static check, ``CameraRegions.motion``)."""


def open_sources(config: FocusConfig) -> RegionSources:
    """Open the detector or read the boxes file once per run; describe them for the results.

    Raises:
        InputError: the focus source is unknown, the boxes file or detector model is unusable.
    """
    kind = config.kind
    settings: dict[str, Any] = {"source": config.source, "expand": _expand_settings(config.expand)}
    src = RegionSources(config=config, settings=settings)
    if kind.reads_file:
        bf = read_boxes_file(config.boxes_file)
        src.boxes = bf.boxes
        src.classes = ("person", "ball")

        settings["boxes_file"] = {
            "path": str(config.boxes_file),
            "sha256": file_sha256(config.boxes_file),
            "source": bf.source,
        }
        src.detector, src.detector_note = boxes_file_detector(bf.source, config.device)
    elif kind.detects:
        det = Detector(config.detector_config())
        src.detector = det
        src.classes = det.selected_names
        settings["detector"] = det.source()

        src.warnings.extend(detector_warnings(det))
    if config.masked or kind.from_motion:
        settings["motion"] = {"kind": config.motion_kind, "min_frames": MIN_MOTION_FRAMES}
    return src


def boxes_file_detector(source: dict[str, Any] | None, device: str) -> tuple[Any, str | None]:
    """The detector that wrote a boxes file (``dynaeval detect``: ``source`` has its model, hash
    and settings), re-opened with the same settings, so that ``--focus boxes:FILE`` scores what
    ``--focus detector`` scores; ``(None, None)`` for a file no detector wrote (the scene
    generator's), ``(None, why)`` when its model is not here with the same SHA-256."""
    if not isinstance(source, dict) or source.get("kind") != "detector":
        return None, None  # the scene generator's boxes, or motion boxes: region test only

    source = source.get("detector", source)  # dynaeval detect nests it under "detector"
    sha = source.get("model_sha256")
    model = Path(str(source.get("model", "")))
    if not (model.is_file() and file_sha256(model) == sha):
        model = DEFAULT_DETECTOR  # the bundled one, from another checkout or install
        if not (model.is_file() and file_sha256(model) == sha):
            return None, (f"the detector that wrote the boxes file ({source.get('model')}) is "
                          "not on this machine with the same SHA-256: presence ran the region "
                          "test only")
    saved = dict(source.get("settings") or {})
    fields = {k: saved[k] for k in DetectorConfig.__dataclass_fields__ if k in saved}
    for key in ("classes", "class_names"):
        if isinstance(fields.get(key), list):
            fields[key] = tuple(fields[key])
    if isinstance(fields.get("aliases"), list):
        fields["aliases"] = tuple(tuple(a) for a in fields["aliases"])
    fields.update(model=str(model), device=device)
    return Detector(DetectorConfig(**fields)), None


def _expand_settings(rule: str) -> dict[str, Any]:
    return asdict(ExpandConfig.preset(rule))


def camera_regions(
    camera: str,
    frames: Sequence[str],
    load_gt: Callable[[int], np.ndarray],
    shape: tuple[int, int],
    sources: RegionSources,
    executor: Executor | None = None,
    paths: Sequence[object] | None = None,
    on_frame: Callable[[float], None] | None = None,
) -> CameraRegions:
    """Regions of every frame of one camera, computed from its ground truth.

    Args:
        camera: camera name (boxes-file keys are ``"<camera>/<frame>"``).
        frames: frame names in temporal order.
        load_gt: ``i -> (H, W, C) float32`` ground truth of frame ``i`` in [0, 1].
        shape: (H, W) of frame 0.
        sources: from ``open_sources``.
        executor: optional thread executor: ISG motion masks and detector runs of the frames are
            computed on it (``load_gt`` and the detector must be thread-safe; the regions are
            those of the sequential run).
        paths: the ground-truth file of each frame, named in the detector's errors.
        on_frame: progress: called with ``share`` each time a frame's pass is done, ``share``
            ``= 1 / passes`` of the per-frame passes that run (motion masks, the detector), so
            a camera's frames add up to about one unit each (a camera whose frames differ in
            shape is found again, frame by frame: its calls may add up to more).

    Returns:
        The camera's regions, one ``FrameRegions`` per frame. When the frames differ in shape
        (not a video: a static scene's test set, photos), every frame's boxes are found and
        clipped on its own, there is no motion mask (reason ``NOT_A_VIDEO``) and
        ``CameraRegions.not_video`` says so.
    """
    try:
        return _camera_regions(camera, frames, load_gt, sources, executor, paths, on_frame,
                               video=True)
    except FramesDiffer as err:
        out = _camera_regions(camera, frames, load_gt, sources, executor, paths, on_frame,
                              video=False)
        for r in out.frames:
            if r.mask_missing is not None and r.mask_missing.status is Status.NOT_A_VIDEO:
                r.mask_missing = Outcome(None, Status.NOT_A_VIDEO, err.reason())
            if r.boxes_missing is not None and r.boxes_missing.status is Status.NOT_A_VIDEO:
                r.boxes_missing = Outcome(None, Status.NOT_A_VIDEO, err.reason())
        return replace(out, not_video=err)


def _camera_regions(camera: str, frames: Sequence[str], load_gt: Callable[[int], np.ndarray],
                    sources: RegionSources, executor: Executor | None,
                    paths: Sequence[object] | None, on_frame: Callable[[float], None] | None,
                    *, video: bool) -> CameraRegions:
    """``camera_regions``; ``video``: the frames are checked to share frame 0's shape
    (``FramesDiffer`` otherwise) and get motion masks; False: each frame on its own."""
    cfg = sources.config
    first = load_gt(0).shape
    load = same_shape(load_gt, first) if video else load_gt
    out = [FrameRegions() for _ in frames]
    find_masks = (cfg.kind.from_motion or (cfg.masked and not sources.given_masks)) and video
    passes = int(find_masks and len(out) >= MIN_MOTION_FRAMES) + int(cfg.kind.detects)
    tick = None if on_frame is None or not passes else (lambda: on_frame(1 / passes))
    check = _camera_masks(out, camera, load, sources, executor, tick, find_masks=find_masks,
                          video=video)
    detections = (_detections(camera, frames, load, sources, executor, paths)
                  if cfg.kind.detects else None)
    for i, (name, r) in enumerate(zip(frames, out, strict=True)):
        raw = _frame_boxes(r, camera, name, sources, detections)
        if detections is not None and tick is not None:
            tick()  # this frame's detector run is done
        if raw is None:
            continue
        if isinstance(raw, tuple):  # the detector: (frame's (H, W), boxes)
            (h, w), raw = raw
        else:
            h, w = first[:2] if video else load(i).shape[:2]
        raw = clip_boxes(raw, h, w)
        r.raw_boxes, r.size = raw, (h, w)
        if len(raw) == 0:
            r.boxes_missing = Outcome(None, Status.NO_REGION, cfg.kind.no_box)
            continue
        r.boxes = expand_boxes(raw, cfg.expand, h, w)
    return CameraRegions(out, motion=check)


def _camera_masks(out: list[FrameRegions], camera: str, load: Callable[[int], np.ndarray],
                  sources: RegionSources, executor: Executor | None,
                  tick: Callable[[], None] | None, *, find_masks: bool,
                  video: bool) -> CameraMotion | None:
    """Set the frames' motion masks (``find_masks``) or why they have none; returns the
    camera's static check (None when it has none: too few frames, no video, no mask asked)."""
    cfg = sources.config
    if find_masks:
        return _add_motion_masks(out, camera, load, cfg.motion_kind, executor, cfg.source, tick)
    if cfg.masked and video:  # given masks replace the motion masks: none found (they were,
        # then dropped), the camera's static check only (its note: regions.given)
        enough = len(out) >= MIN_MOTION_FRAMES
        return static_check(load, len(out), None, cfg.source) if enough else None
    if cfg.masked or cfg.kind.from_motion:
        for r in out:
            r.mask_missing = Outcome(None, Status.NOT_A_VIDEO, NOT_A_VIDEO)
    return None


def _detections(camera: str, frames: Sequence[str], load: Callable[[int], np.ndarray],
                sources: RegionSources, executor: Executor | None,
                paths: Sequence[object] | None) -> Iterator[tuple[tuple[int, int], Any]]:
    """The detector's ``(frame's (H, W), Detections)`` of each frame in order, computed on
    ``executor`` when given (lazily, as the frames are taken); an InputError of the detector
    names the frame and its file."""
    def detect(i: int) -> tuple[tuple[int, int], Any]:
        frame = load(i)
        try:
            return frame.shape[:2], sources.detector(frame)
        except InputError as err:
            if err.path is not None or paths is None:
                raise
            raise InputError(f"camera {camera!r} frame {frames[i]!r}: {err}",
                             path=str(paths[i])) from err

    indices = range(len(frames))
    return executor.map(detect, indices) if executor else map(detect, indices)


def fit_to(r: FrameRegions, size: tuple[int, int], config: FocusConfig) -> FrameRegions:
    """``r`` with its boxes clipped and expanded to a frame of ``size`` (H, W).

    A boxes file's boxes are clipped to frame 0's size without reading the other frames; a
    frame of another size (a camera that is no video) gets them fitted here, when it is read.
    """
    if r.raw_boxes is None or r.size is None or tuple(size) == r.size:
        return r

    h, w = size
    raw = clip_boxes(records_to_boxes(r.records) if r.records is not None else r.raw_boxes, h, w)
    boxes = expand_boxes(raw, config.expand, h, w) if len(raw) else None
    missing = (None if boxes is not None
               else Outcome(None, Status.NO_REGION, config.kind.no_box))
    return replace(r, raw_boxes=raw, boxes=boxes, boxes_missing=missing, size=(h, w))


def _add_motion_masks(out: list[FrameRegions], camera: str, load_gt: Callable[[int], np.ndarray],
                      kind: str, executor: Executor | None, focus: str = "detector",
                      tick: Callable[[], None] | None = None) -> CameraMotion | None:
    """Set each frame's motion mask, or the reason it has none (too few frames, no motion);
    ``tick()`` after each frame's mask (progress). Returns the camera's static check (None
    with too few frames)."""
    if len(out) < MIN_MOTION_FRAMES:
        for r in out:
            r.mask_missing = Outcome(None, Status.UNDEFINED, (
                f"motion masks need >= {MIN_MOTION_FRAMES} frames of a static camera, "
                f"camera {camera!r} has {len(out)}"))
        return None
    lazy = LazyFrames(list(range(len(out))), load_gt)
    masks = iter_motion_masks(lazy, MotionConfig(kind=kind), executor)
    fractions = []
    for r, m in zip(out, masks, strict=True):
        if tick is not None:
            tick()
        fractions.append(float(m.mean()))
        if m.any():
            r.packed_mask = PackedMask.pack(m)
        else:
            r.mask_missing = Outcome(None, Status.EMPTY_REGION, "no moving pixel in the ground truth")
    return static_check(load_gt, len(out), float(np.mean(fractions)), focus)


def _frame_boxes(r: FrameRegions, camera: str, name: str, sources: RegionSources,
                 detections: Iterator[Any] | None) -> np.ndarray | tuple | None:
    """The raw boxes of one frame from the focus source (setting ``r.records``), or None with
    ``r.boxes_missing`` set. ``detections``: ``(frame's (H, W), Detections)``, one per frame, in
    order; the detector's boxes come back with the frame's size, ``((H, W), boxes)``."""
    kind = sources.config.kind
    if not kind.gives_boxes:
        r.boxes_missing = Outcome(None, Status.DISABLED, "no focus regions requested (--focus none)")
        return None
    if kind.reads_file:
        records = sources.boxes.get(frame_key(camera, name))
        if records is None:
            r.boxes_missing = Outcome(None, Status.NO_REGION,
                                      f"frame {frame_key(camera, name)!r} is not in the boxes file")
            return None
        r.records = list(records)
        return records_to_boxes(records)
    if kind.detects:
        hw, found = next(detections)
        r.records = found.records()
        return hw, found.boxes
    if r.packed_mask is None:  # motion
        r.boxes_missing = r.mask_missing
        return None

    return mask_boxes(r.mask, min_area=16)


def detect_ground_truth(
    gt_dir: str | Path,
    *,
    source: str = "detector",
    detector_model: str | None = None,
    device: str = "cpu",
    progress: bool = True,
    classes: Sequence[str | int] | None = None,
    warnings: list[dict] | None = None,
) -> tuple[dict[str, list[dict]], dict[str, Any]]:
    """Boxes of every ground-truth frame, for a boxes file that several scoring runs reuse.

    Args:
        gt_dir: ground-truth folder (the layout ``dynaeval score`` reads).
        source: ``detector`` (the ONNX detector) or ``motion`` (connected components of the
            motion masks of each camera).
        detector_model: ONNX file; None for the detector shipped with dynaeval.
        device: onnxruntime device: ``cpu``, ``cuda[:i]`` or ``auto`` (``dynaeval.core.runtime``).
        progress: show a progress bar on stderr.
        classes: the detector's classes to keep (names or ids; None: person and sports ball).
        warnings: if given, the warnings about the detector (``detector_warnings``) and, with
            ``source="motion"``, about cameras that move are appended to it.

    Returns:
        ``(mapping, source)``: ``"<camera>/<frame>"`` -> records ``{class, id, box, ...}`` of the
        raw (unexpanded) boxes, and what made them, ready for ``write_boxes_file``.
    """
    from tqdm.auto import tqdm

    if source not in BOXES_SOURCES:
        raise InputError(f"boxes source must be detector or motion, got {source!r}")
    cameras = find_frames(gt_dir, role="ground truth")
    total = sum(len(c.frames) for c in cameras.values())
    mapping: dict[str, list[dict]] = {}
    kind = focus_source(source)
    config = FocusConfig(source=source, detector_model=detector_model, expand="none",
                         masked=kind.from_motion, device=device,
                         classes=None if classes is None else tuple(classes))
    sources = open_sources(config)
    if warnings is not None:
        warnings.extend(sources.warnings)
    with tqdm(total=total, desc="detecting", unit="frame", disable=not progress,
              leave=False, file=raw_stream(sys.stderr)) as bar:  # it draws in place
        for cam in cameras.values():
            refs = [ref for _, ref in cam.frames]
            names = [name for name, _ in cam.frames]
            if kind.detects:
                for name, ref in zip(names, refs, strict=True):
                    mapping[frame_key(cam.name, name)] = sources.detector(ref.read()).records()
                    bar.update(1)
                continue
            cache = FrameCache(2**30)  # the motion pass reads every frame twice
            regions = camera_regions(cam.name, names, lambda i, r=refs, c=cache: c.read(r[i]),
                                     cache.read(refs[0]).shape[:2], sources)
            moving = regions.motion
            if warnings is not None and moving is not None and moving.reason:
                warnings.append(note(moving.reason, camera=cam.name))
            for name, reg in zip(names, regions.frames, strict=True):
                boxes = reg.raw_boxes if reg.raw_boxes is not None else np.zeros((0, 4), int)
                mapping[frame_key(cam.name, name)] = [
                    {"class": "motion", "id": i, "box": [int(v) for v in b]}
                    for i, b in enumerate(boxes)
                ]
                bar.update(1)
    return mapping, {"kind": source, **sources.settings}


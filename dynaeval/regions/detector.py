"""Boxes from any object detector exported to ONNX, run through onnxruntime.

Two output conventions are decoded (``DetectorConfig.convention``; ``"auto"`` tells them apart
from the graph's outputs), each by its own module:

* **YOLO-style** (Ultralytics YOLOv8/11 exports; ``dynaeval.regions.yolo``): the image
  letterboxed into a ``(1, 3, S, S)`` input; one output ``(1, 4 + C, N)``.
* **torchvision-style** (``torchvision.models.detection`` RetinaNet / Faster R-CNN / FCOS exports;
  ``dynaeval.regions.torchvision_onnx``): the image at its own size; outputs ``boxes (N, 4)``,
  ``scores (N,)``, ``labels (N,)``.

Class names come from ``DetectorConfig.class_names``, else the model's ``names`` metadata (what
Ultralytics writes, e.g. ``"{0: 'person', ...}"``), else COCO (80 names for YOLO, torchvision's
91-index list). Then, in the order of Ultralytics' predictor (``non_max_suppression`` then
``scale_boxes``): class filter, score strictly above the threshold, per-class NMS on the
unclipped boxes in the model's input pixels, top-k, map to the image, clip, and integer boxes
rounded outwards (floor the min, ceil the max; max exclusive, see ``boxes.py``).

Images given to ``detect`` are ``(H, W, 3)`` **RGB**, uint8 in [0, 255] or float in [0, 1].
``detector_warnings`` are a run's warnings about its detector (the bundled synthetic-scene one on
footage it was not trained for, output names overruled by their dtypes).
"""

from __future__ import annotations

import ast
import functools
import json
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.boxes import batched_nms
from dynaeval.core.errors import InputError
from dynaeval.core.outcome import note
from dynaeval.core.runtime import file_sha256, load_session, onnx_providers
from dynaeval.core.validation import as_image, grey_to_rgb
from dynaeval.regions import torchvision_onnx, yolo
from dynaeval.regions.coco import COCO80_NAMES, COCO91_NAMES  # noqa: F401  (re-export)
from dynaeval.regions.fetch import provenance, resolve_name
from dynaeval.regions.yolo import letterbox  # noqa: F401  (re-export: reference_models, tests)

DEFAULT_DETECTOR = Path(__file__).resolve().parents[1] / "models" / "detector.onnx"
"""Where the packaged default detector (person + ball, trained on the synthetic scenes) lives."""

DECODERS = {"yolo": yolo, "torchvision": torchvision_onnx}
"""Convention name -> its decoder module (``fits``, ``default_names``, ``output_roles``,
``prepare``, ``decode``, ``to_image``, ``n_classes``); ``"auto"`` takes the first that fits the
graph's outputs."""

MAX_NMS = 30000
"""At most this many candidates (highest scores) enter NMS, as Ultralytics' ``max_nms``."""

CONVENTIONS = ("auto", *DECODERS)


@dataclass(frozen=True)
class DetectorConfig:
    """Which ONNX detector to run and how to turn its raw output into boxes."""

    model: str | Path | None = None
    """Path of the ``.onnx`` file; None means the packaged default ``DEFAULT_DETECTOR``."""
    convention: str = "auto"
    """Output convention: ``"yolo"``, ``"torchvision"`` or ``"auto"`` (decided from the outputs)."""
    classes: tuple[str | int, ...] = ("person", "sports ball")
    """Classes kept, by name (matched through ``aliases``) or by the model's integer class id."""
    class_names: tuple[str, ...] | None = None
    """Override the model's class names (index = class id); None: model metadata, else COCO."""
    aliases: tuple[tuple[str, str], ...] = (("sports ball", "ball"),)
    """Name -> name used in boxes files (``sports ball`` is written ``ball``, as the scenes do);
    a requested name matches a model class when both map to the same name."""
    score_threshold: float = 0.25
    """Only detections with a score strictly above this (in [0, 1]) are kept (Ultralytics'
    ``conf > conf_thres``, torchvision's ``scores > score_thresh``)."""
    nms_iou: float = 0.45
    """Per-class NMS: a box whose IoU with a higher-scored box of its class exceeds this is dropped
    (computed on the unclipped boxes in the model's input pixels)."""
    input_size: int | None = None
    """YOLO letterbox side in px when the graph's input size is dynamic (None: 640). Torchvision:
    None feeds the image at its own size; an int resizes the longer side to it."""
    max_detections: int = 300
    """At most this many boxes per image (highest scores first)."""
    device: str = "cpu"
    """``"cpu"``, ``"cuda"`` (error if onnxruntime has no CUDA provider) or ``"auto"``."""
    model_thresholds: bool = True
    """Also apply the model's per-class minimum scores, its ``score_thresholds`` metadata (e.g.
    ``"{'person': 0.25, 'ball': 0.5}"``: the bundled detector's, calibrated on held-out renders,
    docs/detector.md): a box is kept when its score is above both ``score_threshold`` and its
    class's. False: ``score_threshold`` alone (precision-recall curves)."""

    def __post_init__(self) -> None:
        if self.convention not in CONVENTIONS:
            raise InputError(f"detector convention must be one of {', '.join(CONVENTIONS)}, got {self.convention!r}")
        if self.device not in ("cpu", "cuda", "auto"):
            raise InputError(f"detector device must be 'cpu', 'cuda' or 'auto', got {self.device!r}")
        if not 0.0 <= self.score_threshold <= 1.0:
            raise InputError(f"score_threshold must be in [0, 1], got {self.score_threshold!r}")
        if not 0.0 <= self.nms_iou <= 1.0:
            raise InputError(f"nms_iou must be in [0, 1], got {self.nms_iou!r}")
        if self.input_size is not None and self.input_size < 32:
            raise InputError(f"input_size must be >= 32 px or None, got {self.input_size!r}")
        if self.max_detections < 1:
            raise InputError(f"max_detections must be >= 1, got {self.max_detections!r}")
        if not self.classes:
            raise InputError("classes is empty: name at least one class (e.g. 'person') or class id")


# --------------------------------------------------------------------------------------------
# Files


def resolve_model_path(model: str | Path | None) -> Path:
    """The detector file to load: ``model`` itself when it is a file, else a name fetched by
    ``dynaeval detector fetch`` (``dynaeval.regions.fetch``); InputError when neither."""
    if model is None:
        if not DEFAULT_DETECTOR.is_file():
            raise InputError(
                "no default detector in this install (dynaeval/models/detector.onnx is missing). "
                "Pass --detector FILE.onnx (docs/regions.md shows how to export a torchvision "
                "RetinaNet or a YOLO model), or score with --focus motion or --focus boxes:FILE",
                path=DEFAULT_DETECTOR,
            )
        return DEFAULT_DETECTOR
    path = Path(model)
    if path.is_file():
        return path
    if path.suffix.lower() != ".onnx" and path.parent == Path("."):  # a name: fetched detector

        return resolve_name(str(model))
    raise InputError("detector model not found: expected an .onnx file, or the name of a "
                     "detector fetched with 'dynaeval detector fetch NAME'", path=path)


# --------------------------------------------------------------------------------------------
# Model metadata


def _parse_names(raw: str | None) -> dict[int, str] | None:
    """Class names from ONNX metadata: a dict ``{id: name}`` or a list, as Python or JSON text."""
    if not raw:
        return None
    try:
        value = ast.literal_eval(raw)
    except (ValueError, SyntaxError, RecursionError, MemoryError):  # not Python: try JSON
        try:
            value = json.loads(raw)
        except (json.JSONDecodeError, RecursionError):
            return None
    if isinstance(value, Mapping):
        try:
            return {int(k): str(v) for k, v in value.items()}
        except (TypeError, ValueError):
            return None
    if isinstance(value, (list, tuple)):
        return {i: str(v) for i, v in enumerate(value)}
    return None


# --------------------------------------------------------------------------------------------
# Results


@dataclass(frozen=True)
class Detections:
    """Boxes found in one image, sorted by decreasing score."""

    boxes: np.ndarray
    """``(N, 4)`` int64 ``[x_min, y_min, x_max, y_max]``, max exclusive, inside the image."""
    scores: np.ndarray
    """``(N,)`` float32 detector scores in [0, 1]."""
    class_ids: np.ndarray
    """``(N,)`` int64 class ids in the model's own numbering."""
    classes: tuple[str, ...]
    """Class name of each box, after ``DetectorConfig.aliases`` (e.g. ``"ball"``)."""
    input_scale: float | None = None
    """Model-input pixels per image pixel of the image searched (``Detector.input_scale``; None
    when not known): presence trusts the detector only for objects at least
    ``PresenceConfig.detector_min_input_side`` input pixels on their shorter side."""

    def __len__(self) -> int:
        return int(self.boxes.shape[0])

    def records(self) -> list[dict[str, Any]]:
        """Boxes-file records ``{"class", "id", "box", "score"}``; ``id`` is the rank in this image
        (a detector does not track, so it is not an identity across frames)."""
        return [
            {"class": c, "id": i, "box": [int(v) for v in b], "score": float(s)}
            for i, (c, b, s) in enumerate(zip(self.classes, self.boxes, self.scores, strict=True))
        ]


# --------------------------------------------------------------------------------------------
# The detector (state: the session and what was read from the model once)


def _static_dims(shape: list) -> list[int | None]:
    return [d if isinstance(d, int) and d > 0 else None for d in shape]


def _describe(infos: list) -> str:
    return ", ".join(f"{i.name} {i.shape} {i.type}" for i in infos)


class Detector:
    """An ONNX detector ready to run: session, convention, class names and selected class ids.

    Create once and call per image (``detector(image) -> Detections``). The session itself is
    cached per (file, providers), so two Detectors on the same file share it. Decoding the raw
    outputs is the convention's module (``DECODERS``); the Detector prepares and feeds the input.
    """

    def __init__(self, config: DetectorConfig | None = None) -> None:
        self.config = config or DetectorConfig()
        self.path = resolve_model_path(self.config.model)
        self.providers = onnx_providers(self.config.device)
        self.session = load_session(self.path, self.providers)
        inputs = self.session.get_inputs()
        if len(inputs) != 1:
            raise InputError(f"expected a detector with one image input, got {len(inputs)}: {_describe(inputs)}", path=self.path)
        self._input = inputs[0]
        if len(self._input.shape) not in (3, 4) or self._input.type not in ("tensor(float)", "tensor(uint8)"):
            raise InputError(
                f"detector input must be a float32 (or uint8) (3, H, W) or (1, 3, H, W) image, got {_describe(inputs)}",
                path=self.path,
            )
        self.outputs = self.session.get_outputs()
        self.convention = self._infer_convention()
        self._decoder = DECODERS[self.convention]
        self._scales: dict[tuple[int, int], float] = {}  # input_scale per image size
        self.output_roles, self.outputs_note = self._decoder.output_roles(self.outputs)
        """Graph output index of each role (``boxes``/``scores``/``labels``, or YOLO's
        ``output``), and the note saying the output names were overruled (else None)."""
        self.class_names = self._class_names()
        self.selected_ids = self._select_ids()
        self.class_thresholds = self._class_thresholds()

    # -- setup -----------------------------------------------------------------------------
    def _infer_convention(self) -> str:
        conv = self.config.convention
        fitting = [name for name, dec in DECODERS.items() if dec.fits(self.outputs)]
        if conv == "auto" and fitting:
            return fitting[0]
        if conv in fitting:
            return conv
        raise InputError(
            f"detector outputs fit neither convention{'' if conv == 'auto' else f' (asked for {conv!r})'}: "
            f"got [{_describe(self.outputs)}]; expected YOLO-style one output (1, 4+C, N) or "
            "torchvision-style boxes (N, 4), scores (N,), labels (N,)",
            path=self.path,
        )

    def _class_names(self) -> dict[int, str]:
        if self.config.class_names is not None:
            return dict(enumerate(self.config.class_names))
        meta = self.session.get_modelmeta().custom_metadata_map
        names = _parse_names(meta.get("names"))
        return names if names is not None else self._decoder.default_names(self.outputs)

    def _class_thresholds(self) -> dict[int, float]:
        """Class id -> the model's minimum score (``score_thresholds`` metadata, by class name;
        checked to be numbers in [0, 1]); empty when unused or absent."""
        if not self.config.model_thresholds:
            return {}
        raw = self.session.get_modelmeta().custom_metadata_map.get("score_thresholds")
        if not raw:
            return {}
        try:
            table = ast.literal_eval(raw)
            table = {self._canonical(str(k)): float(v) for k, v in dict(table).items()}
        except (ValueError, SyntaxError, TypeError) as err:
            raise InputError(f"the model's score_thresholds metadata is not a {{class: score}} "
                             f"mapping: {raw!r}", path=self.path) from err
        if not all(0.0 <= v <= 1.0 for v in table.values()):
            raise InputError(f"the model's score_thresholds must be in [0, 1]: {raw!r}", path=self.path)
        return {i: table[self._canonical(n)] for i, n in self.class_names.items()
                if self._canonical(n) in table}

    def _canonical(self, name: str) -> str:
        return dict(self.config.aliases).get(name, name)

    def _select_ids(self) -> tuple[int, ...]:
        ids: list[int] = []
        for want in self.config.classes:
            if isinstance(want, (int, np.integer)) and not isinstance(want, bool):
                ids.append(int(want))
                continue
            target = self._canonical(str(want))
            found = [i for i, n in self.class_names.items() if self._canonical(n) == target]
            if not found:
                raise InputError(
                    f"class {want!r} is not among the detector's classes ({self._known_names()}); "
                    "give a known name or an integer class id (CLI: --classes person,ball or "
                    "--classes 0,32), or set DetectorConfig.class_names",
                    path=self.path,
                )
            ids.extend(found)
        return tuple(sorted(set(ids)))

    def _known_names(self) -> str:
        known = sorted({n for n in self.class_names.values() if n not in ("N/A", "__background__")})
        if not known:
            return "unknown: the model has no 'names' metadata and is not a COCO model"
        return f"{', '.join(known[:20])}{', ...' if len(known) > 20 else ''}"

    @property
    def bundled(self) -> bool:
        """True for the packaged synthetic-scene detector (``DEFAULT_DETECTOR``)."""
        return self.path.resolve() == DEFAULT_DETECTOR.resolve()

    @property
    def selected_names(self) -> tuple[str, ...]:
        """Names of the selected classes as boxes files write them (after ``aliases``)."""
        names = (self._canonical(self.class_names.get(i, str(i))) for i in self.selected_ids)
        return tuple(dict.fromkeys(names))

    @functools.cached_property
    def sha256(self) -> str:
        """SHA-256 of the model file."""
        return file_sha256(self.path)

    def source(self) -> dict[str, Any]:
        """What made the boxes, for a boxes file's ``source`` and the results JSON."""
        import onnxruntime as ort

        settings = asdict(self.config)
        settings["model"] = str(self.path)
        fetched = provenance(self.path)
        return {
            **({"fetched": {k: fetched.get(k) for k in ("name", "source", "weights", "pretrained")}}
               if fetched else {}),
            "kind": "detector",
            "model": str(self.path),
            "model_sha256": self.sha256,
            "convention": self.convention,
            "class_ids": list(self.selected_ids),
            "outputs": self._roles_by_name(),
            **({"outputs_note": self.outputs_note} if self.outputs_note else {}),
            "class_score_thresholds": {self.class_names.get(i, str(i)): t for i, t in
                                       sorted(self.class_thresholds.items())
                                       if i in self.selected_ids},
            "settings": settings,
            "onnxruntime": ort.__version__,
        }

    def _roles_by_name(self) -> dict[str, str] | None:
        """Role -> graph output name (None when decided per run from the arrays)."""
        if self.output_roles is None:
            return None
        return {role: self.outputs[i].name for role, i in self.output_roles.items()}

    # -- running ---------------------------------------------------------------------------
    def _feed(self, chw: np.ndarray) -> dict[str, np.ndarray]:
        x = chw if len(self._input.shape) == 3 else chw[None]
        if self._input.type == "tensor(uint8)":
            x = np.clip(np.round(x * 255.0), 0, 255).astype(np.uint8)
        return {self._input.name: np.ascontiguousarray(x, dtype=x.dtype)}

    def _input_hw(self) -> tuple[int | None, int | None]:
        dims = _static_dims(self._input.shape)
        return dims[-2], dims[-1]

    def candidates(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
        """Decoded candidates in the model's *input* pixels (unclipped): float64 ``(N, 4)`` xyxy
        boxes, ``(N,)`` scores, ``(N,)`` int64 class ids, and the geometry that maps them to the
        image (``to_image``). ``image``: (H, W, 3) RGB, or grayscale (H, W) / (H, W, 1), fed as
        grey replicated to RGB."""
        img = np.ascontiguousarray(as_image(_grey_to_rgb(image), "detector input",
                                            check_range=True, channels=3))
        fed, geometry = self._decoder.prepare(img, self._input_hw(), self.config.input_size)
        outs = [np.asarray(o) for o in self.session.run(None, self._feed(fed.transpose(2, 0, 1)))]
        boxes, scores, cls = self._decoder.decode(outs, self.output_roles, self.path)
        self._check_class_count(self._decoder.n_classes(outs))
        return boxes, scores, cls, geometry

    def to_image(self, boxes: np.ndarray, geometry: Any) -> np.ndarray:
        """``(N, 4)`` boxes from the model's input pixels to the image's (unclipped)."""
        return self._decoder.to_image(boxes, geometry)

    def input_scale(self, hw: tuple[int, int]) -> float:
        """Model-input pixels per image pixel for an image of ``hw = (H, W)`` (letterboxed:
        the input side over the longer image side for a square YOLO input)."""
        h, w = int(hw[0]), int(hw[1])
        if (h, w) not in self._scales:
            _, geometry = self._decoder.prepare(np.zeros((h, w, 3), np.uint8), self._input_hw(),
                                                self.config.input_size)
            self._scales[(h, w)] = self._scale_of(geometry)
        return self._scales[(h, w)]

    def _scale_of(self, geometry: Any) -> float:
        """Model-input pixels per image pixel of the mapping ``geometry`` (``to_image``'s)."""
        box = self.to_image(np.array([[0.0, 0.0, 100.0, 100.0]]), geometry)
        return 100.0 / float(box[0, 2] - box[0, 0])

    def raw(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Decoded candidates before filtering: float64 ``(N, 4)`` xyxy boxes in *original image*
        pixels (unclipped), ``(N,)`` scores and ``(N,)`` int64 class ids (see ``candidates``)."""
        boxes, scores, cls, geometry = self.candidates(image)
        return self.to_image(boxes, geometry), scores, cls

    def _check_class_count(self, n_cls: int | None) -> None:
        if n_cls is not None and max(self.selected_ids) >= n_cls:
            raise InputError(
                f"the model predicts {n_cls} classes (ids 0..{n_cls - 1}) but class ids "
                f"{[i for i in self.selected_ids if i >= n_cls]} were selected (names list has "
                f"{len(self.class_names)} entries); set DetectorConfig.class_names or select "
                "classes by integer id",
                path=self.path,
            )

    def __call__(self, image: np.ndarray) -> Detections:
        """Detect in one ``(H, W, 3)`` RGB image (uint8 or float in [0, 1])."""
        h, w = np.asarray(image).shape[:2]
        boxes, scores, cls, geometry = self.candidates(image)
        found = postprocess(boxes, scores, cls, self.config, self.selected_ids, self.class_names,
                            h, w, to_image=lambda b: self.to_image(b, geometry))
        return replace(with_class_thresholds(found, self.class_thresholds),
                       input_scale=self._scale_of(geometry))


def _grey_to_rgb(image: object) -> object:
    """A grayscale numpy image ``(H, W)`` or ``(H, W, 1)`` as ``(H, W, 3)`` (the grey in each
    channel: what an RGB detector sees of a grey photo); anything else unchanged."""
    if isinstance(image, np.ndarray) and image.size and (
            image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 1)):
        return grey_to_rgb(image, "image", "the detector")
    return image


def postprocess(
    boxes: np.ndarray,
    scores: np.ndarray,
    class_ids: np.ndarray,
    config: DetectorConfig,
    selected_ids: Iterable[int],
    class_names: Mapping[int, str],
    height: int,
    width: int,
    to_image: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Detections:
    """Class filter, score > threshold, per-class NMS on the unclipped boxes, top-k, mapping to
    the image, clip, outward rounding (the order of Ultralytics' ``non_max_suppression`` and
    ``scale_boxes``: boxes that overlap only once clipped to the image are both kept).

    ``boxes``: ``(N, 4)`` float xyxy in the model's input pixels, ``to_image`` maps them to image
    pixels (None: they already are); ``scores``: ``(N,)``; ``class_ids``: ``(N,)``. At most
    ``MAX_NMS`` candidates (highest scores) enter NMS. Boxes empty after clipping and rounding are
    dropped (after top-k, so fewer than ``max_detections`` may remain).
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    class_ids = np.asarray(class_ids, dtype=np.int64).reshape(-1)
    keep = (
        np.isin(class_ids, np.asarray(list(selected_ids), dtype=np.int64))
        & (scores > config.score_threshold)
        & np.all(np.isfinite(boxes), axis=1)
        & np.isfinite(scores)
    )
    boxes, scores, class_ids = boxes[keep], scores[keep], class_ids[keep]
    if len(scores) > MAX_NMS:
        top = np.argsort(-scores, kind="stable")[:MAX_NMS]
        boxes, scores, class_ids = boxes[top], scores[top], class_ids[top]
    order = batched_nms(boxes, scores, class_ids, config.nms_iou)[: config.max_detections]
    boxes, scores, class_ids = boxes[order], scores[order], class_ids[order]
    if to_image is not None:
        boxes = np.asarray(to_image(boxes), dtype=np.float64).reshape(-1, 4)
    boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, width)
    boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, height)
    eps = 1e-6  # coordinates within 1e-6 px of an integer are that integer (no 1-px growth)
    ib = np.concatenate([np.floor(boxes[:, :2] + eps), np.ceil(boxes[:, 2:] - eps)], axis=1).astype(np.int64)
    ok = (ib[:, 2] > ib[:, 0]) & (ib[:, 3] > ib[:, 1])
    alias = dict(config.aliases)
    names = tuple(alias.get(n, n) for n in (class_names.get(int(c), str(int(c))) for c in class_ids[ok]))
    return Detections(ib[ok], scores[ok].astype(np.float32), class_ids[ok], names)


def with_class_thresholds(found: Detections, thresholds: Mapping[int, float]) -> Detections:
    """``found`` without the boxes not scoring above their class's minimum in ``thresholds``
    (class id -> score). After per-class NMS this equals filtering before it (up to the
    ``max_detections`` cap): a box is suppressed only by a higher-scored box of its class, which
    passes that class's threshold too."""
    if not thresholds or not len(found):
        return found
    mins = np.array([thresholds.get(int(c), 0.0) for c in found.class_ids], dtype=np.float64)
    keep = found.scores.astype(np.float64) > mins  # above, as score_threshold
    if keep.all():
        return found
    return Detections(found.boxes[keep], found.scores[keep], found.class_ids[keep],
                      tuple(c for c, k in zip(found.classes, keep, strict=True) if k))


def detect(image: np.ndarray, detector: Detector | DetectorConfig | None = None) -> Detections:
    """Boxes of the selected classes in one ``(H, W, 3)`` RGB image (uint8 or float in [0, 1]).

    ``detector``: a ``Detector`` (fastest when called per frame), a ``DetectorConfig`` (a Detector
    is built; its session is cached) or None (the packaged default detector).
    """
    det = detector if isinstance(detector, Detector) else Detector(detector)
    return det(image)


def iter_detect(
    frames: Iterable[tuple[str, np.ndarray]], detector: Detector | DetectorConfig | None = None
) -> Iterator[tuple[str, list[dict[str, Any]]]]:
    """Yield ``(key, records)`` for ``(key, image)`` pairs, one at a time (wrap in a progress bar).

    ``key`` is the boxes-file key ``"<camera>/<frame>"``; records as ``Detections.records``.
    """
    det = detector if isinstance(detector, Detector) else Detector(detector)
    for key, image in frames:
        yield key, det(image).records()


def detect_folder(
    frames: Iterable[tuple[str, np.ndarray]], config: Detector | DetectorConfig | None = None
) -> tuple[dict[str, list[dict[str, Any]]], dict[str, Any]]:
    """Run the detector over ``(key, image)`` pairs; return ``(boxes mapping, source)``.

    The mapping is ready for ``write_boxes_file(path, mapping, source)``; ``source`` records the
    model file, its SHA-256 and every setting. Boxes are raw detections (not expanded): expansion
    is applied when scoring, to boxes from any source.
    """
    det = config if isinstance(config, Detector) else Detector(config)
    return dict(iter_detect(frames, det)), det.source()


SYNTHETIC_DETECTOR = (
    "the boxes come from the bundled synthetic-scene detector (dynaeval/models/detector.onnx, "
    "trained on renders of dynaeval's procedural soccer scenes): it is not for real footage, "
    "where it finds 'persons' and 'balls' in anything. For real footage fetch a COCO detector "
    "(dynaeval detector fetch retinanet, then --detector retinanet) or score with --focus motion")
"""The one warning of a run whose boxes come from the bundled detector."""


def detector_warnings(detector: Detector) -> list[dict]:
    """Run-level warnings about an opened ``Detector``: the bundled synthetic-scene one, output
    names overruled by the dtypes (each once per run)."""
    out = []
    if detector.bundled:
        out.append(note(SYNTHETIC_DETECTOR))
    if detector.outputs_note:
        out.append(note(f"detector {detector.path}: {detector.outputs_note}"))
    return out

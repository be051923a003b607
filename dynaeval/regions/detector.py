"""Boxes from any object detector exported to ONNX, run through onnxruntime.

Two output conventions are decoded (``DetectorConfig.convention``; ``"auto"`` tells them apart
from the graph's outputs):

* **YOLO-style** (Ultralytics YOLOv8/11 exports): one input ``(1, 3, S, S)`` float32 RGB in [0, 1],
  the image *letterboxed* into it (aspect kept, centred, padded with grey 114/255); one output
  ``(1, 4 + C, N)``: per candidate ``cx, cy, w, h`` in input pixels, then ``C`` class scores. A
  candidate's class is the arg-max over all ``C`` scores (as Ultralytics does), its score that
  maximum. Coordinates are mapped back through the letterbox to the original image.
* **torchvision-style** (``torchvision.models.detection`` RetinaNet / Faster R-CNN / FCOS exports):
  one image input, float32 RGB in [0, 1], either ``(3, H, W)`` (the plain export of a model called
  on a list of images) or ``(1, 3, H, W)`` (a batch wrapper); the model resizes internally, so the
  image is fed at its own size unless the graph fixes ``H, W`` (then it is resized and boxes scaled
  back). Outputs ``boxes (N, 4)`` x_min, y_min, x_max, y_max in input pixels, ``scores (N,)``,
  ``labels (N,)`` int (each optionally with a leading batch dimension of 1). Outputs are matched by
  name (containing ``box``, ``score``, ``label``/``class``) or else by dtype and shape.

Class names come from ``DetectorConfig.class_names``, else the model's ``names`` metadata (what
Ultralytics writes, e.g. ``"{0: 'person', ...}"``), else COCO (80 names for YOLO, torchvision's
91-index list). Then: class filter, score threshold, per-class NMS, clip to the image, and integer
boxes rounded outwards (floor the min, ceil the max; max exclusive, see ``boxes.py``).

Images given to ``detect`` are ``(H, W, 3)`` **RGB**, uint8 in [0, 255] or float in [0, 1].
"""

from __future__ import annotations

import ast
import functools
import json
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.boxes import batched_nms, box_iou_matrix, nms  # noqa: F401  (box_iou_matrix, nms: old import path)
from dynaeval.errors import InputError
from dynaeval.runtime import file_sha256, load_session, onnx_providers
from dynaeval.validation import as_image

# torchvision's COCO category list (91 indices, "N/A" for ids unused by COCO 2017); checked against
# torchvision.models.detection weights' meta["categories"] in the tests.
COCO91_NAMES: tuple[str, ...] = (
    "__background__", "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train",
    "truck", "boat", "traffic light", "fire hydrant", "N/A", "stop sign", "parking meter", "bench",
    "bird", "cat", "dog", "horse", "sheep", "cow", "elephant", "bear", "zebra", "giraffe", "N/A",
    "backpack", "umbrella", "N/A", "N/A", "handbag", "tie", "suitcase", "frisbee", "skis",
    "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard",
    "tennis racket", "bottle", "N/A", "wine glass", "cup", "fork", "knife", "spoon", "bowl",
    "banana", "apple", "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", "donut",
    "cake", "chair", "couch", "potted plant", "bed", "N/A", "dining table", "N/A", "N/A", "toilet",
    "N/A", "tv", "laptop", "mouse", "remote", "keyboard", "cell phone", "microwave", "oven",
    "toaster", "sink", "refrigerator", "N/A", "book", "clock", "vase", "scissors", "teddy bear",
    "hair drier", "toothbrush",
)  # fmt: skip
"""torchvision detection label index -> COCO name (index 1 is ``person``, 37 ``sports ball``)."""

COCO80_NAMES: tuple[str, ...] = tuple(n for n in COCO91_NAMES if n not in ("__background__", "N/A"))
"""YOLO's contiguous 80-class COCO list (index 0 is ``person``, 32 ``sports ball``)."""

DEFAULT_DETECTOR = Path(__file__).resolve().parents[1] / "models" / "detector.onnx"
"""Where the packaged default detector (person + ball, trained on the synthetic scenes) lives."""

CONVENTIONS = ("auto", "yolo", "torchvision")


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
    """Detections with score below this (in [0, 1]) are dropped."""
    nms_iou: float = 0.45
    """Per-class NMS: a box whose IoU with a higher-scored box of its class exceeds this is dropped."""
    input_size: int | None = None
    """YOLO letterbox side in px when the graph's input size is dynamic (None: 640). Torchvision:
    None feeds the image at its own size; an int resizes the longer side to it."""
    max_detections: int = 300
    """At most this many boxes per image (highest scores first)."""
    device: str = "cpu"
    """``"cpu"``, ``"cuda"`` (error if onnxruntime has no CUDA provider) or ``"auto"``."""

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
    """The detector file to load; InputError when it does not exist."""
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
    if not path.is_file():
        raise InputError("detector model not found: expected an .onnx file", path=path)
    return path


# --------------------------------------------------------------------------------------------
# Pure helpers: image checks, letterbox, NMS


def letterbox(image: np.ndarray, size_hw: tuple[int, int], pad_value: float = 114 / 255):
    """Resize keeping the aspect ratio and pad (centred) to ``size_hw``, as YOLO expects.

    ``image``: ``(H, W, 3)`` float32 in [0, 1]. Returns ``(canvas, scale_xy, offset_xy)`` where
    ``canvas`` is ``(th, tw, 3)`` float32, and a point ``(x, y)`` of the original image lands at
    ``(x * scale_x + off_x, y * scale_y + off_y)`` on the canvas (both scales equal the resize
    factor up to rounding of the resized size).
    """
    import cv2

    h, w = image.shape[:2]
    th, tw = size_hw
    r = min(th / h, tw / w)
    nh, nw = max(1, int(round(h * r))), max(1, int(round(w * r)))
    resized = image if (nh, nw) == (h, w) else cv2.resize(image, (nw, nh), interpolation=cv2.INTER_LINEAR)
    top, left = (th - nh) // 2, (tw - nw) // 2
    canvas = np.full((th, tw, 3), pad_value, dtype=np.float32)
    canvas[top : top + nh, left : left + nw] = resized
    return canvas, (nw / w, nh / h), (left, top)


def _parse_names(raw: str | None) -> dict[int, str] | None:
    """Class names from ONNX metadata: a dict ``{id: name}`` or a list, as Python or JSON text."""
    if not raw:
        return None
    try:
        value = ast.literal_eval(raw)
    except (ValueError, SyntaxError):
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
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
    cached per (file, providers), so two Detectors on the same file share it.
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
        self.class_names = self._class_names()
        self.selected_ids = self._select_ids()

    # -- setup -----------------------------------------------------------------------------
    def _infer_convention(self) -> str:
        conv = self.config.convention
        n = len(self.outputs)
        looks_yolo = n == 1 and len(self.outputs[0].shape) == 3
        looks_tv = n >= 3
        if conv == "auto":
            if looks_yolo:
                return "yolo"
            if looks_tv:
                return "torchvision"
        elif (conv == "yolo" and looks_yolo) or (conv == "torchvision" and looks_tv):
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
        if names is not None:
            return names
        if self.convention == "yolo":
            rows = self.outputs[0].shape[1]
            if isinstance(rows, int) and rows - 4 != len(COCO80_NAMES):
                return {}  # not a COCO model and no names: only integer class ids can select
            return dict(enumerate(COCO80_NAMES))
        return dict(enumerate(COCO91_NAMES))

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
                known = sorted({n for n in self.class_names.values() if n not in ("N/A", "__background__")})
                listed = (
                    f"{', '.join(known[:20])}{', ...' if len(known) > 20 else ''}"
                    if known
                    else "unknown: the model has no 'names' metadata and is not a COCO model"
                )
                raise InputError(
                    f"class {want!r} is not among the detector's classes ({listed}); give a known "
                    "name, an integer class id, or DetectorConfig.class_names",
                    path=self.path,
                )
            ids.extend(found)
        return tuple(sorted(set(ids)))

    @functools.cached_property
    def sha256(self) -> str:
        """SHA-256 of the model file."""
        return file_sha256(self.path)

    def source(self) -> dict[str, Any]:
        """What made the boxes, for a boxes file's ``source`` and the results JSON."""
        import onnxruntime as ort

        settings = asdict(self.config)
        settings["model"] = str(self.path)
        return {
            "kind": "detector",
            "model": str(self.path),
            "model_sha256": self.sha256,
            "convention": self.convention,
            "class_ids": list(self.selected_ids),
            "settings": settings,
            "onnxruntime": ort.__version__,
        }

    # -- running ---------------------------------------------------------------------------
    def _feed(self, chw: np.ndarray) -> dict[str, np.ndarray]:
        x = chw if len(self._input.shape) == 3 else chw[None]
        if self._input.type == "tensor(uint8)":
            x = np.clip(np.round(x * 255.0), 0, 255).astype(np.uint8)
        return {self._input.name: np.ascontiguousarray(x, dtype=x.dtype)}

    def _input_hw(self) -> tuple[int | None, int | None]:
        dims = _static_dims(self._input.shape)
        return dims[-2], dims[-1]

    def raw(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Decoded candidates before filtering: float64 ``(N, 4)`` xyxy boxes in *original image*
        pixels (unclipped), ``(N,)`` scores and ``(N,)`` int64 class ids."""
        img = np.ascontiguousarray(as_image(image, "detector input", check_range=True, channels=3))
        if self.convention == "yolo":
            return self._raw_yolo(img)
        return self._raw_torchvision(img)

    def _raw_yolo(self, img: np.ndarray):
        th, tw = self._input_hw()
        side = self.config.input_size or 640
        canvas, (sx, sy), (ox, oy) = letterbox(img, (th or side, tw or side))
        (out,) = self.session.run(None, self._feed(canvas.transpose(2, 0, 1)))
        out = np.asarray(out)
        if out.ndim != 3 or out.shape[0] != 1 or out.shape[1] <= 4:
            raise InputError(f"YOLO-style output must be (1, 4+C, N), got {out.shape}", path=self.path)
        n_cls = out.shape[1] - 4
        if max(self.selected_ids) >= n_cls:
            raise InputError(
                f"the model predicts {n_cls} classes (ids 0..{n_cls - 1}) but class ids "
                f"{[i for i in self.selected_ids if i >= n_cls]} were selected (names list has "
                f"{len(self.class_names)} entries); set DetectorConfig.class_names or select "
                "classes by integer id",
                path=self.path,
            )
        pred = out[0].T.astype(np.float64)  # (N, 4 + C)
        cx, cy, w, h = pred[:, 0], pred[:, 1], pred[:, 2], pred[:, 3]
        boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
        boxes[:, [0, 2]] = (boxes[:, [0, 2]] - ox) / sx
        boxes[:, [1, 3]] = (boxes[:, [1, 3]] - oy) / sy
        cls = np.argmax(pred[:, 4:], axis=1).astype(np.int64)
        scores = pred[np.arange(pred.shape[0]), 4 + cls]
        return boxes, scores, cls

    def _raw_torchvision(self, img: np.ndarray):
        import cv2

        h, w = img.shape[:2]
        th, tw = self._input_hw()
        if th is not None and tw is not None:
            size = (th, tw)
        elif self.config.input_size is not None:
            r = self.config.input_size / max(h, w)
            size = (max(1, int(round(h * r))), max(1, int(round(w * r))))
        else:
            size = (h, w)
        x = img if size == (h, w) else cv2.resize(img, (size[1], size[0]), interpolation=cv2.INTER_LINEAR)
        outs = [np.asarray(o) for o in self.session.run(None, self._feed(x.transpose(2, 0, 1)))]
        boxes, scores, labels = self._match_torchvision(outs)
        boxes = boxes.astype(np.float64)
        boxes[:, [0, 2]] *= w / size[1]
        boxes[:, [1, 3]] *= h / size[0]
        return boxes, scores.astype(np.float64), labels

    def _roles_by_name(self) -> dict[str, int] | None:
        names = [o.name.lower() for o in self.outputs]
        roles: dict[str, int] = {}
        for role, keys in (("boxes", ("box",)), ("scores", ("score",)), ("labels", ("label", "class"))):
            hits = [i for i, n in enumerate(names) if any(k in n for k in keys)]
            if len(hits) == 1:
                roles[role] = hits[0]
        return roles if len(set(roles.values())) == 3 else None

    @staticmethod
    def _roles_by_type(outs: list[np.ndarray]) -> dict[str, int] | None:
        ints = [i for i, a in enumerate(outs) if np.issubdtype(a.dtype, np.integer)]
        floats = [i for i, a in enumerate(outs) if np.issubdtype(a.dtype, np.floating)]
        if len(ints) != 1 or len(floats) != 2:
            return None
        n = outs[ints[0]].size
        is_boxes = [outs[i].size == 4 * n and outs[i].shape[-1:] == (4,) for i in floats]
        if is_boxes[0] == is_boxes[1]:
            return None
        b, s = (floats[0], floats[1]) if is_boxes[0] else (floats[1], floats[0])
        return {"boxes": b, "scores": s, "labels": ints[0]} if outs[s].size == n else None

    def _match_torchvision(self, outs: list[np.ndarray]):
        def squeeze(a: np.ndarray, ndim: int) -> np.ndarray:
            return a[0] if a.ndim == ndim + 1 and a.shape[0] == 1 else a

        roles = self._roles_by_name() or self._roles_by_type(outs)
        if roles is None:
            got = ", ".join(f"{o.name} {a.shape} {a.dtype}" for o, a in zip(self.outputs, outs, strict=True))
            raise InputError(
                f"cannot find torchvision-style outputs boxes (N, 4) float, scores (N,) float, "
                f"labels (N,) int among [{got}]",
                path=self.path,
            )
        boxes = squeeze(outs[roles["boxes"]], 2)
        scores = squeeze(outs[roles["scores"]], 1)
        labels = squeeze(outs[roles["labels"]], 1)
        n = boxes.shape[0] if boxes.ndim == 2 else -1
        if boxes.shape != (n, 4) or scores.shape != (n,) or labels.shape != (n,):
            raise InputError(
                f"torchvision-style outputs disagree: boxes {boxes.shape}, scores {scores.shape}, "
                f"labels {labels.shape}; expected (N, 4), (N,), (N,)",
                path=self.path,
            )
        if not np.issubdtype(labels.dtype, np.integer) and not np.all(labels == np.round(labels)):
            raise InputError("torchvision-style labels must be integer class ids", path=self.path)
        return boxes, scores, labels.astype(np.int64)

    def __call__(self, image: np.ndarray) -> Detections:
        """Detect in one ``(H, W, 3)`` RGB image (uint8 or float in [0, 1])."""
        h, w = np.asarray(image).shape[:2]
        boxes, scores, cls = self.raw(image)
        return postprocess(boxes, scores, cls, self.config, self.selected_ids, self.class_names, h, w)


def postprocess(
    boxes: np.ndarray,
    scores: np.ndarray,
    class_ids: np.ndarray,
    config: DetectorConfig,
    selected_ids: Iterable[int],
    class_names: Mapping[int, str],
    height: int,
    width: int,
) -> Detections:
    """Class filter, score threshold, clip to the image, per-class NMS, top-k, outward rounding.

    ``boxes``: ``(N, 4)`` float xyxy in image pixels; ``scores``: ``(N,)``; ``class_ids``: ``(N,)``.
    Boxes empty after clipping are dropped.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    class_ids = np.asarray(class_ids, dtype=np.int64).reshape(-1)
    keep = (
        np.isin(class_ids, np.asarray(list(selected_ids), dtype=np.int64))
        & (scores >= config.score_threshold)
        & np.all(np.isfinite(boxes), axis=1)
        & np.isfinite(scores)
    )
    boxes, scores, class_ids = boxes[keep], scores[keep], class_ids[keep]
    boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, width)
    boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, height)
    order = batched_nms(boxes, scores, class_ids, config.nms_iou)[: config.max_detections]
    boxes, scores, class_ids = boxes[order], scores[order], class_ids[order]
    eps = 1e-6  # coordinates within 1e-6 px of an integer are that integer (no 1-px growth)
    ib = np.concatenate([np.floor(boxes[:, :2] + eps), np.ceil(boxes[:, 2:] - eps)], axis=1).astype(np.int64)
    ok = (ib[:, 2] > ib[:, 0]) & (ib[:, 3] > ib[:, 1])
    alias = dict(config.aliases)
    names = tuple(alias.get(n, n) for n in (class_names.get(int(c), str(int(c))) for c in class_ids[ok]))
    return Detections(ib[ok], scores[ok].astype(np.float32), class_ids[ok], names)


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

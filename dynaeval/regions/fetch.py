"""COCO detectors in one command: ``dynaeval detector fetch NAME`` downloads a detector's weights
with its library's own loader, exports it to ONNX in the convention ``dynaeval.regions.detector``
reads, and stores it in the user cache with its provenance; ``--detector NAME`` then finds it.

Known names (``KNOWN``): ``retinanet`` (torchvision ``retinanet_resnet50_fpn_v2``, the seed
study's detector), ``fasterrcnn-mobilenet`` (torchvision ``fasterrcnn_mobilenet_v3_large_fpn``,
small and fast), ``yolov8n`` and ``yolo11n`` (Ultralytics, when the ``ultralytics`` package is
installed). The cache folder is ``$DYNAEVAL_DETECTORS``, else ``$XDG_CACHE_HOME/dynaeval/detectors``,
else ``~/.cache/dynaeval/detectors``; each detector is ``NAME.onnx`` with ``NAME.json`` beside it
(source, weights name, URL and SHA-256, export settings, opset, class names, versions, date).

torch, torchvision and ultralytics are imported only inside the functions that export: resolving a
name (what scoring does) reads two files.
"""

from __future__ import annotations

import datetime
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dynaeval.core.deps import DEPENDENCIES, MissingDependency, load
from dynaeval.core.errors import InputError
from dynaeval.core.runtime import file_sha256
from dynaeval.core.version import VERSION
from dynaeval.io.atomic import write_text_atomic
from dynaeval.regions.coco import COCO80_NAMES, COCO91_NAMES

CACHE_ENV = "DYNAEVAL_DETECTORS"
"""Environment variable that overrides the cache folder of fetched detectors."""
OPSET = 17
"""ONNX opset of every export (the legacy TorchScript exporter's tested range; Ultralytics' too)."""
EXPORT_HW = (720, 1280)
"""Size (H, W) of the dummy image a torchvision model is traced with; the graph's image size is
dynamic, so any frame size runs."""
YOLO_RELEASE = "https://github.com/ultralytics/assets/releases/download/v8.4.0"
"""Where Ultralytics' own loader downloads ``NAME.pt`` from (named in the offline message)."""
ULTRALYTICS_INSTALL = DEPENDENCIES["ultralytics"].install
"""The install line of the YOLO names (``dynaeval.core.deps``: not a plain ``pip install
ultralytics``, which breaks OpenCV)."""
TORCHVISION_INSTALL = "pip install torch torchvision onnx"
"""The install line of the torchvision names (onnx writes the class names into the export)."""


@dataclass(frozen=True)
class KnownDetector:
    """A detector ``fetch`` can build, export and store."""

    name: str
    """The name given to ``dynaeval detector fetch`` and ``--detector``."""
    library: str
    """``torchvision`` or ``ultralytics``: who builds it and downloads its weights."""
    builder: str
    """torchvision: the ``torchvision.models.detection`` function; ultralytics: the ``.pt`` name."""
    weights: str | None
    """torchvision: the weights enum member (``RetinaNet_ResNet50_FPN_V2_Weights.COCO_V1``)."""
    description: str
    """One line for ``dynaeval detector list``."""
    kwargs: dict[str, Any] = field(default_factory=dict)
    """Extra arguments of the builder (none for the shipped names)."""


KNOWN: dict[str, KnownDetector] = {d.name: d for d in (
    KnownDetector("retinanet", "torchvision", "retinanet_resnet50_fpn_v2",
                  "RetinaNet_ResNet50_FPN_V2_Weights.COCO_V1",
                  "torchvision RetinaNet ResNet-50 FPN v2, COCO (the seed study's detector)"),
    KnownDetector("fasterrcnn-mobilenet", "torchvision", "fasterrcnn_mobilenet_v3_large_fpn",
                  "FasterRCNN_MobileNet_V3_Large_FPN_Weights.COCO_V1",
                  "torchvision Faster R-CNN MobileNet-v3 large FPN, COCO (small, fast)"),
    KnownDetector("yolov8n", "ultralytics", "yolov8n.pt", None,
                  f"Ultralytics YOLOv8n, COCO (needs: {ULTRALYTICS_INSTALL})"),
    KnownDetector("yolo11n", "ultralytics", "yolo11n.pt", None,
                  f"Ultralytics YOLO11n, COCO (needs: {ULTRALYTICS_INSTALL})"),
)}
"""Name -> what ``fetch`` builds."""


def cache_dir() -> Path:
    """Folder of fetched detectors: ``$DYNAEVAL_DETECTORS``, else ``$XDG_CACHE_HOME/dynaeval/
    detectors``, else ``~/.cache/dynaeval/detectors`` (not created here)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "dynaeval" / "detectors"


def fetched_path(name: str, folder: Path | None = None) -> Path | None:
    """``NAME.onnx`` in the cache when it is there (with its provenance JSON), else None."""
    folder = cache_dir() if folder is None else folder
    onnx, meta = folder / f"{name}.onnx", folder / f"{name}.json"
    return onnx if onnx.is_file() and meta.is_file() else None


def provenance(model: str | Path) -> dict[str, Any] | None:
    """The provenance JSON beside a fetched ``NAME.onnx`` (None for any other model file)."""
    meta = Path(model).with_suffix(".json")
    if not meta.is_file():
        return None
    try:
        doc = json.loads(meta.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return doc if isinstance(doc, dict) and doc.get("schema") == "dynaeval/detector/v1" else None


def resolve_name(model: str) -> Path:
    """The ``.onnx`` file of a fetched detector ``model`` (a ``KNOWN`` name, or any ``NAME`` with
    ``NAME.onnx`` in the cache).

    Raises:
        InputError: a known name not fetched yet (says the command), or an unknown name.
    """
    path = fetched_path(model)
    if path is not None:
        return path
    if model in KNOWN:
        raise InputError(
            f"detector {model!r} is not fetched yet: run 'dynaeval detector fetch {model}' (needs "
            f"network once; it writes {cache_dir() / (model + '.onnx')}, override the folder with "
            f"${CACHE_ENV}), or pass --detector FILE.onnx")
    raise InputError(
        f"detector model not found: {model!r} is neither an .onnx file nor a fetched detector "
        f"(known names: {', '.join(KNOWN)}; 'dynaeval detector list' shows what is fetched)",
        path=model if model.endswith(".onnx") else None)


def list_detectors(folder: Path | None = None) -> list[dict[str, Any]]:
    """One row per known or fetched detector: ``name``, ``fetched`` (bool), ``path`` (or None),
    ``description``, and for fetched ones ``weights`` and ``date`` from the provenance."""
    folder = cache_dir() if folder is None else folder
    names = list(KNOWN)
    if folder.is_dir():
        names += sorted(p.stem for p in folder.glob("*.onnx")
                        if p.stem not in KNOWN and not p.name.startswith("."))  # not a temp file
    rows = []
    for name in names:
        path = fetched_path(name, folder)
        prov = provenance(path) if path else None
        rows.append({
            "name": name, "fetched": path is not None, "path": str(path) if path else None,
            "description": KNOWN[name].description if name in KNOWN else "fetched detector",
            "weights": (prov or {}).get("weights", {}).get("name"),
            "date": (prov or {}).get("date"),
        })
    return rows


# --------------------------------------------------------------------------------------------
# Fetching (torch / torchvision / ultralytics imported here only)


def fetch(name: str, *, folder: Path | None = None, overwrite: bool = False,
          pretrained: bool = True, builder_kwargs: dict[str, Any] | None = None,
          model_hook: Callable[[Any], None] | None = None) -> Path:
    """Download ``name``'s weights (the library's own loader), export to ONNX, store it in
    ``folder`` (default ``cache_dir()``) as ``NAME.onnx`` + ``NAME.json``; return the ``.onnx``.

    Args:
        name: a ``KNOWN`` name.
        folder: where to store (created when missing).
        overwrite: replace a fetched copy (else InputError when it exists).
        pretrained: False builds the same architecture with random weights and downloads
            nothing (tests, benchmarks); the provenance says so.
        builder_kwargs: extra arguments of the torchvision builder (e.g. ``box_score_thresh``).
        model_hook: called on the built torch model (torchvision's, or Ultralytics'
            ``YOLO.model``) before the export (tests: a random-weight model's batch norm is
            recalibrated so that its boxes differ in score).

    Raises:
        InputError: unknown name; torch/torchvision/ultralytics missing (says what to install);
            the download failed (says which file to put where); already fetched.
    """
    if name not in KNOWN:
        raise InputError(f"unknown detector {name!r}: known names are {', '.join(KNOWN)}")
    spec = KNOWN[name]
    folder = cache_dir() if folder is None else Path(folder)
    onnx, meta = folder / f"{name}.onnx", folder / f"{name}.json"
    if (onnx.exists() or meta.exists()) and not overwrite:
        raise InputError(f"detector {name!r} is already fetched; pass --overwrite to fetch it "
                         "again", path=onnx)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"cannot create the detector cache folder ({err}); set ${CACHE_ENV}",
                         path=folder) from err
    tmp = folder / f".{name}.{os.getpid()}.onnx"
    try:
        if spec.library == "torchvision":
            record = _export_torchvision(spec, tmp, pretrained, dict(builder_kwargs or {}),
                                         model_hook)
        else:
            record = _export_ultralytics(spec, tmp, folder, pretrained, model_hook)
        record.update(_common_record(spec, tmp, pretrained))
        os.replace(tmp, onnx)
    finally:
        tmp.unlink(missing_ok=True)

    write_text_atomic(meta, json.dumps(record, indent=2) + "\n", overwrite=True,
                      what="detector provenance")
    return onnx


def _common_record(spec: KnownDetector, onnx: Path, pretrained: bool) -> dict[str, Any]:
    return {
        "schema": "dynaeval/detector/v1", "name": spec.name, "pretrained": pretrained,
        "onnx_sha256": file_sha256(onnx), "dynaeval": VERSION,
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


def _import(names: str, what: str):  # noqa: ANN202
    """Import torch + torchvision (or ultralytics, or onnx), or InputError saying what to install."""
    try:
        return [load(n) for n in names.split()]
    except MissingDependency as err:
        raise _missing(err, what, ULTRALYTICS_INSTALL if "ultralytics" in names
                       else TORCHVISION_INSTALL) from err


def _missing(err: ImportError, what: str, install: str) -> InputError:
    return InputError(f"fetching {what} needs the {err.name} package: {install} (dynaeval only "
                      "needs it to fetch; scoring runs the ONNX file)")


def torchvision_model(spec: KnownDetector, pretrained: bool, **kwargs: Any):  # noqa: ANN201
    """``spec``'s torchvision model in eval mode and its weights enum member (None when not
    ``pretrained``: random weights, random backbone, nothing downloaded)."""
    torch, tvd = _import("torch torchvision.models.detection", spec.name)
    enum_name, member = spec.weights.split(".")
    weights = getattr(getattr(tvd, enum_name), member)
    if pretrained:
        _check_checkpoint(spec, weights, torch)
        kwargs = {"weights": weights, **spec.kwargs, **kwargs}
    else:
        kwargs = {"weights": None, "weights_backbone": None, **spec.kwargs, **kwargs}
    return getattr(tvd, spec.builder)(**kwargs).eval(), (weights if pretrained else None)


def _checkpoint_file(weights, torch) -> Path:  # noqa: ANN001
    return Path(torch.hub.get_dir()) / "checkpoints" / weights.url.rsplit("/", 1)[-1]


def _check_checkpoint(spec: KnownDetector, weights, torch) -> None:  # noqa: ANN001
    """Download the checkpoint with torch's own loader, or InputError saying where to put it."""
    path = _checkpoint_file(weights, torch)
    if path.is_file():
        return
    try:
        torch.hub.load_state_dict_from_url(weights.url, progress=True, check_hash=True)
    except Exception as err:  # URLError, timeouts, HTTP errors, a bad hash: all say the same
        raise InputError(
            f"could not download the weights of {spec.name!r} ({type(err).__name__}: {err}). "
            f"On a machine with network run 'dynaeval detector fetch {spec.name}' there, or "
            f"download {weights.url} and put it at {path} ($TORCH_HOME/hub/checkpoints), then "
            "run the fetch again") from err


def _output_names(model, x) -> list[str]:  # noqa: ANN001
    """The model's own output order (Faster R-CNN: boxes, labels, scores; RetinaNet: boxes,
    scores, labels), read from what it returns: the ONNX outputs are named after it."""
    torch = load("torch")

    with torch.no_grad():
        return list(model([x])[0].keys())


def _export_torchvision(spec: KnownDetector, out: Path, pretrained: bool, kwargs: dict[str, Any],
                        model_hook: Callable[[Any], None] | None) -> dict[str, Any]:
    torch, torchvision = _import("torch torchvision", spec.name)
    model, weights = torchvision_model(spec, pretrained, **kwargs)
    if model_hook is not None:
        model_hook(model)
    names = _class_names(weights)
    x = torch.rand(3, *EXPORT_HW, generator=torch.Generator().manual_seed(0))
    outputs = _output_names(model, x)
    settings = {"exporter": "torch.onnx.export (legacy TorchScript, dynamo=False)",
                "opset": OPSET, "input": "image (3, H, W) float32 RGB in [0, 1]",
                "traced_at": list(EXPORT_HW), "outputs": outputs,
                "dynamic_axes": {"image": [1, 2], **{o: [0] for o in outputs}},
                "builder_kwargs": {k: repr(v) for k, v in {**spec.kwargs, **kwargs}.items()},
                "model_hook": getattr(model_hook, "__name__", None)}
    torch.onnx.export(model, ([x],), str(out), opset_version=OPSET, dynamo=False,
                      input_names=["image"], output_names=outputs,
                      dynamic_axes={"image": {1: "height", 2: "width"}, **{o: {0: "n"} for o in outputs}})
    write_onnx_metadata(out, {"names": repr(dict(enumerate(names)))})
    wfile = _checkpoint_file(weights, torch) if weights is not None else None
    return {
        "source": f"torchvision.models.detection.{spec.builder}",
        "weights": _weights_record(spec.weights if pretrained else None, wfile,
                                   weights.url if weights is not None else None),
        "export": settings, "convention": "torchvision", "class_names": names,
        "versions": {"torch": torch.__version__, "torchvision": torchvision.__version__},
    }


def _class_names(weights) -> list[str]:  # noqa: ANN001

    if weights is not None:
        return [str(c) for c in weights.meta["categories"]]
    return list(COCO91_NAMES)


def _weights_record(name: str | None, path: Path | None, url: str | None) -> dict[str, Any]:
    if name is None:
        return {"name": None, "note": "random weights (pretrained=False): for tests only"}
    return {"name": name, "url": url, "file": str(path),
            "sha256": file_sha256(path) if path and path.is_file() else None}


def write_onnx_metadata(path: str | Path, entries: dict[str, str]) -> None:
    """Add ``entries`` to the ONNX file's metadata_props (``names`` is what the runtime reads)."""
    (onnx,) = _import("onnx", "a detector")
    model = onnx.load(str(path))
    kept = [p for p in model.metadata_props if p.key not in entries]
    del model.metadata_props[:]
    model.metadata_props.extend(kept)
    for key, value in entries.items():
        model.metadata_props.add(key=key, value=value)
    onnx.save(model, str(path))


def _export_ultralytics(spec: KnownDetector, out: Path, folder: Path, pretrained: bool,
                        model_hook: Callable[[Any], None] | None) -> dict[str, Any]:
    (ultralytics,) = _import("ultralytics", spec.name)
    stem = spec.builder.removesuffix(".pt")
    work = folder / "weights"
    work.mkdir(exist_ok=True)
    pt = work / spec.builder
    if pretrained:
        try:
            model = ultralytics.YOLO(str(pt))  # its own loader downloads to this path
        except ImportError as err:  # installed with --no-deps, without requests
            raise _missing(err, spec.name, ULTRALYTICS_INSTALL) from err
        except Exception as err:  # offline: Ultralytics raises several kinds
            raise InputError(
                f"could not download the weights of {spec.name!r} ({type(err).__name__}: {err}). "
                f"Run 'dynaeval detector fetch {spec.name}' on a machine with network, or "
                f"download {YOLO_RELEASE}/{spec.builder} and put it at {pt}, then fetch again"
            ) from err
    else:
        model = ultralytics.YOLO(f"{stem}.yaml")  # the architecture, random weights
    if model_hook is not None:
        model_hook(model.model)
    settings = {"exporter": "ultralytics YOLO.export", "format": "onnx", "imgsz": 640,
                "opset": OPSET, "nms": False, "dynamic": False, "simplify": False,
                "model_hook": getattr(model_hook, "__name__", None)}
    cwd = Path.cwd()
    os.chdir(work)  # an export of the .yaml architecture writes into the working folder
    try:
        exported = model.export(**{k: v for k, v in settings.items()
                                   if k not in ("exporter", "model_hook")})
    except ImportError as err:  # onnx missing and Ultralytics' own pip run off or offline
        raise _missing(err, spec.name, ULTRALYTICS_INSTALL) from err
    finally:
        os.chdir(cwd)
    os.replace(work / exported, out)
    names = [str(model.names[i]) for i in sorted(model.names)]
    if not pretrained:  # the .yaml's names are '0'..'79': give the COCO model's, as the .pt has

        names = list(COCO80_NAMES)
        write_onnx_metadata(out, {"names": repr(dict(enumerate(names)))})
    return {
        "source": f"ultralytics.YOLO({spec.builder if pretrained else stem + '.yaml'!r})",
        "weights": _weights_record(spec.builder if pretrained else None,
                                   pt if pretrained else None,
                                   f"{YOLO_RELEASE}/{spec.builder}" if pretrained else None),
        "export": settings, "convention": "yolo", "class_names": names,
        "versions": {"ultralytics": ultralytics.__version__},
    }

"""Boxes files: regions written once from the ground truth and reused for every method scored.

Two accepted layouts (both JSON objects):

* **bare mapping** (what the scene generator writes)::

    {"cam00/000012": [{"class": "person", "id": 3, "box": [10, 20, 42, 96], "visible": 0.8}, ...],
     ...}

* **wrapper** (what :func:`write_boxes_file` / ``dynaeval detect`` writes), so that metadata about
  how the boxes were made never mixes with frame keys::

    {"schema": "dynaeval/boxes/v1",
     "source": {"kind": "detector", "model_sha256": "...", "settings": {...}},
     "boxes": {"cam00/000012": [...], ...}}

Keys are ``"<camera>/<frame>"`` stems (no file extension; the camera part may itself contain ``/``,
the frame is what follows the last ``/``). Each value is a list (possibly empty: "no object in this
frame" is information) of records. A record needs ``"class"`` (non-empty string) and ``"box"``
(``[x_min, y_min, x_max, y_max]``, four JSON integers, max exclusive, ``x_max > x_min`` and
``y_max > y_min``; coordinates outside the image are allowed and clipped where the box is used).
Non-integer coordinates (``10.5``, also ``10.0``: the scene generator and ``dynaeval detect`` write
integers), coordinates beyond ``MAX_COORD`` and inverted boxes (corners swapped) are refused when
the file is read, before any frame is scored, naming the file, the frame key and the record.
The file is read as strict JSON: nested deeper than 64 levels, a NaN token or a number out of
range (``1e999``) is refused naming it (``dynaeval.io.jsonfile``).
Optional typed fields: ``"id"`` (int; a track id from the generator, a per-frame index from a
detector), ``"visible"`` (number in [0, 1]), ``"score"`` (number in [0, 1]). Any other field is
kept as is.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.boxes import as_boxes, inverted_box_problem
from dynaeval.core.errors import InputError
from dynaeval.io.atomic import write_text_atomic
from dynaeval.io.jsonfile import read_json

BOXES_SCHEMA = "dynaeval/boxes/v1"
"""Value of the ``"schema"`` field of the wrapper layout."""

MAX_COORD = 2**31 - 1
"""Largest magnitude of a box coordinate read (boxes are stored as int64 and clipped to the image
where used; a larger number would wrap around)."""

_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff", ".bmp", ".webp", ".npy")


@dataclass(frozen=True)
class BoxesFile:
    """Contents of a boxes file after validation."""

    boxes: dict[str, list[dict[str, Any]]]
    """``"<camera>/<frame>"`` -> list of records (``class``, ``box`` and optional fields)."""
    source: dict[str, Any] | None = None
    """How the boxes were made (detector hash, settings); None for a bare mapping."""
    schema: str | None = None
    """``BOXES_SCHEMA`` for the wrapper layout, None for a bare mapping."""
    extra: dict[str, Any] = field(default_factory=dict)
    """Other top-level fields of the wrapper, kept as read."""


def frame_key(camera: str, frame: str) -> str:
    """The boxes-file key of a frame: ``"<camera>/<frame>"`` with the frame's extension removed."""
    stem = frame
    for suffix in _IMAGE_SUFFIXES:
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
            break
    return f"{camera}/{stem}"


def _check_key(key: object, path: str | Path | None) -> str:
    if not isinstance(key, str) or "/" not in key:
        raise InputError(
            f"key {key!r}: expected '<camera>/<frame>' (e.g. 'cam00/000012'); if this is a "
            f"wrapper file it needs \"schema\": \"{BOXES_SCHEMA}\" and a \"boxes\" object",
            path=path,
        )
    camera, frame = key.rsplit("/", 1)
    if not camera or not frame:
        raise InputError(f"key {key!r}: camera and frame must both be non-empty", path=path)
    if frame.lower().endswith(_IMAGE_SUFFIXES):
        raise InputError(
            f"key {key!r}: keys are frame stems without extension, e.g. {frame_key(camera, frame)!r}",
            path=path,
        )
    return key


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_number(value: object) -> bool:
    return (_is_int(value) or isinstance(value, (float, np.floating))) and math.isfinite(
        float(value)  # type: ignore[arg-type]
    )


def validate_record(record: object, *, key: str, index: int, path: str | Path | None = None) -> dict:
    """Check one record of a boxes file and return it as a plain dict (ints as Python ints).

    Raises InputError naming the file, the key and the record index on any problem.
    """
    where = f"frame {key!r}, record {index}"
    if not isinstance(record, Mapping):
        raise InputError(f"{where}: expected an object with 'class' and 'box', got {type(record).__name__}", path=path)
    out = dict(record)
    cls = out.get("class")
    if not isinstance(cls, str) or not cls:
        raise InputError(f"{where}: 'class' must be a non-empty string (e.g. \"person\"), got {cls!r}", path=path)
    box = out.get("box")
    if not isinstance(box, (list, tuple, np.ndarray)) or len(box) != 4:
        raise InputError(f"{where}: 'box' must be [x_min, y_min, x_max, y_max], got {box!r}", path=path)
    if not all(_is_int(v) for v in box):
        raise InputError(
            f"{where}: 'box' coordinates must be integers (whole pixels), got {list(box)!r}; "
            "round them outwards when writing the file (floor x_min, y_min; ceil x_max, y_max)",
            path=path,
        )
    if any(abs(int(v)) > MAX_COORD for v in box):
        raise InputError(
            f"{where}: 'box' coordinates must be within ±{MAX_COORD} pixels, got {list(box)!r} "
            "(out of range: such a box would be stored wrapped around, with other corners)",
            path=path,
        )
    x0, y0, x1, y1 = (int(v) for v in box)
    _check_order([x0, y0, x1, y1], where, path)
    out["box"] = [x0, y0, x1, y1]
    if "id" in out:
        if not _is_int(out["id"]):
            raise InputError(f"{where}: 'id' must be an integer, got {out['id']!r}", path=path)
        out["id"] = int(out["id"])
    for name in ("visible", "score"):
        if name in out:
            v = out[name]
            if not _is_number(v) or not 0.0 <= float(v) <= 1.0:
                raise InputError(f"{where}: {name!r} must be a number in [0, 1], got {v!r}", path=path)
            out[name] = float(v)
    return out


def _check_order(box: list[int], where: str, path: str | Path | None) -> None:
    """Refuse an inverted box (max < min: corners swapped), then an empty one (max == min)."""
    problem = inverted_box_problem(box)
    if problem:
        raise InputError(f"{where}: {problem}", path=path)
    x0, y0, x1, y1 = box
    if x1 == x0 or y1 == y0:
        raise InputError(
            f"{where}: 'box' {box} is empty: need x_max > x_min and y_max > y_min "
            "(max is exclusive)",
            path=path,
        )


def validate_boxes(mapping: object, path: str | Path | None = None) -> dict[str, list[dict]]:
    """Validate a ``"<camera>/<frame>" -> [records]`` mapping; return a clean copy."""
    if not isinstance(mapping, Mapping):
        raise InputError(f"boxes must be a JSON object of '<camera>/<frame>' keys, got {type(mapping).__name__}", path=path)
    out: dict[str, list[dict]] = {}
    for key, records in mapping.items():
        _check_key(key, path)
        if not isinstance(records, (list, tuple)):
            raise InputError(f"key {key!r}: expected a list of records, got {type(records).__name__}", path=path)
        out[key] = [validate_record(r, key=key, index=i, path=path) for i, r in enumerate(records)]
    return out


def parse_boxes(data: object, path: str | Path | None = None) -> BoxesFile:
    """Validate decoded JSON in either layout (wrapper or bare mapping) into a BoxesFile."""
    if not isinstance(data, Mapping):
        raise InputError(f"a boxes file must hold a JSON object, got {type(data).__name__}", path=path)
    if "schema" not in data:
        return BoxesFile(boxes=validate_boxes(data, path))
    schema = data["schema"]
    if schema != BOXES_SCHEMA:
        raise InputError(f"unknown boxes schema {schema!r}; this version reads {BOXES_SCHEMA!r}", path=path)
    if "boxes" not in data:
        raise InputError(f"wrapper file ({BOXES_SCHEMA}) has no 'boxes' object", path=path)
    source = data.get("source")
    if source is not None and not isinstance(source, Mapping):
        raise InputError(f"'source' must be an object, got {type(source).__name__}", path=path)
    extra = {k: v for k, v in data.items() if k not in ("schema", "source", "boxes")}
    return BoxesFile(
        boxes=validate_boxes(data["boxes"], path),
        source=None if source is None else dict(source),
        schema=schema,
        extra=extra,
    )


_MAKE_ONE = " (make one with `dynaeval detect GT -o boxes.json`)"


def read_boxes_file(path: str | Path) -> BoxesFile:
    """Read and strictly validate a boxes file (either layout); InputError names file and key.

    Read as strict JSON (``dynaeval.io.jsonfile.read_json``): a file nested deeper than
    ``MAX_DEPTH`` levels, a NaN token or a number out of range is refused naming it."""
    data = read_json(path, what="boxes file", missing_hint=_MAKE_ONE,
                     fix="correct the file, or write it again with `dynaeval detect GT -o "
                         "boxes.json`")
    return parse_boxes(data, path)


def _plain(value: Any) -> Any:
    """numpy scalars/arrays and paths -> Python types for JSON."""
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def write_boxes_file(
    path: str | Path,
    boxes: Mapping[str, Iterable[Mapping[str, Any]]],
    source: Mapping[str, Any] | None = None,
    *,
    overwrite: bool = True,
) -> Path:
    """Write ``boxes`` in the wrapper layout, atomically (``dynaeval.io.atomic``).

    The records are validated first (same rules as reading), so a written file always reads back.
    A failed write leaves any existing file at ``path`` untouched. With ``overwrite=False`` the
    last step is exclusive: if ``path`` exists (or appeared meanwhile) nothing is written and
    InputError is raised. Returns the path.
    """
    path = Path(path)
    clean = validate_boxes({k: list(v) for k, v in boxes.items()}, path)
    doc = {"schema": BOXES_SCHEMA, "source": _plain(dict(source or {})), "boxes": _plain(clean)}
    text = json.dumps(doc, indent=1, allow_nan=False)  # before opening: a bad value leaves no file
    write_text_atomic(path, text + "\n", overwrite=overwrite, what="boxes file")
    return path


def records_to_boxes(records: Iterable[Mapping[str, Any]], classes: Iterable[str] | None = None) -> np.ndarray:
    """``(N, 4)`` int64 boxes of the records, optionally only those whose ``class`` is in ``classes``."""
    wanted = None if classes is None else set(classes)
    sel = [r["box"] for r in records if wanted is None or r["class"] in wanted]
    return as_boxes(sel)

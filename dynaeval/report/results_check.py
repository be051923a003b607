"""The field-by-field check of a results document read back from a file (``load_results``, so
``dynaeval merge`` and ``dynaeval leaderboard``), with no jsonschema needed.

A plain ``pip install dynaeval`` has no jsonschema, and a hand-edited or damaged file must still be
refused before merge or the leaderboard use it: a string or ``true`` where a number belongs
(``"psnr": "31.5"`` was printed, ``true`` printed as 1.00), an ``inputs.shard`` without its
``count`` or with a string index (a traceback, or a misleading "shards missing"), a warning
without ``reason``. Every refusal is an ``InputError`` naming the file, the key path
(``summary.focused_psnr``, ``frames[3].psnr``, ``inputs.shard.count``) and what was expected.

What is checked is what merge, the leaderboard and the report read:

* the required keys (``RESULTS_REQUIRED``, the schema's) and the types of the top-level parts;
* ``inputs``: ``pred``/``gt`` strings, ``n_frames`` a whole number, camera lists of strings,
  ``skipped_frames`` of ``{camera, frame}``, ``shard`` ``{index, count}`` with
  1 <= index <= count (``--shard I/N`` is 1-based), ``temporal_pairs`` per camera
  ``{scored, expected}``, ``layout`` ``{name, root}``;
* ``metrics``: per metric ``{higher_is_better: bool, unit: str}``;
* values in ``frames``, ``cameras`` and ``summary``: a number or ``null`` (a boolean is not a
  number) for every metric ``metrics`` lists; a number, boolean or ``null`` under a key that
  ``metrics`` does not list is refused too (merge would take it for a metric);
  magnitudes beyond ``VALUE_LIMIT`` are out of range;
* frame rows: ``camera``, ``frame``, ``pred``, ``gt`` strings, ``index`` a whole number,
  ``objects`` an array of objects; ``cameras.<c>.n_frames`` and ``summary.n_frames`` whole numbers;
* ``counts`` whole numbers, ``timing`` numbers >= 0 (``total_s`` required);
* ``warnings``: objects with a string ``reason``, optional string ``metric``, ``camera``,
  ``frame``; in a v2 file also a ``status`` (a ``dynaeval.core.outcome.Status`` value, not ``ok``),
  and ``summary_status`` an object of statuses (a v1 file has neither: ``load_results`` gives
  them);
* ``settings`` an object, ``settings.temporal`` (read by merge) an object;
* ``regions`` (optional): ``source`` one of ``REGION_SOURCES``, ``bundled_detector`` a boolean,
  per camera ``source``, ``n_frames``, ``frames_with_boxes``, ``boxes`` (whole numbers per class),
  ``mask_fraction`` (``null`` or ``{mean, max}``), ``global_motion_px`` (number or ``null``).

Keys it does not know are ignored (a string, array or object under any other key), so a newer
writer may add fields. Strict-JSON problems (NaN tokens, ``1e999``, deep nesting) are refused
before, when the file is parsed (``dynaeval.io.jsonfile``).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NoReturn

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import VALUE_LIMIT, Status

RESULTS_REQUIRED = {
    "": ("schema", "dynaeval_version", "created", "method", "scene", "inputs", "settings",
         "metrics", "frames", "cameras", "summary", "summary_status", "counts", "timing",
         "warnings"),
    "inputs": ("pred", "gt", "n_frames", "cameras", "unscored_cameras", "skipped_frames"),
    "summary": ("n_frames",),
}
"""The keys the schema requires, checked without jsonschema (a test holds them to the schema);
a ``dynaeval/results/v1`` file has all but ``V2_ONLY``."""

V2_ONLY = ("summary_status",)
"""Top-level keys results schema v2 added."""

WARNING_STATUSES = tuple(s.value for s in Status if s is not Status.OK)
"""The ``status`` of a warning (``$defs.status`` of the v2 schema; a test holds them together)."""

FRAME_FIELDS = ("camera", "frame", "index", "pred", "gt")
"""Keys of a frame row that are not metric values."""

REGION_SOURCES = ("detector", "motion", "boxes", "none")
"""Values of ``regions.source``: the focus sources (``dynaeval.regions.focus.FOCUS_SOURCES``; a
test holds them together)."""


_KINDS = {dict: "a JSON object", list: "a JSON array", str: "a JSON string"}


def _shown(value: Any) -> str:
    """A value as a message shows it: ``"31.5" (a string)``, ``true (a boolean)``, ``an object``."""
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    if value is None:
        return "null"
    if isinstance(value, str):
        text = json.dumps(value if len(value) <= 40 else value[:40] + "...", ensure_ascii=False)
        return f"{text} (a string)"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "an array"
    return repr(value)


def _is_whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _fix(value: Any) -> str:
    """What to do about ``value`` standing where a number belongs."""
    if isinstance(value, bool):
        return "true/false is not a number: write the value, or score again"
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            pass
        else:
            return "write the number without quotes, or score again"
    return _FIX


_FIX = "correct it by hand or score again"


class _Check:
    """Refusals of one file: every one an InputError naming the file and the key path."""

    def __init__(self, path: str | Path) -> None:
        self.path = path

    def fail(self, where: str, expected: str, value: Any, fix: str = _FIX) -> NoReturn:
        """Refuse ``value`` at ``where``: what was expected, what came, what to do."""
        raise InputError(f"not a valid dynaeval results file: '{where}' must be {expected}, got "
                         f"{_shown(value)}; {fix}", path=self.path)

    def required(self, part: dict[str, Any], where: str, keys: Iterable[str]) -> None:
        """Refuse ``part`` (at ``where``) when one of ``keys`` is missing, naming them all."""
        missing = [k for k in keys if k not in part]
        if missing:
            field = f"{where}." if where else ""
            raise InputError(f"not a complete dynaeval results file: no "
                             f"{', '.join(repr(field + k) for k in missing)} (was it edited or "
                             "truncated? score again to get the whole file)", path=self.path)

    def kind(self, value: Any, where: str, kind: type) -> None:
        """``value`` is a JSON object, array or string (``kind`` dict, list or str)."""
        if not isinstance(value, kind):
            self.fail(where, _KINDS[kind], value)

    def string_fields(self, part: dict[str, Any], where: str, keys: Iterable[str]) -> None:
        """Those of ``keys`` that ``part`` holds are strings."""
        for key in keys:
            if key in part:
                self.kind(part[key], f"{where}.{key}" if where else key, str)

    def string_list(self, value: Any, where: str) -> None:
        """``value`` is an array of strings."""
        self.kind(value, where, list)
        for i, item in enumerate(value):
            self.kind(item, f"{where}[{i}]", str)

    def whole(self, value: Any, where: str, minimum: int = 0) -> None:
        """``value`` is a JSON integer >= ``minimum`` (not a boolean, not ``1.0``)."""
        if not _is_whole(value) or value < minimum:
            self.fail(where, f"a whole number >= {minimum}", value, _fix(value))

    def number(self, value: Any, where: str, *, null: bool = True, minimum: float | None = None,
               ) -> None:
        """``value`` is a number (not a boolean) within ``VALUE_LIMIT``, or null when ``null``."""
        if value is None and null:
            return
        if not _is_number(value):
            self.fail(where, "a number or null" if null else "a number", value, _fix(value))
        if abs(value) > VALUE_LIMIT:
            raise InputError(f"not a valid dynaeval results file: '{where}' is {value!r}: out of "
                             f"range (values are within ±{VALUE_LIMIT:g}); {_FIX}", path=self.path)
        if minimum is not None and value < minimum:
            self.fail(where, f"a number >= {minimum:g}", value)

    def object(self, value: Any, where: str, required: Iterable[str] = ()) -> dict[str, Any]:
        """``value`` is a JSON object holding ``required``; returned."""
        self.kind(value, where, dict)
        self.required(value, where, required)
        return value


def check_results(doc: dict[str, Any], path: str | Path) -> None:
    """Check a parsed results document field by field (module docstring); return if it is
    usable by merge, the leaderboard and the report.

    Args:
        doc: the parsed file (a JSON object of a schema version this dynaeval reads).
        path: the file, named in every error.

    Raises:
        InputError: the first missing or wrong field, named by its key path.
    """
    check = _Check(path)
    v1 = doc.get("schema") == "dynaeval/results/v1"
    check.required(doc, "", [k for k in RESULTS_REQUIRED[""] if not (v1 and k in V2_ONLY)])
    for key in ("inputs", "settings", "metrics", "cameras", "summary", "counts", "timing"):
        check.kind(doc[key], key, dict)
    for key in ("frames", "warnings"):
        check.kind(doc[key], key, list)
    for key in ("method", "scene", "schema", "dynaeval_version", "created"):
        check.kind(doc[key], key, str)
    check.required(doc["inputs"], "inputs", RESULTS_REQUIRED["inputs"])
    check.required(doc["summary"], "summary", RESULTS_REQUIRED["summary"])
    _check_inputs(check, doc["inputs"])
    if "temporal" in doc["settings"]:
        check.kind(doc["settings"]["temporal"], "settings.temporal", dict)
    names = set(doc["metrics"])
    for name, info in doc["metrics"].items():
        where = f"metrics.{name}"
        check.object(info, where, ("higher_is_better", "unit"))
        if not isinstance(info["higher_is_better"], bool):
            check.fail(f"{where}.higher_is_better", "true or false", info["higher_is_better"])
        check.kind(info["unit"], f"{where}.unit", str)
    for i, row in enumerate(doc["frames"]):
        _check_frame(check, row, f"frames[{i}]", names)
    for cam, entry in doc["cameras"].items():
        check.object(entry, f"cameras.{cam}", ("n_frames",))
        check.whole(entry["n_frames"], f"cameras.{cam}.n_frames")
        _check_values(check, entry, f"cameras.{cam}", names, ("n_frames",))
    check.whole(doc["summary"]["n_frames"], "summary.n_frames")
    _check_values(check, doc["summary"], "summary", names, ("n_frames",))
    for name, n in doc["counts"].items():
        check.whole(n, f"counts.{name}")
    check.required(doc["timing"], "timing", ("total_s",))
    for name, seconds in doc["timing"].items():
        check.number(seconds, f"timing.{name}", null=False, minimum=0)
    for i, warning in enumerate(doc["warnings"]):
        check.object(warning, f"warnings[{i}]", ("reason",) if v1 else ("status", "reason"))
        check.string_fields(warning, f"warnings[{i}]", ("reason", "metric", "camera", "frame"))
        if not v1:
            _check_status(check, warning["status"], f"warnings[{i}].status")
    if not v1:
        check.kind(doc["summary_status"], "summary_status", dict)
        for name, status in doc["summary_status"].items():
            _check_status(check, status, f"summary_status.{name}")
    if "regions" in doc:
        _check_regions(check, doc["regions"])
    _check_temporal_parts(check, doc.get("temporal_parts", {}))


def _check_temporal_parts(check: _Check, found: Any) -> None:
    """``temporal_parts``: per camera and key, ``signed``, ``pred``, ``gt`` numbers or null."""
    check.kind(found, "temporal_parts", dict)
    for cam, terms in found.items():
        check.kind(terms, f"temporal_parts.{cam}", dict)
        for key, parts in terms.items():
            check.kind(parts, f"temporal_parts.{cam}.{key}", dict)
            for part in ("signed", "pred", "gt"):
                check.number(parts.get(part), f"temporal_parts.{cam}.{key}.{part}", null=True)


def _check_status(check: _Check, status: Any, where: str) -> None:
    """``status`` is one of ``WARNING_STATUSES``."""
    if status not in WARNING_STATUSES:
        check.fail(where, f"one of {', '.join(WARNING_STATUSES)}", status)


def _check_inputs(check: _Check, inputs: dict[str, Any]) -> None:
    check.string_fields(inputs, "inputs", ("pred", "gt"))
    check.whole(inputs["n_frames"], "inputs.n_frames")
    check.string_list(inputs["cameras"], "inputs.cameras")
    check.string_list(inputs["unscored_cameras"], "inputs.unscored_cameras")
    check.kind(inputs["skipped_frames"], "inputs.skipped_frames", list)
    for i, skipped in enumerate(inputs["skipped_frames"]):
        check.object(skipped, f"inputs.skipped_frames[{i}]", ("camera", "frame"))
        check.string_fields(skipped, f"inputs.skipped_frames[{i}]", ("camera", "frame"))
    if "shard" in inputs:
        shard = check.object(inputs["shard"], "inputs.shard", ("index", "count"))
        check.whole(shard["count"], "inputs.shard.count", minimum=1)
        check.whole(shard["index"], "inputs.shard.index", minimum=1)
        if shard["index"] > shard["count"]:
            check.fail("inputs.shard.index", f"at most inputs.shard.count ({shard['count']}): "
                       "--shard I/N is 1-based", shard["index"])
    if "temporal_pairs" in inputs:
        check.kind(inputs["temporal_pairs"], "inputs.temporal_pairs", dict)
        for cam, pairs in inputs["temporal_pairs"].items():
            where = f"inputs.temporal_pairs.{cam}"
            check.object(pairs, where, ("scored", "expected"))
            check.whole(pairs["scored"], f"{where}.scored")
            check.whole(pairs["expected"], f"{where}.expected")
    if "layout" in inputs:
        check.object(inputs["layout"], "inputs.layout", ("name", "root"))
        check.string_fields(inputs["layout"], "inputs.layout", ("name", "root"))


def _check_values(check: _Check, part: dict[str, Any], where: str, names: set[str],
                  fields: tuple[str, ...]) -> None:
    """The values of a frame row, a camera entry or the summary: a number or null for each
    listed metric; a number, boolean or null under any other key but ``fields`` (checked by the
    caller) is refused."""
    for key, value in part.items():
        if key in names:
            check.number(value, f"{where}.{key}")
        elif key not in fields and (value is None or isinstance(value, (bool, int, float))):
            raise InputError(f"not a valid dynaeval results file: '{where}.{key}' holds a value "
                             f"({_shown(value)}) of a metric that 'metrics' does not list (merge "
                             "would take it for one); list it there or remove the key",
                             path=check.path)


def _check_frame(check: _Check, row: Any, where: str, names: set[str]) -> None:
    check.object(row, where, FRAME_FIELDS)
    check.string_fields(row, where, ("camera", "frame", "pred", "gt"))
    check.whole(row["index"], f"{where}.index")
    if "objects" in row:
        check.kind(row["objects"], f"{where}.objects", list)
        for k, obj in enumerate(row["objects"]):
            check.kind(obj, f"{where}.objects[{k}]", dict)
    _check_values(check, row, where, names, FRAME_FIELDS)


def _check_regions(check: _Check, regions: Any) -> None:
    check.object(regions, "regions", ("source", "bundled_detector", "cameras"))
    if regions["source"] not in REGION_SOURCES:
        check.fail("regions.source", f"one of {', '.join(REGION_SOURCES)}", regions["source"])
    if not isinstance(regions["bundled_detector"], bool):
        check.fail("regions.bundled_detector", "true or false", regions["bundled_detector"])
    check.kind(regions["cameras"], "regions.cameras", dict)
    for cam, entry in regions["cameras"].items():
        where = f"regions.cameras.{cam}"
        check.object(entry, where, ("source", "n_frames", "frames_with_boxes", "boxes"))
        check.kind(entry["source"], f"{where}.source", str)
        check.whole(entry["n_frames"], f"{where}.n_frames")
        check.whole(entry["frames_with_boxes"], f"{where}.frames_with_boxes")
        check.kind(entry["boxes"], f"{where}.boxes", dict)
        for cls, n in entry["boxes"].items():
            check.whole(n, f"{where}.boxes.{cls}")
        if "global_motion_px" in entry:
            check.number(entry["global_motion_px"], f"{where}.global_motion_px", minimum=0)
        fraction = entry.get("mask_fraction")
        if fraction is not None:
            check.object(fraction, f"{where}.mask_fraction", ("mean", "max"))
            for key in ("mean", "max"):
                check.number(fraction[key], f"{where}.mask_fraction.{key}", null=False, minimum=0)

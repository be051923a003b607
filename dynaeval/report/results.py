"""The results document (leaderboard JSON, schema ``dynaeval/results/v2``) and writing it safely.

Layout (docs/results-format.md documents every field; the JSON Schema ships as
``dynaeval/schemas/results-v2.schema.json``)::

    {"schema": "dynaeval/results/v2", "dynaeval_version": ..., "created": ISO-8601 UTC,
     "method": ..., "scene": ...,
     "inputs": {"pred": ..., "gt": ..., "n_frames": ..., "cameras": [...],
                "unscored_cameras": [...], "skipped_frames": [...]},
     "settings": {...every setting that changes a number...},
     "metrics": {name: {"higher_is_better": bool, "unit": str}},
     "frames": [{"camera", "frame", "index", "pred", "gt", <metric>: value|null, ...}],
     "cameras": {camera: {"n_frames": int, <metric>: mean|null}},
     "summary": {"n_frames": int, <metric>: mean|null},
     "summary_status": {<metric>: status of its null summary},
     "counts": {<metric>: frames with a defined value},
     "timing": {"total_s": ..., "read": ..., <metric>: seconds summed over frames},
     "warnings": [{"metric"?, "camera"?, "frame"?, "status", "reason"}]}

Summaries are the mean of per-frame values (every frame weighs the same, cameras with more frames
weigh more), never a metric of the pooled error. A per-frame value that is undefined (empty region)
or infinite (PSNR of identical images) is ``null`` with a warning whose ``status``
(``dynaeval.core.outcome.Status``) says which (``restore_infinite`` reads an ``infinite`` one back); a
summary over frames that include an infinite value is ``null`` too (its mean is infinite), over
undefined ones it is the mean of the defined values with ``counts`` saying how many (infinite ones
are counted). Every null summary value has its status in ``summary_status``.

Files of schema ``dynaeval/results/v1`` (no statuses) are read too: ``load_results`` gives them
their statuses once, from their text (``_upgrade_v1``, the one place that reads warning text).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from dynaeval.core.deps import available, load
from dynaeval.core.errors import InputError
from dynaeval.core.outcome import (
    NO_REGIONS,
    CameraTerm,
    Status,
    no_box_reason,
    status_of,
    summary_reason,
    warning,
)
from dynaeval.core.schemas import RESULTS_SCHEMA, results_schema_path
from dynaeval.io.atomic import write_text_atomic
from dynaeval.io.jsonfile import read_json
from dynaeval.metrics.registry import METRICS, SPECS
from dynaeval.regions.sources import SOURCE_KINDS
from dynaeval.report.results_check import FRAME_FIELDS, check_results

SCHEMA = RESULTS_SCHEMA
SCHEMA_V1 = "dynaeval/results/v1"
"""The previous layout: the same document without ``status`` and ``summary_status``."""
READS = (SCHEMA, SCHEMA_V1)

def _direction(name: str) -> dict[str, Any]:
    """``{"higher_is_better", "unit"}`` of a result key, from the metric registry.

    Raises:
        KeyError: the key is not registered (a bug: every reported key is in the registry).
    """
    if name not in METRICS:
        raise KeyError(f"result key {name!r} is not in the metric registry "
                       "(dynaeval.metrics.registry.SPECS): register the metric")
    info = METRICS[name]
    return {"higher_is_better": info.higher_is_better, "unit": info.unit}


def _mean(values: list[float | None]) -> tuple[float | None, int, str | None]:
    """Mean of the defined values; (mean or None, count defined, reason when None)."""
    defined = [v for v in values if v is not None]
    if not defined:
        return None, 0, "no frame has a defined value"
    if any(math.isinf(v) for v in defined):
        n_inf = sum(math.isinf(v) for v in defined)
        return None, len(defined), f"{n_inf} frame(s) have an infinite value (identical images)"
    return math.fsum(defined) / len(defined), len(defined), None


def _summary_status(values: list[float | None], members: list[dict]) -> Status:
    """The status of a null summary of ``values``: ``INFINITE`` when one is infinite, else the
    one status the warnings of its null ``members`` share (``UNDEFINED`` when they differ)."""
    if any(v is not None and math.isinf(v) for v in values):
        return Status.INFINITE
    found = {status_of(w) for w in members} - {Status.NOTE}
    return found.pop() if len(found) == 1 else Status.UNDEFINED



def restore_infinite(rows: list[dict[str, Any]], warnings: list[dict]) -> int:
    """Put ``inf`` back, in place, into the rows of a results file where a frame warning's
    status says the ``null`` stands for +infinity (``Status.INFINITE``), so re-summarising them
    (``merge``) gives what the unsharded run gave: a null summary with its warning, and the frame
    counted. Returns how many values were restored."""
    infinite = {(w["camera"], w["frame"], w["metric"]) for w in warnings
                if "camera" in w and "frame" in w and "metric" in w
                and status_of(w) is Status.INFINITE}
    n = 0
    for row in rows:
        for name in list(row):
            if row[name] is None and (row["camera"], row["frame"], name) in infinite:
                row[name] = math.inf
                n += 1
    return n


def place_temporal(
    rows: list[dict[str, Any]], temporal: dict[str, dict[str, CameraTerm]]
) -> tuple[dict[str, dict[str, float | None]], list[dict]]:
    """Put per-pair temporal values into the frame rows, in place; return the camera-level ones.

    The value of pair (t-1, t) goes into the row of frame t (the first frame of a camera has
    none), a null one with a warning of its ``CameraTerm.pair_outcome`` (a gap of missing frames,
    the camera's own null, or its ``pair_null``: frames without a box). Terms without per-pair
    values (``flicker``, ``jod``, or a term null for the whole camera) are camera-level:
    returned as ``{camera: {name: value}}``, with a warning of its outcome when null.

    Args:
        rows: frame rows of every camera, each camera's in index order.
        temporal: per camera, its terms by result key (``dynaeval.run.stages``).
    """
    camera_values: dict[str, dict[str, float | None]] = {}
    warnings: list[dict] = []
    for cam, terms in temporal.items():
        cam_rows = sorted((r for r in rows if r["camera"] == cam), key=lambda r: r["index"])
        for name, term in terms.items():
            if term.per_pair and len(term.per_pair) == len(cam_rows) - 1:
                for k, (row, value) in enumerate(zip(cam_rows[1:], term.per_pair, strict=True)):
                    row[name] = value
                    if value is None:
                        why = term.pair_outcome(k)
                        warnings.append(warning(why.status, why.detail, camera=cam,
                                                frame=row["frame"], metric=name))
                continue
            camera_values.setdefault(cam, {})[name] = term.outcome.value
            if term.outcome.value is None:
                warnings.append(warning(term.outcome.status, term.outcome.detail, camera=cam,
                                        metric=name))
    return camera_values, warnings


@dataclass
class _Summaries:
    """What ``_summaries`` finds: per-camera means, the overall summary, the counts of defined
    values, the names of the camera-level terms, the status of each null summary value and
    its warnings."""

    cameras: dict[str, dict[str, Any]]
    summary: dict[str, Any]
    counts: dict[str, int]
    camera_only: list[str]
    status: dict[str, str] = field(default_factory=dict)
    """``summary_status``: metric -> ``Status`` value of its null summary."""
    warnings: list[dict] = field(default_factory=list)
    """One per null summary value (of a run with frames)."""


def _summaries(
    rows: list[dict[str, Any]], names: list[str],
    camera_values: dict[str, dict[str, float | None]], warnings: list[dict],
    off: set[str] = frozenset(),
) -> _Summaries:
    """Per-camera means, the overall summary, the counts of defined values, the names of the
    camera-level terms; the status of each null summary value (``DISABLED`` for the keys
    ``off``, else from the statuses of the ``warnings`` of the values it averages) and its
    warning."""
    in_rows = {k for r in rows for k in r}
    camera_only = [n for n in dict.fromkeys(n for vals in camera_values.values() for n in vals)
                   if n not in in_rows]
    cameras: dict[str, dict[str, Any]] = {}
    by_camera: dict[str, list[dict]] = {}
    for row in rows:
        by_camera.setdefault(row["camera"], []).append(row)
    for cam, cam_rows in by_camera.items():
        entry: dict[str, Any] = {"n_frames": len(cam_rows)}
        for name in names:
            entry[name], _, _ = _mean([r.get(name) for r in cam_rows])
        for name in camera_only:
            entry[name] = camera_values.get(cam, {}).get(name)
        cameras[cam] = entry
    summary: dict[str, Any] = {"n_frames": len(rows)}
    out = _Summaries(cameras, summary, {}, camera_only)
    members: dict[tuple[str, bool], list[dict]] = {}  # (metric, of a frame) -> its nulls' warnings
    for w in warnings:
        if "camera" in w and "metric" in w:
            members.setdefault((w["metric"], "frame" in w), []).append(w)
    for per_camera, keys in ((False, names), (True, camera_only)):
        for name in keys:
            values = ([c.get(name) for c in cameras.values()] if per_camera
                      else [r.get(name) for r in rows])
            summary[name], out.counts[name], reason = _mean(values)
            if reason is None:
                continue
            status = (Status.DISABLED if name in off
                      else _summary_status(values, members.get((name, not per_camera), [])))
            out.status[name] = status.value
            if rows:
                out.warnings.append(warning(status, metric=name, reason=summary_reason(
                    reason, per_camera=per_camera)))
    return out


def switched_off(settings: dict[str, Any]) -> set[str]:
    """The result keys the run's ``settings`` switched off though they are reported: tLP's when
    ``settings.temporal.tlp`` is false (LPIPS not among the metrics). Their null values are
    what was asked for (``Status.DISABLED``), and their warnings are left out."""
    if (settings.get("temporal") or {}).get("tlp") is not False:
        return set()
    return set(SPECS["tlp"].keys())


def _without_disabled_tlp(warnings: list[dict], settings: dict[str, Any]) -> list[dict]:
    """``warnings`` without those of the keys ``switched_off``; a tLP that was on and came out
    null keeps its warnings."""
    keys = switched_off(settings)
    return [w for w in warnings if w.get("metric") not in keys] if keys else warnings


def no_regions_warning(regions: dict[str, Any] | None) -> dict[str, str] | None:
    """The one headline warning of a run whose ``regions`` hold no box in any frame (None
    otherwise; ``Status.NO_REGION``, its text ``dynaeval.core.outcome.no_box_reason``): what found
    nothing, that every focused (and presence) value is null, the fix."""
    kind = SOURCE_KINDS.get((regions or {}).get("source"))
    if kind is None or not kind.gives_boxes or not regions.get("cameras"):
        return None
    cams = list(regions["cameras"].values())
    if any(c["frames_with_boxes"] for c in cams):
        return None
    classes = ", ".join(dict.fromkeys(c for cam in cams for c in cam["boxes"])) or "?"
    who, fix = kind.nothing_found(bool(regions.get("bundled_detector")), classes)
    return warning(Status.NO_REGION, reason=no_box_reason(
        who, fix, sum(c["n_frames"] for c in cams), presence=kind.classed))


def is_no_regions_warning(w: dict) -> bool:
    """The headline of ``no_regions_warning``: run-level, of no metric, ``Status.NO_REGION``."""
    return "camera" not in w and "metric" not in w and status_of(w) is Status.NO_REGION


def _explained_by_no_regions(metric: str, regions: dict[str, Any]) -> bool:
    """A null summary of ``metric`` that the no-box headline explains."""
    info = METRICS.get(metric)
    explained = {"focused", "person", "ball",
                 *(("masked",) if SOURCE_KINDS[regions["source"]].from_motion else ())}
    return info is not None and info.variant in explained


@dataclass
class RunRecord:
    """What a run (or ``merge``, from shards) hands the results document, one field each."""

    rows: list[dict[str, Any]]
    """Frame rows (``camera``, ``frame``, ``index``, ``pred``, ``gt``, values; inf kept)."""
    metric_names: list[str]
    """The per-frame result keys, in report order."""
    method: str
    """The method's name (``method``)."""
    scene: str
    """The scene's name (``scene``)."""
    pred_dir: str
    """The predictions' folder (``inputs.pred``)."""
    gt_dir: str
    """The ground truth's folder (``inputs.gt``)."""
    settings: dict[str, Any]
    """Every setting that changes a number (``settings``)."""
    unscored_cameras: list[str]
    """Cameras of the ground truth without predictions (``inputs.unscored_cameras``)."""
    skipped: list[dict]
    """Frames left out (``inputs.skipped_frames``)."""
    warnings: list[dict]
    """The run's warnings so far, each with a ``status``."""
    timing: dict[str, float]
    """Seconds per phase and metric."""
    version: str
    """The dynaeval version that scored."""
    temporal: dict[str, dict[str, CameraTerm]] | None = None
    """Per camera, its camera-level terms by result key (``place_temporal``)."""
    camera_values: dict[str, dict[str, float | None]] | None = None
    """Camera-level values given directly (``merge``)."""
    shard: tuple[int, int] | None = None
    """``(index, count)`` of a shard's run."""
    inputs_extra: dict[str, Any] | None = None
    """More ``inputs`` fields (the render folder's layout, the temporal pairs)."""
    regions: dict[str, Any] | None = None
    """``{"source", "bundled_detector", "cameras": {camera: regions_summary}}``, or None."""
    temporal_parts: dict[str, dict[str, dict[str, float | None]]] | None = None
    """Parts given directly (``merge``), beside those of ``temporal``."""


def build_results(record: RunRecord) -> dict[str, Any]:
    """Assemble the results document from per-frame rows (values may be inf; made strict here).

    Every metric that has per-frame values is summarised the same way: per camera the mean over
    its frames, overall the mean over all frames (``_mean``). ``temporal`` (per camera, its
    terms by result key) is first spread over the rows by ``place_temporal``: a temporal
    term's per-frame value is that of the pair (previous frame, this frame), so its summary is
    the mean over all frame pairs of all cameras. Camera-level terms (``flicker``; or
    ``camera_values`` given directly, as ``merge`` does) are summarised as the mean over cameras.
    ``regions`` (``{"source", "bundled_detector", "cameras": {camera: regions_summary}}``) is
    written as is; ``temporal_parts`` (``{camera: {key: {"signed", "pred", "gt"}}}``, as
    ``merge`` has them) beside the parts of ``temporal``'s terms (``parts_of``); when no frame
    has a box, one headline warning (``no_regions_warning``) replaces the null-summary warnings
    of the focused and presence metrics.
    """
    warnings = list(record.warnings)
    unmarked = [w for w in warnings if "status" not in w]
    if unmarked:
        raise ValueError(f"warning without a status: {unmarked[0]} (a bug: make warnings with "
                         "dynaeval.core.outcome.warning or note)")
    camera_values = {c: dict(v) for c, v in (record.camera_values or {}).items()}
    if record.temporal:  # the per-pair values go into the rows, the camera-level ones here
        placed, more = place_temporal(record.rows, record.temporal)
        warnings.extend(more)
        for cam, values in placed.items():
            camera_values.setdefault(cam, {}).update(values)
    names = _frame_metric_names(record)
    found = _summaries(record.rows, names, camera_values, warnings, switched_off(record.settings))
    warnings = _run_warnings(warnings, found.warnings, record.regions, record.settings)
    doc = _document(record, found, [*names, *found.camera_only], warnings)
    parts = {**(record.temporal_parts or {}), **parts_of(record.temporal or {})}
    if parts:
        doc["temporal_parts"] = parts
    return strict(doc)


def _frame_metric_names(record: RunRecord) -> list[str]:
    """The per-frame result keys: ``metric_names``, then any other value key of the rows (a
    float or None), in the order met."""
    names = list(record.metric_names)
    for row in record.rows:
        for k, v in row.items():
            if k not in FRAME_FIELDS and k not in names and (v is None or isinstance(v, float)):
                names.append(k)
    return names


def _run_warnings(warnings: list[dict], nulls: list[dict], regions: dict[str, Any] | None,
                  settings: dict[str, Any]) -> list[dict]:
    """The document's warnings: the run's, then those of its null summaries (``nulls``) but
    for those the no-box headline explains (the headline then first) or tLP switched off."""
    headline = no_regions_warning(regions)
    nulls = [w for w in nulls
             if headline is None or not _explained_by_no_regions(w["metric"], regions)]
    warnings = _without_disabled_tlp([*warnings, *nulls], settings)
    return [headline, *warnings] if headline is not None else warnings


def _document(record: RunRecord, found: _Summaries, metric_names: list[str],
              warnings: list[dict]) -> dict[str, Any]:
    """The results document but its ``temporal_parts``: non-finite frame values None, the
    rest as found (strict JSON is made by the caller)."""
    frames = [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in record.rows
    ]
    return {
        "schema": SCHEMA,
        "dynaeval_version": record.version,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "method": record.method,
        "scene": record.scene,
        "inputs": {
            "pred": record.pred_dir,
            "gt": record.gt_dir,
            "n_frames": len(record.rows),
            "cameras": list(found.cameras),
            "unscored_cameras": list(record.unscored_cameras),
            "skipped_frames": list(record.skipped),
            **({"shard": {"index": record.shard[0], "count": record.shard[1]}}
               if record.shard else {}),
            **(record.inputs_extra or {}),
        },
        "settings": record.settings,
        "metrics": {n: _direction(n) for n in metric_names},
        "frames": frames,
        "cameras": found.cameras,
        "summary": found.summary,
        "summary_status": found.status,
        "counts": found.counts,
        "timing": {k: round(v, 6) for k, v in record.timing.items()},
        "warnings": warnings,
        **({"regions": record.regions} if record.regions is not None else {}),
    }


def parts_of(temporal: dict[str, dict[str, CameraTerm]]) -> dict[str, dict[str, dict]]:
    """``{camera: {key: {"signed", "pred", "gt"}}}``: the two sides behind each temporal term
    that has them (``warp_error``, ``flicker`` and their focused variants; means over the pairs,
    None where undefined), cameras and keys without parts left out."""
    out = {cam: {k: dict(t.parts) for k, t in terms.items() if t.parts}
           for cam, terms in temporal.items()}
    return {cam: terms for cam, terms in out.items() if terms}


def strict(obj: Any) -> Any:
    """Replace every non-finite float in a JSON-like structure by None (strict JSON)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict(v) for v in obj]
    return obj


def write_json_atomic(path: str | Path, doc: Any, *, overwrite: bool = False) -> Path:
    """Write ``doc`` as strict JSON to ``path`` atomically (``dynaeval.io.atomic``): a failed
    run never leaves a half-written file.

    Raises:
        InputError: ``path`` exists and ``overwrite`` is False, or its folder is missing.
        ValueError: ``doc`` holds NaN or infinity (nothing is written).
    """
    return write_text_atomic(path, results_text(doc), overwrite=overwrite, what="results file")


def results_text(doc: Any) -> str:
    """``doc`` as the strict JSON text of a results file (ValueError on NaN or infinity)."""
    return json.dumps(doc, indent=1, allow_nan=False, ensure_ascii=False) + "\n"


schema_path = results_schema_path
"""Path of the JSON Schema of the results document (of layout ``schema``, default this
version's) shipped in the package (``core.schemas``, where the registry reads its field names)."""


def _check_against_schema(doc: dict[str, Any], path: Path) -> None:
    """With jsonschema installed (a test dependency), also hold ``doc`` to the shipped schema:
    an extra check beside ``check_results``, which needs no package."""
    if not available("jsonschema"):  # optional: check_results always runs
        return
    jsonschema = load("jsonschema")
    schema = json.loads(schema_path(doc["schema"]).read_text(encoding="utf-8"))
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(doc))
    if error is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path)
        raise InputError(f"not a valid dynaeval results file: {where.lstrip('.') or 'document'}: "
                         f"{error.message}", path=path)


def load_results(path: str | Path) -> dict[str, Any]:
    """Read a results file, checking it is a complete one, in strict JSON, of a schema version
    this dynaeval reads, every field merge and the leaderboard read of the right type.

    Raises:
        InputError: naming the file: missing, a folder, unreadable, not JSON, nested deeper than
            ``dynaeval.io.jsonfile.MAX_DEPTH`` levels, holding a NaN or Infinity token or a number
            out of range (``1e999``; the key is named: such a value would be counted but not
            averaged, or taken for identical images), not a dynaeval results file, another schema
            version, or a field missing or of the wrong type (``check_results``: the key path).
    """
    path = Path(path)
    doc = read_json(path, what="results file", fix="fix it by hand or score again")
    schema = doc.get("schema") if isinstance(doc, dict) else None
    if not isinstance(schema, str) or not schema.startswith("dynaeval/results/"):
        raise InputError("not a dynaeval results file (no 'schema' field)", path=path)
    if schema not in READS:
        raise InputError(
            f"results schema {schema!r} is not one this dynaeval reads "
            f"({' or '.join(map(repr, READS))}); score again with this version",
            path=path,
        )
    check_results(doc, path)
    _check_against_schema(doc, path)
    return _upgrade_v1(doc) if schema == SCHEMA_V1 else doc


def _v1_status(w: dict[str, Any]) -> Status:
    """The status of a warning of a ``dynaeval/results/v1`` file, from its text: the words
    dynaeval 1.x wrote for each cause. Exact for the statuses code acts on (an infinite value, a
    null summary's, the no-box headline, missing frames); the best match for the others."""
    text = w.get("reason", "")
    low = text.lower()
    rules = (
        (Status.NOTE, ("over the union of the boxes of the frames",
                       "scored on the pairs of frames that both have boxes")),
        (Status.INFINITE, ("value is +infinity", "infinite value")),
        (Status.MISSING_FRAMES, ("--allow-missing: ",)),
        (Status.NOT_CONSECUTIVE, ("not a pair of consecutive", "are consecutive",
                                  "not consecutive")),
        (Status.NO_REGION, ("frames have no box", "has no box")),  # whatever the box's cause
        (Status.UNAVAILABLE, ("not computed:", "lpips unavailable", "not installed")),
        (Status.DISABLED, ("disabled in the configuration", "focus: none",
                           "no focus regions requested")),
        (Status.NOT_A_VIDEO, ("differ", "separate test views", "separate views")),
        (Status.EMPTY_REGION, ("empty", "occluded", "no static pixel", "no moving pixel",
                               "holds no pixel")),
        (Status.NO_REGION, (NO_REGIONS, "no box", "not in the boxes file", "has a region",
                            "has no region", "no covisibility mask", "in the ground truth of "
                            "this frame")),
    )
    if low.startswith("summary is null") and "infinite value" not in low:
        return Status.UNDEFINED
    for status, marks in rules:
        if any(m.lower() in low for m in marks):
            if status is Status.MISSING_FRAMES and not text.startswith(marks[0]):
                continue
            return status
    return Status.UNDEFINED if "metric" in w else Status.NOTE


def _upgrade_v1(doc: dict[str, Any]) -> dict[str, Any]:
    """A ``dynaeval/results/v1`` document as this version's: each warning given the ``status``
    its text says (``_v1_status``), and ``summary_status`` for every null summary value (from
    its warning: infinite, else the one status of the values it averages). The one place that
    reads warning text; done once, at load."""
    warnings = [{**{k: v for k, v in w.items() if k != "reason"}, "status": _v1_status(w).value,
                 "reason": w.get("reason", "")} for w in doc["warnings"]]
    by_metric: dict[tuple[str, bool], set[str]] = {}
    for w in warnings:
        if "camera" in w and "metric" in w:
            by_metric.setdefault((w["metric"], "frame" in w), set()).add(w["status"])
    frame_keys = {k for f in doc["frames"] for k in f}
    off = switched_off(doc["settings"])  # their warnings were left out of the file
    status: dict[str, str] = {}
    for name, value in doc["summary"].items():
        if value is not None or name == "n_frames":
            continue
        own = [w for w in warnings if "camera" not in w and w.get("metric") == name
               and w["reason"].startswith("summary is null")]
        if own and own[0]["status"] == Status.INFINITE.value:
            status[name] = Status.INFINITE.value
            continue
        if name in off:
            status[name] = Status.DISABLED.value
            continue
        found = by_metric.get((name, name in frame_keys), set())
        status[name] = found.pop() if len(found) == 1 else Status.UNDEFINED.value
        for w in own:
            w["status"] = status[name]
    summary_at = list(doc).index("summary") + 1
    items = list(doc.items())
    items.insert(summary_at, ("summary_status", status))
    out = dict(items)
    out.update(schema=SCHEMA, warnings=warnings)
    return out

"""The results document (leaderboard JSON, schema ``dynaeval/results/v1``) and writing it safely.

Layout (docs/results-format.md documents every field; the JSON Schema ships as
``dynaeval/schemas/results-v1.schema.json``)::

    {"schema": "dynaeval/results/v1", "dynaeval_version": ..., "created": ISO-8601 UTC,
     "method": ..., "scene": ...,
     "inputs": {"pred": ..., "gt": ..., "n_frames": ..., "cameras": [...],
                "unscored_cameras": [...], "skipped_frames": [...]},
     "settings": {...every setting that changes a number...},
     "metrics": {name: {"higher_is_better": bool, "unit": str}},
     "frames": [{"camera", "frame", "index", "pred", "gt", <metric>: value|null, ...}],
     "cameras": {camera: {"n_frames": int, <metric>: mean|null}},
     "summary": {"n_frames": int, <metric>: mean|null},
     "counts": {<metric>: frames with a defined value},
     "timing": {"total_s": ..., "read": ..., <metric>: seconds summed over frames},
     "warnings": [{"metric", "reason", "camera"?, "frame"?}]}

Summaries are the mean of per-frame values (every frame weighs the same, cameras with more frames
weigh more), never a metric of the pooled error. A per-frame value that is undefined (empty region)
or infinite (PSNR of identical images) is ``null`` with a warning (the warning of an infinite one
says "value is +infinity": ``restore_infinite`` reads it back); a summary over frames that
include an infinite value is ``null`` too (its mean is infinite), over undefined ones it is the mean
of the defined values with ``counts`` saying how many (infinite ones are counted).
"""

from __future__ import annotations

import json
import math
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from dynaeval.deps import available, load
from dynaeval.errors import InputError
from dynaeval.io.atomic import write_text_atomic
from dynaeval.io.jsonfile import read_json
from dynaeval.metrics.registry import METRICS, SPECS
from dynaeval.report.results_check import FRAME_FIELDS, check_results

SCHEMA = "dynaeval/results/v1"

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


INFINITE_MARK = "value is +infinity"
"""What the warning of an infinite per-frame value says (``scoring.score_frame``: "prediction
equals ground truth in the scored region: value is +infinity, written as null"). A results
file stores such a value as ``null``, like an undefined one; the warning tells them apart."""


def restore_infinite(rows: list[dict[str, Any]], warnings: list[dict]) -> int:
    """Put ``inf`` back, in place, into the rows of a results file where a frame warning says
    the ``null`` stands for +infinity, so re-summarising them (``merge``) gives what the
    unsharded run gave: a null summary with its warning, and the frame counted. Returns how many
    values were restored."""
    infinite = {(w["camera"], w["frame"], w["metric"]) for w in warnings
                if "camera" in w and "frame" in w and "metric" in w
                and INFINITE_MARK in w.get("reason", "")}
    n = 0
    for row in rows:
        for name in list(row):
            if row[name] is None and (row["camera"], row["frame"], name) in infinite:
                row[name] = math.inf
                n += 1
    return n


def place_temporal(
    rows: list[dict[str, Any]], temporal: dict[str, dict[str, dict]]
) -> tuple[dict[str, dict[str, float | None]], list[dict]]:
    """Put per-pair temporal values into the frame rows, in place; return the camera-level ones.

    The value of pair (t-1, t) goes into the row of frame t (the first frame of a camera has
    none); a null value's warning takes the entry's ``pair_reasons[k]`` for pair k when given
    (a gap of missing frames, ``dynaeval.scoring``). Terms without per-pair values (``flicker``, or a term undefined for the whole camera)
    are camera-level: returned as ``{camera: {name: value}}``, with a warning when null.

    Args:
        rows: frame rows of every camera, each camera's in index order.
        temporal: per camera, ``dynaeval.metrics.temporal.temporal_metrics`` output.
    """
    camera_values: dict[str, dict[str, float | None]] = {}
    warnings: list[dict] = []
    for cam, terms in temporal.items():
        cam_rows = sorted((r for r in rows if r["camera"] == cam), key=lambda r: r["index"])
        for name, entry in terms.items():
            per_pair = entry.get("per_pair") or []
            if per_pair and len(per_pair) == len(cam_rows) - 1:
                gaps = entry.get("pair_reasons") or {}
                for k, (row, value) in enumerate(zip(cam_rows[1:], per_pair, strict=True)):
                    row[name] = value
                    if value is None:
                        warnings.append({"camera": cam, "frame": row["frame"], "metric": name,
                                         "reason": gaps.get(k) or entry.get("reason")
                                         or entry.get("pair_reason")
                                         or "undefined for the pair (previous frame, this frame)"})
                continue
            camera_values.setdefault(cam, {})[name] = entry.get("value")
            if entry.get("value") is None:
                warnings.append({"camera": cam, "metric": name,
                                 "reason": entry.get("reason") or "undefined"})
    return camera_values, warnings


def _summaries(
    rows: list[dict[str, Any]], names: list[str],
    camera_values: dict[str, dict[str, float | None]], warnings: list[dict],
) -> tuple[dict[str, dict[str, Any]], dict[str, Any], dict[str, int], list[str]]:
    """Per-camera means, the overall summary, the counts of defined values, and the names of
    the camera-level terms; a null summary adds a warning to ``warnings``."""
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
    counts: dict[str, int] = {}
    for name in names:
        summary[name], counts[name], reason = _mean([r.get(name) for r in rows])
        if reason and rows:
            warnings.append({"metric": name, "reason": f"summary is null: {reason}"})
    for name in camera_only:
        summary[name], counts[name], reason = _mean([c.get(name) for c in cameras.values()])
        if reason and rows:
            warnings.append({"metric": name, "reason": f"summary is null: {reason} (per camera)"})
    return cameras, summary, counts, camera_only


def _without_disabled_tlp(warnings: list[dict], settings: dict[str, Any]) -> list[dict]:
    """``warnings`` without those of tLP when the run switched it off (LPIPS not among the
    metrics, ``settings.temporal.tlp`` false): its null values are what was asked for, and the
    settings say so; a tLP that was on and came out null keeps its warnings."""
    if (settings.get("temporal") or {}).get("tlp") is not False:
        return warnings

    keys = set(SPECS["tlp"].keys())
    return [w for w in warnings if w.get("metric") not in keys]


NO_REGIONS = "no focus box in any of the"
"""How the headline warning of a run without any box begins (``merge`` recomputes it)."""

_NO_REGIONS_FIX = {
    "bundled": ("the bundled detector knows only dynaeval's synthetic scenes: for real footage "
                "fetch a COCO detector (dynaeval detector fetch retinanet, then --detector "
                "retinanet) or score with --focus motion"),
    "detector": ("check --classes (the detector keeps: {classes}) and that the footage is what "
                 "the detector was trained on, or score with --focus motion"),
    "boxes": ("check that the file's keys are '<camera>/<frame>' of these frames (dynaeval "
              "detect GT -o boxes.json writes them)"),
    "motion": ("motion boxes need a static camera and moving objects: score with --focus "
               "detector or --focus boxes:FILE"),
}


def no_regions_warning(regions: dict[str, Any] | None) -> dict[str, str] | None:
    """The one headline warning of a run whose ``regions`` hold no box in any frame (None
    otherwise): what found nothing, that every focused (and presence) value is null, the fix."""
    if not regions or regions.get("source") in (None, "none") or not regions.get("cameras"):
        return None
    cams = list(regions["cameras"].values())
    if any(c["frames_with_boxes"] for c in cams):
        return None
    source = regions["source"]
    key = "bundled" if source == "detector" and regions.get("bundled_detector") else source
    who = {"bundled": "the bundled synthetic-scene detector found none",
           "detector": "the detector found none", "boxes": "the boxes file lists none",
           "motion": "the motion masks hold no moving region"}[key]
    classes = ", ".join(dict.fromkeys(c for cam in cams for c in cam["boxes"])) or "?"
    nulls = "focused_* value" + (" and presence value" if source in ("detector", "boxes") else "")
    return {"reason": f"{NO_REGIONS} {sum(c['n_frames'] for c in cams)} ground-truth frames: "
                      f"{who}, so every {nulls} is null. Fix: "
                      f"{_NO_REGIONS_FIX[key].format(classes=classes)}"}


def _explained_by_no_regions(warning: dict, regions: dict[str, Any]) -> bool:
    """A run-level null-summary warning of a metric that the no-box headline explains."""
    info = METRICS.get(warning.get("metric", ""))
    if "camera" in warning or info is None or not warning["reason"].startswith("summary is null"):
        return False
    explained = {"focused", "person", "ball", *(("masked",) if regions["source"] == "motion" else ())}
    return info.variant in explained


def build_results(
    *,
    rows: list[dict[str, Any]],
    metric_names: list[str],
    method: str,
    scene: str,
    pred_dir: str,
    gt_dir: str,
    settings: dict[str, Any],
    unscored_cameras: list[str],
    skipped: list[dict],
    warnings: list[dict],
    timing: dict[str, float],
    version: str,
    temporal: dict[str, dict[str, dict]] | None = None,
    camera_values: dict[str, dict[str, float | None]] | None = None,
    shard: tuple[int, int] | None = None,
    inputs_extra: dict[str, Any] | None = None,
    regions: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Assemble the results document from per-frame rows (values may be inf; made strict here).

    Every metric that has per-frame values is summarised the same way: per camera the mean over
    its frames, overall the mean over all frames (``_mean``). ``temporal`` (per camera,
    ``temporal_metrics`` output) is first spread over the rows by ``place_temporal``: a temporal
    term's per-frame value is that of the pair (previous frame, this frame), so its summary is
    the mean over all frame pairs of all cameras. Camera-level terms (``flicker``; or
    ``camera_values`` given directly, as ``merge`` does) are summarised as the mean over cameras.
    ``regions`` (``{"source", "bundled_detector", "cameras": {camera: regions_summary}}``) is
    written as is; when no frame has a box, one headline warning (``no_regions_warning``) replaces
    the null-summary warnings of the focused and presence metrics.
    """
    warnings = list(warnings)
    camera_values = {c: dict(v) for c, v in (camera_values or {}).items()}
    if temporal:
        placed, more = place_temporal(rows, temporal)
        warnings.extend(more)
        for cam, values in placed.items():
            camera_values.setdefault(cam, {}).update(values)
    names = list(metric_names)
    for row in rows:
        for k, v in row.items():
            if k not in FRAME_FIELDS and k not in names and (v is None or isinstance(v, float)):
                names.append(k)
    cameras, summary, counts, camera_only = _summaries(rows, names, camera_values, warnings)
    warnings = _without_disabled_tlp(warnings, settings)
    headline = no_regions_warning(regions)
    if headline is not None:
        warnings = [headline, *(w for w in warnings if not _explained_by_no_regions(w, regions))]
    metric_names = [*names, *camera_only]
    frames = [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in rows
    ]
    doc = {
        "schema": SCHEMA,
        "dynaeval_version": version,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "method": method,
        "scene": scene,
        "inputs": {
            "pred": pred_dir,
            "gt": gt_dir,
            "n_frames": len(rows),
            "cameras": list(cameras),
            "unscored_cameras": list(unscored_cameras),
            "skipped_frames": list(skipped),
            **({"shard": {"index": shard[0], "count": shard[1]}} if shard else {}),
            **(inputs_extra or {}),
        },
        "settings": settings,
        "metrics": {n: _direction(n) for n in metric_names},
        "frames": frames,
        "cameras": cameras,
        "summary": summary,
        "counts": counts,
        "timing": {k: round(v, 6) for k, v in timing.items()},
        "warnings": warnings,
        **({"regions": regions} if regions is not None else {}),
    }
    return strict(doc)


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


def schema_path() -> Path:
    """Path of the JSON Schema of the results document shipped in the package."""
    return Path(__file__).resolve().parent.parent / "schemas" / "results-v1.schema.json"


def _check_against_schema(doc: dict[str, Any], path: Path) -> None:
    """With jsonschema installed (a test dependency), also hold ``doc`` to the shipped schema:
    an extra check beside ``check_results``, which needs no package."""
    if not available("jsonschema"):  # optional: check_results always runs
        return
    jsonschema = load("jsonschema")
    schema = json.loads(schema_path().read_text(encoding="utf-8"))
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
    if schema != SCHEMA:
        raise InputError(
            f"results schema {schema!r} is not the one this dynaeval reads ({SCHEMA!r}); "
            "score again with this version",
            path=path,
        )
    check_results(doc, path)
    _check_against_schema(doc, path)
    return doc

"""Merging the results of shards (``dynaeval score --shard I/N``) into the unsharded results.

Shards split a run by whole cameras (``dynaeval.io.frames.select_shard``), so every per-frame and
per-camera number of a shard is the unsharded one; merging recomputes the summaries from them with
the same function (``build_results``), which makes the merged numbers equal to an unsharded run's,
bit for bit. A shard file stores an infinite per-frame value (PSNR of a frame equal to its ground
truth) as ``null`` like an undefined one; its frame warning's status (``infinite``) says which,
and ``restore_infinite`` puts ``inf`` back first, so the summaries, counts and warnings are the
unsharded ones too. The run-level warnings that ``build_results`` makes again (of a null
summary, the no-box headline, the missing frames) are told apart by their status and place,
never by their text; shards written as ``dynaeval/results/v1`` get their statuses at load.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import Status, status_of
from dynaeval.io.frames import missing_frames_warning, natural_key
from dynaeval.metrics.registry import METRICS
from dynaeval.report.results import (
    FRAME_FIELDS,
    RunRecord,
    build_results,
    is_no_regions_warning,
    load_results,
    restore_infinite,
)


def merge_results(paths: list[str | Path]) -> dict[str, Any]:
    """Merge the results files of all shards of one run.

    Raises:
        InputError: a file is unreadable, damaged (``load_results``) or not a shard, holds a
            metric this dynaeval does not know, the shards come from different runs
            (method, scene, inputs or settings differ), a shard is missing or given twice,
            two files hold the same camera (both named), or a shard's frame rows disagree with
            its own counts (a frame twice, a row removed; the file and frame named).
    """
    if not paths:
        raise InputError("merge needs the results files of the shards")
    docs = [(Path(p), load_results(p)) for p in paths]
    _check_shards(docs)
    first = docs[0][1]
    shards = [doc for _, doc in docs]
    rows = _merged_rows(shards)
    frame_names = {k for r in rows for k in r if k not in FRAME_FIELDS}
    warnings = _merged_warnings(shards)
    skipped = sorted((s for doc in shards for s in doc["inputs"]["skipped_frames"]),
                     key=lambda s: (natural_key(s["camera"]), natural_key(s["frame"])))
    pairs = _merged_temporal_pairs(shards, skipped, first["settings"], warnings)
    return build_results(RunRecord(
        rows=rows,
        metric_names=[n for n in first["metrics"] if n in frame_names],
        method=first["method"],
        scene=first["scene"],
        pred_dir=first["inputs"]["pred"],
        gt_dir=first["inputs"]["gt"],
        settings=first["settings"],
        unscored_cameras=first["inputs"]["unscored_cameras"],
        skipped=skipped,
        warnings=warnings,
        timing=_summed_timing(shards),
        version=first["dynaeval_version"],
        camera_values={
            cam: {k: v for k, v in entry.items() if k != "n_frames" and k not in frame_names}
            for doc in shards for cam, entry in doc["cameras"].items()
        },
        regions=_merged_regions(shards),
        temporal_parts={c: t for doc in shards for c, t in doc.get("temporal_parts", {}).items()},
        inputs_extra={"temporal_pairs": pairs} if pairs else None,
    ))


def _check_shards(docs: list[tuple[Path, dict[str, Any]]]) -> None:
    """None; raises InputError unless the ``(path, results)`` pairs are every shard of one split
    of one run, each once, with known metrics, self-consistent rows and cameras of their own."""
    first_path, first = docs[0]
    counts = set()
    seen: dict[int, Path] = {}
    owner: dict[str, Path] = {}
    for path, doc in docs:
        shard = doc["inputs"].get("shard")
        if not shard:
            raise InputError("not a shard (scored without --shard I/N)", path=path)
        counts.add(shard["count"])
        if shard["index"] in seen:
            raise InputError(f"shard {shard['index']}/{shard['count']} given twice: also "
                             f"{seen[shard['index']]}", path=path)
        seen[shard["index"]] = path
        _check_metrics_known(path, doc)
        _check_rows(path, doc)
        _claim_cameras(path, doc, owner)
        _check_same_run(path, doc, first_path, first)
    if len(counts) != 1:
        raise InputError(f"shards of different splits: I/N with N in {sorted(counts)}")
    (count,) = counts
    missing = sorted(set(range(1, count + 1)) - set(seen))
    if missing:
        raise InputError(f"shards missing: {', '.join(f'{i}/{count}' for i in missing)}")


def _check_metrics_known(path: Path, doc: dict[str, Any]) -> None:
    """None; raises InputError naming the first metric of the shard the registry does not know."""
    unknown = next((n for n in doc["metrics"] if n not in METRICS), None)
    if unknown is not None:
        raise InputError(f"metric {unknown!r} (in 'metrics') is not one this dynaeval knows, "
                         "and merge takes each metric's direction and unit from its registry: "
                         "install the package that adds it (a plugin?) or remove it",
                         path=path)


def _claim_cameras(path: Path, doc: dict[str, Any], owner: dict[str, Path]) -> None:
    """None; records the shard's cameras in ``owner`` (camera -> file), raises InputError for a
    camera another shard already holds."""
    cameras = [*doc["inputs"]["cameras"], *(f["camera"] for f in doc["frames"])]
    for cam in dict.fromkeys(cameras):
        if cam in owner:
            raise InputError(f"camera {cam!r} is in two shards: {owner[cam]} and {path}; "
                             "shards of one run never overlap (score each I/N once)",
                             path=path)
        owner[cam] = path


def _check_same_run(path: Path, doc: dict[str, Any], first_path: Path,
                    first: dict[str, Any]) -> None:
    """None; raises InputError naming the field where the shard's run differs from the first's."""
    for key in ("method", "scene", "settings", "dynaeval_version"):
        if doc[key] != first[key]:
            raise InputError(f"shards of different runs: '{key}' differs from {first_path}",
                             path=path)
    for key in ("pred", "gt", "unscored_cameras"):
        if doc["inputs"][key] != first["inputs"][key]:
            raise InputError(f"shards of different runs: inputs.{key} differs from "
                             f"{first_path}", path=path)


def _merged_rows(docs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Copies of the shards' frame rows, infinite values put back, in natural camera then frame
    index order."""
    rows = [dict(f) for doc in docs for f in doc["frames"]]
    restore_infinite(rows, [w for doc in docs for w in doc["warnings"]])
    rows.sort(key=lambda r: (natural_key(r["camera"]), r["index"]))
    return rows


def _merged_warnings(docs: list[dict[str, Any]]) -> list[dict]:
    """The shards' warnings: every camera's, and each run-level one once but for those
    ``build_results`` makes again."""
    warnings: list[dict] = []
    for doc in docs:
        for w in doc["warnings"]:
            if "camera" in w or (not _made_again(w, doc) and w not in warnings):
                warnings.append(w)
    return warnings


def _summed_timing(docs: list[dict[str, Any]]) -> dict[str, float]:
    """Seconds per phase, summed over the shards."""
    timing: dict[str, float] = {}
    for doc in docs:
        for k, v in doc["timing"].items():
            timing[k] = timing.get(k, 0.0) + v
    return timing


def _check_rows(path: Path, doc: dict[str, Any]) -> None:
    """A shard's frame rows agree with its own counts: each frame once, every row's camera one
    of its ``cameras`` with as many rows as its ``n_frames``, ``summary.n_frames`` rows in all.
    Raises InputError naming the file and the frame or camera (a duplicated row was counted
    twice in the merged summary, a removed one merged as a frame fewer)."""
    seen: set[tuple[str, str]] = set()
    per_camera: dict[str, int] = {}
    for row in doc["frames"]:
        key = (row["camera"], row["frame"])
        if key in seen:
            raise InputError(f"frame {row['camera']}/{row['frame']} has two rows in 'frames'; a "
                             "shard holds each frame once (a damaged or hand-edited file?)",
                             path=path)
        seen.add(key)
        if row["camera"] not in doc["cameras"]:
            raise InputError(f"frame {row['camera']}/{row['frame']}: its camera is not in "
                             "'cameras' (a damaged or hand-edited file?)", path=path)
        per_camera[row["camera"]] = per_camera.get(row["camera"], 0) + 1
    for cam, entry in doc["cameras"].items():
        if per_camera.get(cam, 0) != entry["n_frames"]:
            raise InputError(f"camera {cam!r} has {per_camera.get(cam, 0)} frame rows but "
                             f"cameras.{cam}.n_frames says {entry['n_frames']} (a damaged or "
                             "hand-edited file?)", path=path)
    if len(doc["frames"]) != doc["summary"].get("n_frames", len(doc["frames"])):
        raise InputError(f"'frames' holds {len(doc['frames'])} rows but summary.n_frames says "
                         f"{doc['summary']['n_frames']} (a damaged or hand-edited file?)",
                         path=path)


def _made_again(w: dict, doc: dict[str, Any]) -> bool:
    """A run-level warning of a shard that ``build_results`` makes again from the merged rows:
    of a null summary (its metric is in ``summary_status``) or the no-box headline."""
    return w.get("metric") in doc["summary_status"] or is_no_regions_warning(w)


def _merged_temporal_pairs(docs: list[dict[str, Any]], skipped: list[dict], settings: dict,
                           warnings: list[dict]) -> dict[str, dict]:
    """The shards' ``inputs.temporal_pairs``, cameras in natural order; the shards' warnings
    naming their missing frames replaced, in place, by the one the unsharded run gives."""
    pairs = {c: v for d in docs for c, v in d["inputs"].get("temporal_pairs", {}).items()}
    pairs = {c: pairs[c] for c in sorted(pairs, key=natural_key)}
    warnings[:] = [w for w in warnings
                   if "camera" in w or status_of(w) is not Status.MISSING_FRAMES]
    gaps: dict[str, dict] = {}
    for s in skipped:
        gaps.setdefault(s["camera"], {"missing_frames": [], **pairs.get(s["camera"], {})})
        gaps[s["camera"]]["missing_frames"].append(s["frame"])
    if gaps:
        warnings.append(missing_frames_warning(gaps, "temporal" in settings))
    return pairs


def _merged_regions(docs: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The shards' ``regions``: their common fields and every shard's cameras, in natural order."""
    with_regions = [d["regions"] for d in docs if d.get("regions")]
    if not with_regions:
        return None
    cameras = {c: v for r in with_regions for c, v in r["cameras"].items()}
    return {**{k: v for k, v in with_regions[0].items() if k != "cameras"},
            "cameras": {c: cameras[c] for c in sorted(cameras, key=natural_key)}}

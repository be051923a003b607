"""Leaderboards: many results files (methods x scenes) -> one table with bootstrap intervals.

``build_leaderboard(paths)`` reads results files (``dynaeval/results/v2``; v1 ones read as v2),
refuses to mix files whose number-changing settings differ (unless ``force``), and returns a
leaderboard document (``dynaeval/leaderboard/v1``, fields in docs/results-format.md):

* per (method, scene): the file's summary value of each metric (mean of per-frame values) and a
  95 % bootstrap interval over its frames;
* per method, scene ``"(all)"``: the mean of its per-scene means (every scene weighs the same,
  as NeRF papers average their per-scene tables), with an interval from the same bootstrap
  replicates (frames resampled within each scene, the replicate scene means averaged).

Bootstrap: percentile method, ``n_boot = 1000`` replicates, frames drawn with replacement; the
generator is seeded from ``seed`` and the (method, scene, metric) names, so an interval does not
depend on which other files are combined or in what order. Frames of a video are correlated, so the
interval is the spread of a per-frame average, not of a new recording: read it as a lower bound.

A metric without per-frame values in ``frames`` (``flicker``, ``tlp``: one value per camera) gets
its mean and no interval (``null``); per-pair temporal values stored on the later frame of each
pair (``warp_error``, ``tof``) are resampled like any per-frame value.
"""

from __future__ import annotations

import csv
import io
import math
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.core.version import VERSION
from dynaeval.io.run_costs import RunCosts
from dynaeval.metrics.registry import METRICS, SPECS
from dynaeval.report.results import load_results, strict

COSTS = {"train_minutes": ("train min", False), "render_fps": ("render fps", True),
         "memory_gb": ("memory GB", False)}
"""What a method costs, as its authors or its runs report it (SUITE.toml ``[costs.METHOD]``, or
its run folder where a peer tool writes it: ``dynaeval.io.run_costs``): field -> (column
heading, higher is better). Shown beside the metrics, blank when not given, never guessed."""

SCHEMA = "dynaeval/leaderboard/v1"
ALL_SCENES = "(all)"
FORMATS = ("md", "csv", "json", "html")
GROUP_BY = ("method", "scene")
"""What the rows of a rendered leaderboard are grouped by (``dynaeval leaderboard --by``)."""

RUN_IGNORED_SETTINGS = (
    "allow_missing",
    "focus.boxes_file.path",
    "focus.detector.model",
    "focus.detector.settings.model",
    "focus.detector.settings.device",
    "focus.detector.onnxruntime",
    "focus.detector.outputs_note",
    "masks.folder",
    "prepared.path",
    "prepared.id",
)
"""Run settings that never change a number (paths, devices, the text saying which detector
output was taken as what: ``focus.detector.outputs`` is compared; a prepared ground truth,
``--prepared``, which gives the same numbers): not compared."""


def _ignored_settings() -> tuple[str, ...]:
    return RUN_IGNORED_SETTINGS + tuple(
        f"{s.name}.{f}" for s in SPECS.values() for f in s.ignored_settings)


IGNORED_SETTINGS = _ignored_settings()
"""Settings that never change a number (paths, devices, whether a metric ran): not compared.
The metrics' own come from the registry (``MetricSpec.ignored_settings``)."""

SCENE_SETTINGS = ("focus.boxes_file.",)
"""Settings that belong to a scene (its boxes file): compared only between files of one scene."""


@dataclass(frozen=True)
class BootstrapConfig:
    """How confidence intervals are drawn."""

    n_boot: int = 1000
    """Bootstrap replicates."""
    confidence: float = 0.95
    """Two-sided level; the interval is the (1-c)/2 and (1+c)/2 percentiles of replicate means."""
    seed: int = 0
    """Base seed; each (method, scene, metric) gets its own generator derived from it."""

    def describe(self) -> dict[str, Any]:
        """Settings for the leaderboard JSON."""
        return {
            "method": "percentile",
            "n_boot": self.n_boot,
            "confidence": self.confidence,
            "seed": self.seed,
            "unit": "frames, resampled with replacement within each scene",
        }


def schema_path() -> Path:
    """Path of the JSON Schema of the leaderboard document shipped in the package."""
    return Path(__file__).resolve().parent.parent / "schemas" / "leaderboard-v1.schema.json"


def flatten_settings(settings: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested settings -> ``{"ssim.win_size": 11, ...}`` (lists kept as values)."""
    out: dict[str, Any] = {}
    for key, value in settings.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten_settings(value, name + "."))
        else:
            out[name] = value
    return out


def _skipped_sections(a: dict[str, Any], b: dict[str, Any], prefix: str = "") -> list[str]:
    """Sections, at any depth, whose metrics exist in at most one of the files, so there is
    nothing to compare: a section present in one file only (``temporal`` of a ``--no-temporal``
    run, ``focus.motion`` of a ``--no-masked`` one) or switched off in either (``lpips.enabled``
    false: LPIPS did not run). Sections present in both are searched the same way."""
    out = []
    for key in {*a, *b}:
        va, vb = a.get(key), b.get(key)
        if isinstance(va, dict) or isinstance(vb, dict):
            name = f"{prefix}{key}."
            if not isinstance(va, dict) or not isinstance(vb, dict):
                if va is None or vb is None:
                    out.append(name)
            elif va.get("enabled") is False or vb.get("enabled") is False:
                out.append(name)
            else:
                out.extend(_skipped_sections(va, vb, name))
    return out


def settings_differences(
    a: dict[str, Any], b: dict[str, Any], *, only: tuple[str, ...] | None = None,
    skip: tuple[str, ...] = (),
) -> list[tuple[str, Any, Any]]:
    """Number-changing settings that differ between two results' ``settings``:
    ``[(field, value in a, value in b)]`` (``None`` where a field is absent), in field order.

    Not compared: ``IGNORED_SETTINGS`` and sections (at any depth: ``temporal``,
    ``focus.motion``) of metrics that ran in at most one of the two files (a section absent from
    one, or with ``enabled: false`` in either); fields starting
    with a prefix in ``skip``; with ``only``, every field not starting with one of its prefixes."""
    fa, fb = flatten_settings(a), flatten_settings(b)
    skipped = (*_skipped_sections(a, b), *skip)
    out = []
    for key in [*fa, *(k for k in fb if k not in fa)]:
        if key in IGNORED_SETTINGS or key.startswith(skipped):
            continue
        if only is not None and not key.startswith(only):
            continue
        if fa.get(key) != fb.get(key):
            out.append((key, fa.get(key), fb.get(key)))
    return out


def _rng(seed: int, *names: str) -> np.random.Generator:
    return np.random.default_rng([seed, *(zlib.crc32(n.encode("utf-8")) for n in names)])


def _percentiles(means: np.ndarray, confidence: float) -> tuple[float, float]:
    lo, hi = np.percentile(means, [50 * (1 - confidence), 50 * (1 + confidence)])
    return float(lo), float(hi)


def bootstrap_means(
    values: np.ndarray, config: BootstrapConfig, rng: np.random.Generator
) -> np.ndarray:
    """Means of ``config.n_boot`` resamples (with replacement) of ``values``.

    Args:
        values: (N,) float64 per-frame values, all finite, N >= 1.

    Returns:
        (n_boot,) float64 replicate means.
    """
    n = len(values)
    idx = rng.integers(0, n, size=(config.n_boot, n))
    return values[idx].mean(axis=1)


def _frame_values(doc: dict[str, Any], metric: str) -> np.ndarray:
    vals = [f.get(metric) for f in doc["frames"]]
    return np.array([v for v in vals if v is not None], dtype=np.float64)


def _metric_names(docs: list[dict[str, Any]]) -> list[str]:
    names: list[str] = []
    for d in docs:
        for n in d["metrics"]:
            if n not in names:
                names.append(n)
    return names


def _check(docs: list[dict[str, Any]], paths: list[str], force: bool) -> list[dict[str, Any]]:
    seen: dict[tuple[str, str], str] = {}
    for d, p in zip(docs, paths, strict=True):
        key = (d["method"], d["scene"])
        if key in seen:
            raise InputError(
                f"method {key[0]!r} on scene {key[1]!r} appears twice: in {seen[key]} and {p}; "
                "pass each (method, scene) once (rename one with score --method/--scene)",
                path=p,
            )
        seen[key] = p
    forced = []
    first_of_scene: dict[str, tuple[dict[str, Any], str]] = {}
    for d, p in zip(docs, paths, strict=True):
        first_of_scene.setdefault(d["scene"], (d, p))
    for d, p in zip(docs[1:], paths[1:], strict=True):
        ref, ref_path = docs[0], paths[0]
        diffs = settings_differences(ref["settings"], d["settings"], skip=SCENE_SETTINGS)
        if not diffs:
            ref, ref_path = first_of_scene[d["scene"]]
            diffs = settings_differences(ref["settings"], d["settings"], only=SCENE_SETTINGS)
        if not diffs:
            continue
        if not force:
            key, va, vb = diffs[0]
            more = f" (and {len(diffs) - 1} more)" if len(diffs) > 1 else ""
            raise InputError(
                f"incompatible settings: {key!r} is {va!r} in {ref_path} but {vb!r} in {p}{more}; "
                "their numbers are not comparable. Score again with the same settings, or pass "
                "--force to combine them anyway (the differences are recorded)",
                path=p,
            )
        forced.extend({"field": k, "file_a": ref_path, "value_a": va, "file_b": p, "value_b": vb}
                      for k, va, vb in diffs)
    return forced


def _scene_entry(d: dict[str, Any], n: str, bootstrap: BootstrapConfig,
                 ) -> tuple[dict[str, Any], np.ndarray | None]:
    """One file's value of metric ``n`` with its bootstrap interval over frames, and the
    replicate means (None when the metric has no finite per-frame values)."""
    mean = d["summary"].get(n)
    entry: dict[str, Any] = {"mean": mean, "ci_low": None, "ci_high": None,
                             "n": d["counts"].get(n, 0)}
    reps = None
    per_frame = n in d["metrics"] and any(n in f for f in d["frames"])
    if mean is not None and per_frame:
        vals = _frame_values(d, n)
        if len(vals) and np.isfinite(vals).all():
            reps = bootstrap_means(vals, bootstrap, _rng(bootstrap.seed, d["method"], d["scene"], n))
            entry["ci_low"], entry["ci_high"] = _percentiles(reps, bootstrap.confidence)
    return entry, reps


def _overall_entry(means: list[float | None], reps: list[np.ndarray | None],
                   confidence: float) -> dict[str, Any]:
    """Mean of per-scene means, its interval from the scenes' replicates averaged."""
    entry: dict[str, Any] = {"mean": None, "ci_low": None, "ci_high": None, "n": len(means)}
    if means and all(m is not None for m in means):
        entry["mean"] = math.fsum(means) / len(means)  # type: ignore[arg-type]
        if all(r is not None for r in reps):
            stacked = np.mean(np.stack(reps), axis=0)  # type: ignore[arg-type]
            entry["ci_low"], entry["ci_high"] = _percentiles(stacked, confidence)
    return entry


def _board_rows(docs: list[dict[str, Any]], paths: list[str], names: list[str],
                bootstrap: BootstrapConfig) -> tuple[list[dict[str, Any]], list[str], list[str]]:
    """One row per file, then one ``(all)`` row per method; and the methods and scenes in order."""
    rows: list[dict[str, Any]] = []
    replicates: dict[tuple[str, str], list[np.ndarray | None]] = {}
    scene_means: dict[tuple[str, str], list[float | None]] = {}
    methods = list(dict.fromkeys(d["method"] for d in docs))
    scenes = list(dict.fromkeys(d["scene"] for d in docs))
    for d, p in zip(docs, paths, strict=True):
        row: dict[str, Any] = {"method": d["method"], "scene": d["scene"],
                               "n_frames": d["summary"]["n_frames"], "file": p, "values": {}}
        for n in names:
            row["values"][n], reps = _scene_entry(d, n, bootstrap)
            replicates.setdefault((d["method"], n), []).append(reps)
            scene_means.setdefault((d["method"], n), []).append(row["values"][n]["mean"])
        rows.append(row)
    for method in methods:
        own = [r for r in rows if r["method"] == method]
        rows.append({"method": method, "scene": ALL_SCENES,
                     "n_frames": sum(r["n_frames"] for r in own), "n_scenes": len(own),
                     "values": {n: _overall_entry(scene_means[(method, n)],
                                                  replicates[(method, n)], bootstrap.confidence)
                                for n in names}})
    return rows, methods, scenes


def _selected_metrics(docs: list[dict[str, Any]], metrics: list[str] | None) -> list[str]:
    names = _metric_names(docs)
    if metrics is None:
        return names
    unknown = [m for m in metrics if m not in names]
    if unknown:
        raise InputError(f"metrics not in any results file: {', '.join(unknown)}; "
                         f"available: {', '.join(names)}")
    return list(metrics)


def _default_sort(names: list[str]) -> str:
    """The first whole-frame metric of ``names`` (else the first)."""
    return next((n for n in names if n in METRICS and METRICS[n].variant == "whole"), names[0])


def _ranking(rows: list[dict[str, Any]], info: dict[str, Any], sort: str) -> dict[str, Any]:
    """Each row's ``rank`` within its scene by ``sort`` (1 the best, ties share; None without a
    value), and per scene and metric the best method(s) and whether the runner-up's mean lies
    inside the best's bootstrap interval (their difference is within the noise)."""
    best: dict[str, dict[str, Any]] = {}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == scene]
        for n in info:
            sign = 1.0 if info[n]["higher_is_better"] else -1.0
            scored = sorted((r for r in mine if r["values"][n]["mean"] is not None),
                            key=lambda r: -sign * r["values"][n]["mean"])
            if n == sort:
                for r in mine:
                    mean = r["values"][n]["mean"]
                    r["rank"] = None if mean is None else 1 + sum(
                        sign * (o["values"][n]["mean"] - mean) > 0 for o in scored)
            if not scored:
                continue
            top = scored[0]["values"][n]
            winners = [r["method"] for r in scored if r["values"][n]["mean"] == top["mean"]]
            rest = [r for r in scored if r["method"] not in winners]
            inside = None
            if rest and top["ci_low"] is not None:
                inside = bool(top["ci_low"] <= rest[0]["values"][n]["mean"] <= top["ci_high"])
            best.setdefault(scene, {})[n] = {"methods": winners,
                                              "next": rest[0]["method"] if rest else None,
                                              "next_within_interval": inside}
    return {"metric": sort, "higher_is_better": info[sort]["higher_is_better"], "best": best}


def _row_costs(rows: list[dict[str, Any]], costs: dict[str, dict[str, float]],
               run_costs: dict[tuple[str, str], RunCosts]) -> None:
    """Each row's ``costs``: a (method, scene) row the method's given costs, else what its run
    folder says; an ``(all)`` row the given costs, else the mean over the method's scenes of a
    figure every one of them has. Rows without any figure get none."""
    for r in rows:
        if r["scene"] != ALL_SCENES:
            found = run_costs.get((r["method"], r["scene"]))
            mine = {**(found.costs if found else {}), **costs.get(r["method"], {})}
        else:
            scenes = [o.get("costs", {}) for o in rows
                      if o["method"] == r["method"] and o["scene"] != ALL_SCENES]
            mine = {k: math.fsum(c[k] for c in scenes) / len(scenes) for k in COSTS
                    if scenes and all(k in c for c in scenes)}
        if mine:
            r["costs"] = {k: mine[k] for k in COSTS if k in mine}


def build_leaderboard(
    paths: list[str | Path],
    *,
    force: bool = False,
    bootstrap: BootstrapConfig | None = None,
    metrics: list[str] | None = None,
    sort: str | None = None,
    costs: dict[str, dict[str, float]] | None = None,
    run_costs: dict[tuple[str, str], RunCosts] | None = None,
) -> dict[str, Any]:
    """Combine results files into a leaderboard document (layout: module docstring).

    Args:
        paths: results JSON files, one per (method, scene).
        force: combine even when number-changing settings differ (listed under ``forced``).
        bootstrap: interval settings (default: percentile, 1000 replicates, 95 %, seed 0).
        metrics: metric names to keep (default: every metric of any file, in file order).
        sort: the metric that ranks the methods of each scene (``rank``; default the first
            whole-frame metric), in its registry direction.
        costs: method -> its ``COSTS`` fields given (train minutes, render fps, memory GB), for
            the cost columns and the suite page's quality-vs-cost plot; they win over
            ``run_costs``.
        run_costs: (method, scene) -> what the pair's run folder says it cost
            (``io.run_costs.read_run_costs``).

    Raises:
        InputError: no file, unreadable or old-schema file, a (method, scene) pair twice,
            incompatible settings without ``force``, or an unknown metric asked for (or to
            sort by).
    """
    if not paths:
        raise InputError("leaderboard needs at least one results file")
    bootstrap = _checked_bootstrap(bootstrap)
    str_paths = [str(p) for p in paths]
    docs = [load_results(p) for p in str_paths]
    forced = _check(docs, str_paths, force)
    names, info, sort = _table_metrics(docs, metrics, sort)
    rows, methods, scenes = _board_rows(docs, str_paths, names, bootstrap)
    _row_costs(rows, costs or {}, run_costs or {})
    return strict({
        "schema": SCHEMA, "dynaeval_version": VERSION, "methods": methods, "scenes": scenes,
        "metrics": info, "settings": docs[0]["settings"], "forced": forced,
        "bootstrap": bootstrap.describe(),
        "overall": "mean of per-scene means (every scene weighs the same)",
        "sources": _sources(docs, str_paths), "rows": rows,
        "ranking": _ranking(rows, {n: info[n] for n in names if n in info}, sort),
        **_cost_sections(methods, costs, run_costs or {}),
        "notes": _coverage_notes(rows, methods),
    })


def _checked_bootstrap(bootstrap: BootstrapConfig | None) -> BootstrapConfig:
    """The bootstrap settings (the defaults for None); raises InputError for a replicate count
    under 1 or a confidence outside (0, 1)."""
    bootstrap = bootstrap or BootstrapConfig()
    if bootstrap.n_boot < 1 or not 0 < bootstrap.confidence < 1:
        raise InputError(
            f"bootstrap needs n_boot >= 1 and 0 < confidence < 1, got {bootstrap.n_boot} and "
            f"{bootstrap.confidence}"
        )
    return bootstrap


def _table_metrics(docs: list[dict[str, Any]], metrics: list[str] | None,
                   sort: str | None) -> tuple[list[str], dict[str, Any], str]:
    """The table's metric names, {name: its ``metrics`` entry of the first file that has it},
    and the metric that ranks (``sort``, default ``_default_sort``); raises InputError for an
    unknown one."""
    names = _selected_metrics(docs, metrics)
    info: dict[str, Any] = {}
    for d in docs:
        for n in names:
            if n in d["metrics"]:
                info.setdefault(n, d["metrics"][n])
    sort = sort or _default_sort(names)
    if sort not in names:
        raise InputError(f"cannot sort by {sort!r}: not a metric of the table{did_you_mean(sort, names)}; "
                         f"available: {', '.join(names)}")
    return names, info, sort


def _sources(docs: list[dict[str, Any]], paths: list[str]) -> list[dict[str, str]]:
    """``sources``: each file with its method, scene, dynaeval version and time of scoring."""
    return [{"file": p, "method": d["method"], "scene": d["scene"],
             "dynaeval_version": d["dynaeval_version"], "created": d["created"]}
            for d, p in zip(docs, paths, strict=True)]


def _cost_sections(methods: list[str], costs: dict[str, dict[str, float]] | None,
                   run_costs: dict[tuple[str, str], RunCosts]) -> dict[str, Any]:
    """``costs`` (the figures given, per method) and ``cost_sources`` (the run folders that
    said theirs), each only when there is one."""
    return {
        **({"costs": {m: dict(costs[m]) for m in methods if costs.get(m)}} if costs else {}),
        **({"cost_sources": [{"method": m, "scene": sc, "file": rc.source}
                              for (m, sc), rc in run_costs.items() if rc.costs]}
           if any(rc.costs for rc in run_costs.values()) else {}),
    }


def _coverage_notes(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """``notes``: one when the methods cover different sets of scenes, else none."""
    covered = {m: sorted(r["scene"] for r in rows if r["method"] == m and r["scene"] != ALL_SCENES)
               for m in methods}
    notes = []
    if len({tuple(v) for v in covered.values()}) > 1:
        notes.append("methods cover different scenes: their (all) rows average different scene "
                     "sets and are not comparable")
    return notes


# -- rendering --------------------------------------------------------------------------------


def _ordered_rows(board: dict[str, Any], by: str) -> list[dict[str, Any]]:
    if by not in GROUP_BY:
        raise InputError(f"--by must be 'method' or 'scene', got {by!r}")
    scene_order = {s: i for i, s in enumerate([*board["scenes"], ALL_SCENES])}
    method_order = {m: i for i, m in enumerate(board["methods"])}
    if "ranking" in board:  # methods by their overall rank (ties: input order)
        overall = {r["method"]: r.get("rank") or math.inf for r in board["rows"]
                   if r["scene"] == ALL_SCENES}
        method_order = {m: (overall.get(m, math.inf), i) for m, i in method_order.items()}
        if by == "scene":
            key = lambda r: (scene_order[r["scene"]], r.get("rank") or math.inf,  # noqa: E731
                             method_order[r["method"]])
            return sorted(board["rows"], key=key)
    if by == "method":
        key = lambda r: (method_order[r["method"]], scene_order[r["scene"]])  # noqa: E731
    else:
        key = lambda r: (scene_order[r["scene"]], method_order[r["method"]])  # noqa: E731
    return sorted(board["rows"], key=key)


def _fmt(name: str, v: float | None) -> str:
    """dB values with 2 decimals, others with 4, small errors (< 0.01) with 3 significant digits
    (units from the registry)."""
    if v is None:
        return "n/a"
    if name in METRICS and METRICS[name].unit == "dB":
        return f"{v:.2f}"
    return f"{v:.4f}" if abs(v) >= 0.01 or v == 0 else f"{v:.3g}"


def _cell(name: str, entry: dict[str, Any], mark: str = "") -> str:
    """Mean [interval]; ``mark`` the best value's marker (``*`` ... ``*``, ``≈`` when the
    runner-up is inside its interval), as ``_best_mark`` gives it."""
    text = _fmt(name, entry["mean"])
    if mark:
        text = f"**{text}**{'≈' if mark == 'tie' else ''}"
    if entry["ci_low"] is not None:
        text += f" [{_fmt(name, entry['ci_low'])}, {_fmt(name, entry['ci_high'])}]"
    return text


def _best_mark(board: dict[str, Any], row: dict[str, Any], name: str) -> str:
    """``best``, ``tie`` (best, the runner-up's mean inside its interval) or ``""``."""
    best = board.get("ranking", {}).get("best", {}).get(row["scene"], {}).get(name)
    if not best or row["method"] not in best["methods"]:
        return ""
    return "tie" if best["next_within_interval"] else "best"


def _costs_of(row: dict[str, Any]) -> list[float | None]:
    """The row's ``COSTS`` values (None where not given)."""
    mine = row.get("costs", {})
    return [mine.get(k) for k in COSTS]


def _has_costs(board: dict[str, Any]) -> bool:
    return any(r.get("costs") for r in board["rows"])


def _cost_header(board: dict[str, Any]) -> list[str]:
    """The cost columns' headings, when any row has a cost."""
    return [head for head, _ in COSTS.values()] if _has_costs(board) else []


def _cost_cells(board: dict[str, Any], row: dict[str, Any]) -> list[str]:
    """The row's cost cells (blank where not given), when the board has cost columns."""
    if not _has_costs(board):
        return []
    return ["" if v is None else f"{v:g}" for v in _costs_of(row)]


def _rank(row: dict[str, Any]) -> str:
    return "" if row.get("rank") is None else str(row["rank"])


def _header(board: dict[str, Any]) -> list[str]:
    cols = []
    for n, inf in board["metrics"].items():
        arrow = "↑" if inf["higher_is_better"] else "↓"
        cols.append(f"{n} {arrow}")
    return cols


def md_cell(text: str) -> str:
    """``text`` as one Markdown table cell: ``|`` escaped, line breaks and other control
    characters as spaces (a name with either put numbers under the wrong headings)."""
    clean = "".join(" " if ch < " " or ch == "\x7f" else ch for ch in str(text))
    return clean.replace("\\", "\\\\").replace("|", "\\|")


def csv_text(text: str) -> str:
    """A text cell for a CSV a spreadsheet opens: one starting with ``=``, ``+``, ``-``, ``@``
    (or a tab or carriage return) gets a leading ``'`` so it is not run as a formula (OWASP's
    CSV-injection rule). Numbers are written as numbers, never through this."""
    text = str(text)
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def to_markdown(board: dict[str, Any], by: str = "method") -> str:
    """The leaderboard as a Markdown table: mean [95 % interval] per metric; names escaped
    (``md_cell``)."""
    head = ["method", "scene", "rank", "frames", *_header(board), *_cost_header(board)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in _ordered_rows(board, by):
        cells = [md_cell(r["method"]), md_cell(r["scene"]), _rank(r), str(r["n_frames"])]
        cells += [_cell(n, r["values"][n], _best_mark(board, r, n)) for n in board["metrics"]]
        cells += _cost_cells(board, r)
        lines.append("| " + " | ".join(cells) + " |")
    b = board["bootstrap"]
    lines += ["", f"Means of per-frame values; [{b['confidence']:.0%} bootstrap interval over frames "
              f"({b['method']}, {b['n_boot']} replicates, seed {b['seed']})]. `{ALL_SCENES}`: "
              "mean of the per-scene means."]
    if "ranking" in board:
        rk = board["ranking"]
        lines.append(f"Rank: within each scene by `{rk['metric']}` "
                     f"({'higher' if rk['higher_is_better'] else 'lower'} is better). Bold: the "
                     "best value of each column within a scene; ≈ after it: the runner-up's mean "
                     "lies inside the best's interval (their difference is within the noise).")
    lines += [f"Note: {n}" for n in board["notes"]]
    if board["forced"]:
        lines.append(f"Warning: combined with --force although these settings differ: "
                     f"{', '.join(forced_fields(board))}")
    return "\n".join(lines) + "\n"


def forced_fields(board: dict[str, Any]) -> list[str]:
    """The number-changing settings that differ between the combined files (``--force``),
    sorted, each once; empty when the files agree."""
    return sorted({f["field"] for f in board["forced"]})


def to_csv(board: dict[str, Any], by: str = "method") -> str:
    """Long-format CSV: one line per (method, scene, metric) with mean, ci_low, ci_high, n,
    higher_is_better and ``settings_differ``: the settings that differ between the files the
    table combines (``--force``), joined by ``"; "``, the same on every line; empty when they
    agree. A plain column, so every CSV reader keeps it (``pandas.read_csv`` as it is). Names
    that a spreadsheet would run as a formula are written as text (``csv_text``)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["method", "scene", "rank", "n_frames", "metric", "mean", "ci_low", "ci_high",
                "n", "higher_is_better", "best", "settings_differ", *COSTS])
    differ = "; ".join(forced_fields(board))
    for r in _ordered_rows(board, by):
        for n, inf in board["metrics"].items():
            e = r["values"][n]
            w.writerow([csv_text(r["method"]), csv_text(r["scene"]), _rank(r), r["n_frames"], n,
                        *("" if e[k] is None else repr(e[k]) for k in ("mean", "ci_low", "ci_high")),
                        e["n"], inf["higher_is_better"], _best_mark(board, r, n), differ,
                        *(repr(v) if v is not None else "" for v in _costs_of(r))])
    return buf.getvalue()


def to_html(board: dict[str, Any], by: str = "method") -> str:
    """A self-contained HTML page with the leaderboard table (no script, no network)."""
    from html import escape

    head = ["method", "scene", "rank", "frames", *_header(board), *_cost_header(board)]
    out = ["<!DOCTYPE html>", "<html><head><meta charset='utf-8'><title>dynaeval leaderboard</title>",
           f"<style>{TABLE_CSS}</style></head><body>", "<h1>dynaeval leaderboard</h1>",
           "<table><thead><tr>" + "".join(f"<th>{escape(h)}</th>" for h in head)
           + "</tr></thead><tbody>"]
    for r in _ordered_rows(board, by):
        cls = " class='overall'" if r["scene"] == ALL_SCENES else ""
        cells = [escape(c) for c in (r["method"], r["scene"], _rank(r), str(r["n_frames"]))]
        cells += [_html_cell(n, r["values"][n], _best_mark(board, r, n)) for n in board["metrics"]]
        cells += [escape(c) for c in _cost_cells(board, r)]
        out.append(f"<tr{cls}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    out.append("</tbody></table>")
    md_notes = to_markdown(board, by).split("\n\n", 1)[1].strip().splitlines()
    out += [f"<p>{escape(line.replace('`', ''))}</p>" for line in md_notes]
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def _html_cell(name: str, entry: dict[str, Any], mark: str) -> str:
    """``_cell`` as HTML: the best value in ``<strong>``."""
    from html import escape

    text = escape(_cell(name, entry))
    if mark:
        mean = escape(_fmt(name, entry["mean"]))
        text = text.replace(mean, f"<strong>{mean}</strong>{'≈' if mark == 'tie' else ''}", 1)
    return text


TABLE_CSS = (
    "body{font-family:sans-serif;margin:2em;color:#222}"
    "table{border-collapse:collapse;font-size:14px}"
    "th,td{border:1px solid #ccc;padding:4px 8px;text-align:right}"
    "th:first-child,td:first-child,th:nth-child(2),td:nth-child(2){text-align:left}"
    "th{background:#f0f0f0}tr.overall td{font-weight:bold;background:#fafafa}"
)


def render(board: dict[str, Any], fmt: str = "md", by: str = "method") -> str:
    """The leaderboard as text in ``fmt`` (md, csv, json or html)."""
    if fmt == "md":
        return to_markdown(board, by)
    if fmt == "csv":
        return to_csv(board, by)
    if fmt == "html":
        return to_html(board, by)
    if fmt == "json":
        import json

        _ordered_rows(board, by)  # validates ``by``
        return json.dumps(board, indent=1, allow_nan=False, ensure_ascii=False) + "\n"
    raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")

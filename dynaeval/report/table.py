"""Plain-text tables of results for the terminal."""

from __future__ import annotations

from typing import Any

from dynaeval.metrics.registry import METRICS, REGIONS

REGION_LABELS = {"whole": "whole", "focused": "focused", "masked": "masked",
                 "covisible": "dycheck m*"}
"""Column heading of each region variant."""


def fmt(name: str, value: Any) -> str:
    """A value of result key ``name`` at the registry's precision (``n/a`` for null)."""
    if value is None:
        return "n/a"
    return f"{value:.{METRICS[name].precision}f}"


def _render(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    head = line(header)
    return [head, "-" * len(head), *map(line, rows)]


def _heading(name: str, info: dict[str, Any]) -> str:
    arrow = "↑" if info["higher_is_better"] else "↓"
    unit = f" ({info['unit']})" if info["unit"] else ""
    return f"{name} {arrow}{unit}"


def region_rows(results: dict[str, Any], *,
                objects: bool = False) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the metric x region table of the summary: one row per metric with
    region variants; with ``objects`` also one row per object key (in the ``whole`` column)."""
    metrics, summary = results["metrics"], results["summary"]
    shown = [n for n in metrics if objects or METRICS[n].kind != "object"]

    def base(n: str) -> str:
        return n if METRICS[n].kind == "object" else METRICS[n].metric

    def region(n: str) -> str:
        return "whole" if METRICS[n].kind == "object" else METRICS[n].variant

    bases = list(dict.fromkeys(base(n) for n in shown))
    regions = [r for r in REGIONS if any(region(n) == r for n in shown)]
    rows = []
    for b in bases:
        keys = {region(n): n for n in shown if base(n) == b}
        first = keys.get("whole") or next(keys[r] for r in regions if r in keys)
        rows.append([_heading(b, metrics[first])] + [
            fmt(keys[r], summary.get(keys[r])) if r in keys else "" for r in regions])
    return ["metric", *(REGION_LABELS[r] for r in regions)], rows


def run_title(results: dict[str, Any]) -> str:
    """What was scored, in words: ``"METHOD on SCENE"``, or ``"MODEL (3dgs render folder)"``
    when method and scene are one name (``dynaeval score RUN`` names both after the render
    folder; a plain pair of folders with the same name gives just that name)."""
    method, scene = results["method"], results["scene"]
    layout = (results.get("inputs") or {}).get("layout") or {}
    title = method if method == scene else f"{method} on {scene}"
    return f"{title} ({layout['name']} render folder)" if layout.get("name") else title


def summary_table(results: dict[str, Any]) -> str:
    """The summary (mean over all frames) as a metric x region table, the per-object metrics,
    then per-camera means of the whole-frame per-frame metrics. Arrows give the direction:
    ↑ higher is better, ↓ lower is better. Metrics, regions and precision come from the registry."""
    metrics, summary = results["metrics"], results["summary"]
    n_cams = len(results["cameras"])
    header, rows = region_rows(results)
    out = [
        f"{run_title(results)}: {summary['n_frames']} frames, "
        f"{n_cams} camera{'s' if n_cams != 1 else ''} (means over frames)",
        *_render(header, rows),
    ]
    objects = [n for n in metrics if METRICS[n].kind == "object"]
    if objects:
        obj_rows = [[_heading(n, metrics[n]), fmt(n, summary.get(n))] for n in objects]
        out += ["", *_render(["per object (tight boxes)", "mean"], obj_rows)]
    whole = [n for n in metrics if METRICS[n].kind == "frame" and METRICS[n].variant == "whole"]
    if n_cams > 1 and whole:
        cam_rows = [
            [cam, str(v["n_frames"])] + [fmt(b, v.get(b)) for b in whole]
            for cam, v in results["cameras"].items()
        ]
        out += ["", *_render(["camera", "frames", *whole], cam_rows)]
    return "\n".join(out)

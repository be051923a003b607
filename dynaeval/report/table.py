"""Plain-text tables of results for the terminal."""

from __future__ import annotations

from typing import Any

REGIONS = (("", "whole"), ("focused_", "focused"), ("masked_", "masked"))
OBJECT_PREFIXES = ("presence_", "tight_psnr_")
"""Per-object metrics (``dynaeval.metrics.presence``): shown in a table of their own."""


def _fmt(base: str, value: Any) -> str:
    if value is None:
        return "n/a"
    return f"{value:.3f}" if "psnr" in base else f"{value:.4f}"


def _base(name: str) -> str:
    for prefix, _ in REGIONS:
        if prefix and name.startswith(prefix):
            return name[len(prefix):]
    return name


def _render(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    head = line(header)
    return [head, "-" * len(head), *map(line, rows)]


def summary_table(results: dict[str, Any]) -> str:
    """The summary (mean over all frames) as a metric x region table, then per-camera means of
    the whole-frame metrics. Arrows give the direction: ↑ higher is better, ↓ lower is better."""
    metrics = results["metrics"]
    summary = results["summary"]
    bases: list[str] = []
    for name in metrics:
        if _base(name) not in bases:
            bases.append(_base(name))
    objects = [b for b in bases if b.startswith(OBJECT_PREFIXES)]
    bases = [b for b in bases if b not in objects]
    regions = [(p, label) for p, label in REGIONS if any(p + b in metrics for b in bases)]
    rows = []
    for b in bases:
        info = metrics.get(b) or next(metrics[p + b] for p, _ in regions if p + b in metrics)
        arrow = "↑" if info["higher_is_better"] else "↓"
        unit = f" ({info['unit']})" if info["unit"] else ""
        rows.append([f"{b} {arrow}{unit}"] + [
            _fmt(b, summary.get(p + b)) if p + b in metrics else "" for p, _ in regions
        ])
    n_cams = len(results["cameras"])
    out = [
        f"{results['method']} on {results['scene']}: {summary['n_frames']} frames, "
        f"{n_cams} camera{'s' if n_cams != 1 else ''} (means over frames)",
        *_render(["metric"] + [label for _, label in regions], rows),
    ]
    if objects:
        obj_rows = []
        for b in objects:
            arrow = "↑" if metrics[b]["higher_is_better"] else "↓"
            unit = f" ({metrics[b]['unit']})" if metrics[b]["unit"] else ""
            obj_rows.append([f"{b} {arrow}{unit}", _fmt(b, summary.get(b))])
        out += ["", *_render(["per object (tight boxes)", "mean"], obj_rows)]
    whole = [b for b in bases if b in metrics and b in ("psnr", "ssim", "lpips")]
    if n_cams > 1 and whole:
        cam_rows = [
            [cam, str(v["n_frames"])] + [_fmt(b, v.get(b)) for b in whole]
            for cam, v in results["cameras"].items()
        ]
        out += ["", *_render(["camera", "frames", *whole], cam_rows)]
    return "\n".join(out)

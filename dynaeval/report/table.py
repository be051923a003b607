"""Plain-text tables of results for the terminal."""

from __future__ import annotations

from typing import Any

_FORMATS = {"psnr": "{:.3f}"}


def _fmt(name: str, value: Any) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, int):
        return str(value)
    base = name.split("_", 1)[1] if name.startswith(("focused_", "masked_")) else name
    return _FORMATS.get(base, "{:.4f}").format(value)


def summary_table(results: dict[str, Any]) -> str:
    """Per-camera means and the overall mean as an aligned text table.

    Columns are the metrics in ``results["metrics"]`` with their direction (↑ higher is better,
    ↓ lower is better); the last row is the summary (mean over all frames).
    """
    names = list(results["metrics"])
    header = ["camera", "frames"] + [
        f"{n} {'↑' if results['metrics'][n]['higher_is_better'] else '↓'}" for n in names
    ]
    rows = [
        [cam, str(v["n_frames"])] + [_fmt(n, v.get(n)) for n in names]
        for cam, v in results["cameras"].items()
    ]
    s = results["summary"]
    rows.append(["all", str(s["n_frames"])] + [_fmt(n, s.get(n)) for n in names])
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    title = f"{results['method']} on {results['scene']}"
    sep = "-" * len(line(header))
    return "\n".join([title, line(header), sep, *map(line, rows[:-1]), sep, line(rows[-1])])

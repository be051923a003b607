"""One HTML page for a whole suite (``dynaeval suite``): the leaderboard, then per scene every
method side by side on the same frame and the same crop.

Per scene, the frame shown is the one whose worst-frame metric (``focused_psnr`` when every
method has it, else ``psnr``) averaged over the methods is lowest, among the frames every method
scored: where the methods struggle together. The crop is the ground-truth objects of that frame
(the union of their boxes, ``objects`` in the frame rows, written when the presence check ran)
with a margin (``dynaeval.report.html.crop_window``), else the whole frame. The ground truth is
the first tile, then each method in the leaderboard's order, all magnified alike
(``dynaeval.report.html.tiles_uri``). One file, images inlined, as ``score --report`` writes.
"""

from __future__ import annotations

from html import escape
from typing import Any

import numpy as np

from dynaeval.report.html import REPORT_CSS, crop_window, figure_uri, read_frame, tiles_uri
from dynaeval.report.leaderboard import COSTS, TABLE_CSS, render
from dynaeval.report.table import fmt

TILE_HEIGHT = 200
"""Height in pixels of each tile on the page."""


def shared_frame(docs: list[dict[str, Any]]) -> tuple[str, tuple[str, str] | None]:
    """(metric, (camera, frame)) of the frame a scene's methods are shown on (module docstring):
    among the frames every method scored, the lowest mean of the metric over the methods where
    it is defined (a null value, e.g. the infinite PSNR of a perfect frame, is left out of the
    mean; frames without any value come last). The key is None when no frame is in every
    method's results."""
    metric = ("focused_psnr" if all("focused_psnr" in d["metrics"] for d in docs) else "psnr")
    values: dict[tuple[str, str], list[float | None]] = {}
    for d in docs:
        for row in d["frames"]:
            values.setdefault((row["camera"], row["frame"]), []).append(row.get(metric))
    common = {k: [x for x in v if x is not None] for k, v in values.items() if len(v) == len(docs)}
    rank = {k: (0, float(np.mean(v))) if v else (1, 0.0) for k, v in common.items()}
    return metric, (min(rank, key=lambda k: (rank[k], k)) if rank else None)


def _window(row: dict[str, Any], shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """The crop of a frame row: its ground-truth objects' boxes together, else the whole frame."""
    boxes = [o["box"] for o in row.get("objects") or [] if o.get("box") is not None]
    if not boxes:
        return 0, shape[1], 0, shape[0]
    b = np.asarray(boxes, dtype=np.float64)
    return crop_window(shape, (b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max()))


def scene_html(scene: str, docs: list[dict[str, Any]]) -> list[str]:
    """The section of one scene: its methods on one frame, one crop."""
    metric, key = shared_frame(docs)
    parts = [f"<h2>Scene {escape(scene)}</h2>"]
    if key is None:
        return [*parts, "<p>No frame is in the results of every method.</p>"]
    rows = [next(r for r in d["frames"] if (r["camera"], r["frame"]) == key) for d in docs]
    background = docs[0]["settings"].get("background", "white")
    gt = read_frame(rows[0]["gt"], background)
    images = [gt, *(read_frame(r["pred"], background) for r in rows)]
    window = _window(rows[0], gt.shape)
    names = ["ground truth", *(f"{d['method']} ({metric} {fmt(metric, r.get(metric))})"
                               for d, r in zip(docs, rows, strict=True))]
    return [*parts, f"<p>Camera {escape(str(key[0]))}, frame {escape(str(key[1]))} (lowest mean {metric} "
            f"over the methods), pixels x {window[0]}-{window[1]}, y {window[2]}-{window[3]}; "
            f"left to right: {escape(', '.join(names))}.</p>",
            f"<img src='{tiles_uri(images, window, TILE_HEIGHT)}' alt='{escape(scene)}: "
            f"{escape(', '.join(names))}'>"]


def render_suite_page(docs: list[dict[str, Any]], board: dict[str, Any]) -> str:
    """The page (HTML text) of a suite's results documents and their leaderboard ``board``.

    Raises:
        InputError: a frame listed in the results is gone.
    """
    table = render(board, "html")
    end = table.index("</table>") + len("</table>")
    # the table in its own scrolling box, as the report's tables (it ran off a 1400 px page)
    body = (f"<div class='table'>{table[table.index('<table>'):end]}</div>"
            + table[end:table.index("</body>")])
    parts = ["<!DOCTYPE html>", "<html><head><meta charset='utf-8'><title>dynaeval suite</title>",
             f"<style>{TABLE_CSS}{REPORT_CSS}</style></head><body>", "<h1>dynaeval suite</h1>",
             f"<p>{len(board['methods'])} method(s) x {len(board['scenes'])} scene(s).</p>", body]
    costed = [sc for sc in board["scenes"] if _given_costs(board, sc)]
    if costed:
        parts.append("<h2>Quality against cost</h2><p>Per scene, each method's ranking metric "
                     "against what it costs (SUITE.toml <code>[costs]</code>, else what its run "
                     "folder says: NeRFBaselines' <code>info.json</code>); the Pareto front (no "
                     "other method both cheaper and better) is joined and ringed. A method "
                     "without the figure is left out of that panel.</p>")
        parts += [f"<img alt='{escape(scene)} quality against cost' "
                  f"src='{figure_uri(quality_cost_figure(board, scene))}'>" for scene in costed]
    for scene in board["scenes"]:
        order = {m: i for i, m in enumerate(board["methods"])}
        shown = sorted((d for d in docs if d["scene"] == scene), key=lambda d: order[d["method"]])
        parts += scene_html(scene, shown)
    return "\n".join([*parts, "</body></html>"]) + "\n"


def pareto_front(points: list[tuple[float, float]], cheaper_is_lower: bool,
                 better_is_higher: bool) -> list[int]:
    """Indices of the (cost, quality) points no other point dominates (at least as cheap and as
    good, one of them strictly), in order of cost."""
    c = [(x if cheaper_is_lower else -x, -y if better_is_higher else y) for x, y in points]
    front = [i for i, (a, b) in enumerate(c)
             if not any(a2 <= a and b2 <= b and (a2, b2) != (a, b) for a2, b2 in c)]
    return sorted(front, key=lambda i: c[i][0])


def _given_costs(board: dict[str, Any], scene: str) -> list[str]:
    """The ``COSTS`` some method of ``scene`` has, in ``COSTS`` order."""
    rows = [r for r in board["rows"] if r["scene"] == scene]
    return [k for k in COSTS if any(k in r.get("costs", {}) for r in rows)]


def quality_cost_figure(board: dict[str, Any], scene: str) -> Any:
    """The matplotlib figure of ``scene``: the ranking metric's mean per method against each
    cost some method has on that scene (its row's ``costs``; one panel per cost), the Pareto
    front marked."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    metric, higher = board["ranking"]["metric"], board["ranking"]["higher_is_better"]
    given = _given_costs(board, scene)
    fig, axes = plt.subplots(1, len(given), figsize=(4.2 * len(given), 3.2), dpi=100,
                             squeeze=False)
    rows = [r for r in board["rows"] if r["scene"] == scene]
    for ax, key in zip(axes[0], given, strict=True):
        pts = [(r["method"], r.get("costs", {}).get(key), r["values"][metric]["mean"])
               for r in rows]
        pts = [(m, x, y) for m, x, y in pts if x is not None and y is not None]
        head, cost_higher = COSTS[key]
        for m, x, y in pts:
            ax.scatter([x], [y], color="#4477aa", zorder=2)
            ax.annotate(m, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
        front = [pts[i] for i in pareto_front([(x, y) for _, x, y in pts], not cost_higher,
                                              higher)]
        if front:
            ax.plot([x for _, x, _ in front], [y for _, _, y in front], color="#cc3311",
                    lw=1, zorder=1)
            ax.scatter([x for _, x, _ in front], [y for _, _, y in front], s=120,
                       facecolors="none", edgecolors="#cc3311", zorder=3)
        ax.set_xlabel(f"{head} (higher is better)" if cost_higher else f"{head} (lower is better)")
        ax.set_ylabel(f"{metric} ({'higher' if higher else 'lower'} is better)")
        ax.set_title(scene, fontsize=10)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


"""A one-file HTML report of one scoring run: ``dynaeval score ... --report DIR``.

``DIR/index.html`` is the whole report: its images (PNG) are inlined as ``data:`` URIs, so the one
file opens in a browser from disk (no server, no network, no script) and can be mailed or copied
alone. It is about 2.6 MB for the bundled sample (16 frames, 18 metrics) and does not grow with
the number of frames: one curve per metric, a fixed number of worst frames and missing objects.

Contents: the summary table (metric x region), per-camera means, per-frame curves of each metric
(one plot per metric, one line per camera, integer frame ticks; matplotlib with the Agg backend,
imported here only), and the worst frames (lowest ``focused_psnr``, else ``psnr``) as prediction /
ground truth / error heat-map with the scored regions drawn on each: expanded boxes (the
``focused_*`` pixels) in yellow and the motion-mask outline (the ``masked_*`` pixels) in cyan.
Tables wider than the window scroll inside their own box; their headings break at ``_``.

The regions come from ``score(..., on_regions=recorder)`` with a ``RegionRecorder``: it keeps the
boxes of every frame and the outline (contours) of every motion mask, not the masks themselves.
"""

from __future__ import annotations

import base64
import io
import json
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.io.atomic import write_files_atomic
from dynaeval.io.frames import FrameRef
from dynaeval.io.layouts import part_ref_from_text
from dynaeval.report.leaderboard import TABLE_CSS
from dynaeval.report.table import fmt, region_rows, run_title

BOX_COLOUR = "#ffd400"
MASK_COLOUR = "#00e5ff"


class RegionRecorder:
    """Collects the regions ``score`` used, per (camera, frame): boxes and mask outlines.

    Pass ``recorder`` as ``score(..., on_regions=recorder)``; memory is a few boxes and contour
    points per frame.
    """

    def __init__(self) -> None:
        self.boxes: dict[tuple[str, str], np.ndarray] = {}
        """(N, 4) int64 expanded, clipped, merged boxes of each frame that has any."""
        self.outlines: dict[tuple[str, str], list[np.ndarray]] = {}
        """Contours of the motion mask, each (K, 2) int32 (x, y) pixel coordinates."""

    def __call__(self, camera: str, pairs: list[Any], regions: list[Any]) -> None:
        import cv2

        for pair, reg in zip(pairs, regions, strict=True):
            key = (camera, pair.frame)
            if reg.boxes is not None:
                self.boxes[key] = np.asarray(reg.boxes, dtype=np.int64).reshape(-1, 4)
            mask = reg.mask  # unpacked on each access
            if mask is not None:
                contours, _ = cv2.findContours(np.ascontiguousarray(mask, dtype=np.uint8),
                                               cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
                self.outlines[key] = [c.reshape(-1, 2) for c in contours]


def read_frame(ref: str, background: str) -> np.ndarray:
    """A frame given as the results' ``pred``/``gt`` string (``path`` or ``path#N`` for video)."""
    path = Path(ref)
    if not path.exists() and "#" in ref:
        file, _, index = ref.rpartition("#")
        if index.isdigit():
            return FrameRef(Path(file), int(index)).read(background)
    if not path.exists():
        part = part_ref_from_text(ref)  # a K-Planes stack's or a DyCheck render's part
        if part is not None:
            return part.read(background)
        raise InputError("frame listed in the results is gone; the report needs it", path=ref)
    return FrameRef(path).read(background)


def worst_frames(results: dict[str, Any], n: int = 4) -> tuple[str, list[dict[str, Any]]]:
    """The ``n`` frames with the lowest ``focused_psnr`` (when scored) else ``psnr``.

    Returns:
        (metric used, frame rows of the results, worst first). Frames whose value is null are
        left out.
    """
    metric = "focused_psnr" if "focused_psnr" in results["metrics"] else "psnr"
    rows = [f for f in results["frames"] if f.get(metric) is not None]
    return metric, sorted(rows, key=lambda f: f[metric])[:n]


def camera_label(results: dict[str, Any], camera: str) -> str:
    """The name the report shows for a camera of the results.

    The results call the frames of a flat folder (no camera subfolders) camera ``"."``, their
    path relative to the folder; the report names it after the ground-truth folder
    (``score runs/cam00 gt/cam00`` -> ``cam00``), or ``all`` for a render folder of a known layout
    (whose ground-truth folder is the layout's own ``gt``). Any other camera keeps its name.
    """
    if camera != ".":
        return camera
    inputs = results.get("inputs") or {}
    if inputs.get("layout") or not inputs.get("gt"):
        return "all"
    return Path(inputs["gt"]).name or "all"


def _heading_cell(text: str) -> str:
    """A ``<th>`` whose text may break after each ``_`` (``focused_<wbr>flicker``)."""
    return "<th>" + "_<wbr>".join(escape(p) for p in text.split("_")) + "</th>"


def _table(header: list[str], rows: list[list[str]]) -> str:
    """An HTML table in its own horizontally scrolling box (cells are escaped here)."""
    head = "".join(_heading_cell(h) for h in header)
    body = "".join("<tr>" + "".join(f"<td>{escape(c)}</td>" for c in row) + "</tr>" for row in rows)
    return f"<div class='table'><table><tr>{head}</tr>{body}</table></div>"


def _summary_html(results: dict[str, Any]) -> str:
    metrics = results["metrics"]
    header, body = region_rows(results, objects=True)
    per_cam = [m for m in metrics if any(m in v for v in results["cameras"].values())]
    cam_rows = [[camera_label(results, cam), str(v["n_frames"]), *(fmt(m, v.get(m)) for m in per_cam)]
                for cam, v in results["cameras"].items()]
    return (_table(header, body) + "<h3>Per camera (means over frames)</h3>"
            + _table(["camera", "frames", *per_cam], cam_rows))


def _png_uri(png: bytes) -> str:
    """``data:`` URI of PNG bytes, for an ``<img src>`` inside the page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def figure_uri(fig: Any) -> str:
    """A matplotlib figure as a PNG ``data:`` URI; the figure is closed."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return _png_uri(buf.getvalue())


def curve_figure(results: dict[str, Any], name: str) -> Any:
    """The matplotlib figure of per-frame metric ``name``: value against frame index (integer
    ticks), one line per camera (named by ``camera_label``)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    frames, cameras = results["frames"], results["inputs"]["cameras"]
    fig, ax = plt.subplots(figsize=(7, 2.6), dpi=100)
    for cam in cameras:
        pts = [(f["index"], f[name]) for f in frames if f["camera"] == cam and f.get(name) is not None]
        if pts:
            x, y = zip(*pts, strict=True)
            ax.plot(x, y, marker=".", lw=1, label=camera_label(results, cam))
    info = results["metrics"][name]
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frame index")
    ax.set_ylabel(f"{name}{' (' + info['unit'] + ')' if info['unit'] else ''}")
    ax.set_title(f"{name} per frame ({'higher' if info['higher_is_better'] else 'lower'} is better)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    if ax.lines and len(cameras) <= 12:  # no line (every value null): no empty legend
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def _curves(results: dict[str, Any]) -> list[tuple[str, str]]:
    """(metric, PNG ``data:`` URI) of each per-frame metric's curve."""
    frames = results["frames"]
    names = [m for m in results["metrics"] if any(m in f for f in frames)]
    return [(name, figure_uri(curve_figure(results, name))) for name in names]


def _draw_regions(ax: Any, boxes: np.ndarray | None, outlines: list[np.ndarray] | None) -> None:
    from matplotlib.patches import Rectangle

    for x0, y0, x1, y1 in boxes if boxes is not None else []:
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False,
                               edgecolor=BOX_COLOUR, lw=1.2))
    for c in outlines or []:
        closed = np.vstack([c, c[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color=MASK_COLOUR, lw=0.8)


def _frame_figure(row: dict[str, Any], metric: str, results: dict[str, Any],
                  recorder: RegionRecorder | None) -> str:
    """Prediction / ground truth / error panels of one frame with its regions, as a PNG URI."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    background = results["settings"].get("background", "white")
    pred = read_frame(row["pred"], background)
    gt = read_frame(row["gt"], background)
    if pred.shape != gt.shape:
        raise InputError(f"prediction {pred.shape} and ground truth {gt.shape} differ in shape",
                         path=row["pred"])
    err = np.abs(pred.astype(np.float64) - gt.astype(np.float64)).mean(axis=2)
    key = (row["camera"], row["frame"])
    boxes = recorder.boxes.get(key) if recorder else None
    outlines = recorder.outlines.get(key) if recorder else None
    h, w = gt.shape[:2]
    fig, axes = plt.subplots(1, 3, figsize=(15, 15 * h / w / 3 + 0.6), dpi=100)
    show = (lambda a: a[..., 0]) if gt.shape[2] == 1 else (lambda a: a)
    panels = [(show(np.clip(pred, 0, 1)), "prediction"), (show(np.clip(gt, 0, 1)), "ground truth"),
              (err, "|prediction - ground truth| (mean over channels)")]
    for ax, (img, title) in zip(axes, panels, strict=True):
        kw = {"cmap": "inferno", "vmin": 0.0, "vmax": max(float(err.max()), 1e-6)} \
            if img is err else ({"cmap": "gray", "vmin": 0, "vmax": 1} if img.ndim == 2 else {})
        im = ax.imshow(img, interpolation="nearest", **kw)
        _draw_regions(ax, boxes, outlines)
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
        if img is err:
            fig.colorbar(im, ax=ax, fraction=0.03, pad=0.01)
    value = row.get(metric)
    fig.suptitle(f"camera {camera_label(results, row['camera'])}, frame {row['frame']}: "
                 f"{metric} = {value:.2f} dB", fontsize=10)
    fig.tight_layout()
    return figure_uri(fig)


def missing_objects(results: dict[str, Any], n: int = 8) -> list[tuple[dict, dict]]:
    """Up to ``n`` (frame row, object) pairs whose object the presence check found missing, in
    frame order (``objects`` in the frame rows, written when presence ran)."""
    out = []
    for row in results["frames"]:
        for obj in row.get("objects") or []:
            if obj.get("present") is False and len(out) < n:
                out.append((row, obj))
    return out


def _object_crops(row: dict[str, Any], obj: dict[str, Any], background: str) -> str:
    """Ground-truth and predicted crop of one object side by side (its tight box, 50 % margin,
    at least 48 px), magnified to 160 px high with nearest-neighbour sampling; a PNG URI."""
    gt, pred = read_frame(row["gt"], background), read_frame(row["pred"], background)
    return tiles_uri([gt, pred], crop_window(gt.shape, obj["box"]))


def crop_window(shape: tuple[int, ...], box: Any, *, min_half: float = 24.0,
                margin: float = 0.75) -> tuple[int, int, int, int]:
    """The square window ``(x0, x1, y0, y1)`` (pixels, end exclusive) centred on ``box``
    (``(x0, y0, x1, y1)``), ``margin`` x its longer side on each side of the centre (0.75: a
    50 % margin) and at least ``min_half`` px, clipped to an image of ``shape`` (H, W, ...)."""
    h, w = shape[:2]
    x0, y0, x1, y1 = box
    half = max(min_half, margin * max(x1 - x0, y1 - y0))
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return (int(max(0, cx - half)), int(min(w, cx + half)),
            int(max(0, cy - half)), int(min(h, cy + half)))


def tiles_uri(images: list[np.ndarray], window: tuple[int, int, int, int],
              height: int = 160) -> str:
    """The same ``window`` (``crop_window``) of each image ((H, W, C) float in [0, 1]), magnified
    to ``height`` px with nearest-neighbour sampling, side by side 6 px apart; a PNG URI."""
    import cv2

    a, b, c, d = window
    scale = height / max(1, d - c)
    tiles = [cv2.resize(np.ascontiguousarray(img[c:d, a:b]), None, fx=scale, fy=scale,
                        interpolation=cv2.INTER_NEAREST) for img in images]
    gap = np.ones((tiles[0].shape[0], 6, tiles[0].shape[2]), np.float32)
    both = np.concatenate([t for tile in tiles for t in (gap, tile)][1:], axis=1)
    if both.shape[2] == 1:
        both = np.repeat(both, 3, axis=2)
    ok, png = cv2.imencode(".png", np.round(np.clip(both, 0, 1) * 255).astype(np.uint8)[..., ::-1])
    if not ok:
        raise RuntimeError("OpenCV could not encode a PNG")  # a bug, not the user's input
    return _png_uri(png.tobytes())


def write_report(
    results: dict[str, Any],
    out_dir: str | Path,
    *,
    recorder: RegionRecorder | None = None,
    n_worst: int = 4,
    overwrite: bool = False,
) -> Path:
    """Write ``out_dir/index.html``, the whole report (images inlined), for one results doc.

    Args:
        results: the results of ``dynaeval.score`` (or ``load_results``); the frames it lists
            must still be on disk for the worst-frame panels.
        out_dir: folder, created if missing; only ``index.html`` is written into it.
        recorder: regions recorded during ``score`` (boxes and mask outlines are drawn when given).
        n_worst: how many worst frames to show.
        overwrite: replace an existing ``index.html``.

    Returns:
        Path of ``index.html`` (written last, atomically: a failed run leaves none).

    Raises:
        InputError: ``index.html`` exists and not ``overwrite``, ``out_dir`` is a file, a frame
            listed in the results is gone, or the disk is full (nothing is left behind).
    """
    index = report_index(out_dir, overwrite=overwrite)
    page = render_report(results, recorder=recorder, n_worst=n_worst)
    write_files_atomic([(index, page, "report")], overwrite=overwrite)
    return index


def report_index(out_dir: str | Path, *, overwrite: bool = False) -> Path:
    """``out_dir/index.html``, the report's one file, checked before anything is rendered.

    Raises:
        InputError: ``out_dir`` is a file, or ``index.html`` exists and not ``overwrite``.
    """
    out_dir = Path(out_dir)
    index = out_dir / "index.html"
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError("report folder is a file; choose a folder", path=out_dir)
    if index.exists() and not overwrite:
        raise InputError("report exists; pass --overwrite or choose another --report folder",
                         path=index)
    return index


def render_report(results: dict[str, Any], *, recorder: RegionRecorder | None = None,
                  n_worst: int = 4) -> str:
    """The report's HTML page (images inlined as data URIs) for one results document; writes
    nothing, so an interrupt while it renders leaves no file and no folder.

    Raises:
        InputError: a frame listed in the results is gone.
    """
    title = f"dynaeval: {run_title(results)}"
    parts = [
        "<!DOCTYPE html>", "<html><head><meta charset='utf-8'>", f"<title>{escape(title)}</title>",
        f"<style>{TABLE_CSS}{REPORT_CSS}</style></head><body>",
        f"<h1>{escape(title)}</h1>",
        f"<p>{results['summary']['n_frames']} frames, {len(results['cameras'])} camera(s); "
        f"dynaeval {escape(results['dynaeval_version'])}, {escape(results['created'])}. "
        "Values are means of per-frame values.</p>",
        "<h2>Summary</h2>", _summary_html(results),
        "<h2>Per-frame curves</h2>", "<div class='curves'>",
        *(f"<img src='{src}' alt='{escape(name)} per frame'>" for name, src in _curves(results)),
        "</div>",
        *_worst_html(results, recorder, n_worst),
        *_missing_html(results),
        *_details_html(results),
    ]
    return "\n".join(parts) + "\n"


REPORT_CSS = (
    "img{max-width:100%;display:block;margin:0.5em 0}"
    ".curves img{display:inline-block;width:49%;margin:0}"
    "div.table{max-width:100%;overflow-x:auto}"  # a table wider than the window scrolls in its box
    "div.table table{font-size:13px}div.table th,div.table td{padding:3px 5px}"
    "div.table th{vertical-align:bottom}"
    "details pre{font-size:12px;background:#f7f7f7;padding:1em;white-space:pre-wrap;"
    "overflow-wrap:anywhere}"
    "li{overflow-wrap:anywhere}"
)
"""The report's own style, after the leaderboard's ``TABLE_CSS``: nothing wider than the window."""


def _worst_html(results: dict[str, Any], recorder: RegionRecorder | None,
                n_worst: int) -> list[str]:
    """The worst frames' panels and their captions."""
    metric, worst = worst_frames(results, n_worst)
    parts = [f"<h2>Worst frames by {escape(metric)}</h2>"]
    if recorder is not None:
        parts.append("<p>Drawn on each panel: <span style='color:#b09000'>boxes</span> "
                     "(pixels of the focused_* metrics) and the <span style='color:#0097a7'>"
                     "motion-mask outline</span> (pixels of the masked_* metrics).</p>")
    if not worst:
        parts.append(f"<p>No frame has a defined {escape(metric)}.</p>")
    for row in worst:
        src = _frame_figure(row, metric, results, recorder)
        cap = ", ".join(f"{m} {row[m]:.4g}" for m in results["metrics"] if row.get(m) is not None)
        alt = f"camera {camera_label(results, row['camera'])} frame {row['frame']}"
        parts.append(f"<img src='{src}' alt='{escape(alt)}'><p>{escape(cap)}</p>")
    return parts


def _missing_html(results: dict[str, Any]) -> list[str]:
    """Crops of the objects the presence check did not find."""
    missing = missing_objects(results)
    if not missing:
        return []
    background = results["settings"].get("background", "white")
    parts = ["<h2>Objects missing from the prediction</h2><p>Ground truth (left) and "
             "prediction (right) around each object the presence check did not find "
             "(first frames in order).</p>"]
    for row, obj in missing:
        src = _object_crops(row, obj, background)
        cap = (f"camera {camera_label(results, row['camera'])} frame {row['frame']}: "
               f"{obj['class']} {obj['id']} "
               + ", ".join(f"{k} {obj[k]:.3g}" for k in ("ncc", "psnr", "visibility")
                           if isinstance(obj.get(k), float)))
        parts.append(f"<img src='{src}' alt='{escape(cap)}'><p>{escape(cap)}</p>")
    return parts


def _details_html(results: dict[str, Any]) -> list[str]:
    """Warnings and settings, folded."""
    parts = []
    if results["warnings"]:
        items = "".join(f"<li>{escape(json.dumps(w, ensure_ascii=False))}</li>"
                        for w in results["warnings"][:200])
        parts.append(f"<details><summary>{len(results['warnings'])} warning(s)</summary>"
                     f"<ul>{items}</ul></details>")
    parts.append("<details><summary>Settings</summary><pre>"
                 f"{escape(json.dumps(results['settings'], indent=1, ensure_ascii=False))}"
                 "</pre></details></body></html>")
    return parts

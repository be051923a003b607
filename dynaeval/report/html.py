"""A self-contained HTML report of one scoring run: ``dynaeval score ... --report DIR``.

``DIR/index.html`` references PNG files in ``DIR/img/`` by relative path: the folder opens in a
browser from disk (no server, no network, no script) and can be zipped or copied as a whole.

Contents: the summary table (metric x region), per-camera means, per-frame curves of each metric
(one plot per metric, one line per camera; matplotlib with the Agg backend, imported here only),
and the worst frames (lowest ``focused_psnr``, else ``psnr``) as prediction / ground truth /
error heat-map with the scored regions drawn on each: expanded boxes (the ``focused_*`` pixels)
in yellow and the motion-mask outline (the ``masked_*`` pixels) in cyan.

The regions come from ``score(..., on_regions=recorder)`` with a ``RegionRecorder``: it keeps the
boxes of every frame and the outline (contours) of every motion mask, not the masks themselves.
"""

from __future__ import annotations

import json
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.errors import InputError

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


def _read_frame(ref: str, background: str) -> np.ndarray:
    """A frame given as the results' ``pred``/``gt`` string (``path`` or ``path#N`` for video)."""
    from dynaeval.io.frames import FrameRef

    path = Path(ref)
    if not path.exists() and "#" in ref:
        file, _, index = ref.rpartition("#")
        if index.isdigit():
            return FrameRef(Path(file), int(index)).read(background)
    if not path.exists():
        from dynaeval.io.layouts import part_ref_from_text

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


def _summary_html(results: dict[str, Any]) -> str:
    from dynaeval.report.table import fmt, region_rows

    metrics = results["metrics"]
    header, body = region_rows(results, objects=True)
    head = "".join(f"<th>{escape(h)}</th>" for h in header)
    rows = ["<tr>" + "".join(f"<td>{escape(c)}</td>" for c in row) + "</tr>" for row in body]
    table = f"<table><tr>{head}</tr>{''.join(rows)}</table>"
    per_cam = [m for m in metrics if any(m in v for v in results["cameras"].values())]
    cam_head = "".join(f"<th>{escape(m)}</th>" for m in per_cam)
    cam_rows = "".join(
        f"<tr><td>{escape(cam)}</td><td>{v['n_frames']}</td>"
        + "".join(f"<td>{fmt(m, v.get(m))}</td>" for m in per_cam) + "</tr>"
        for cam, v in results["cameras"].items())
    cams = f"<table><tr><th>camera</th><th>frames</th>{cam_head}</tr>{cam_rows}</table>"
    return table + "<h3>Per camera (means over frames)</h3>" + cams


def _curves(results: dict[str, Any], img_dir: Path) -> list[tuple[str, str]]:
    """One PNG per per-frame metric: value against frame index, one line per camera."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    frames = results["frames"]
    names = [m for m in results["metrics"] if any(m in f for f in frames)]
    out = []
    for name in names:
        fig, ax = plt.subplots(figsize=(7, 2.6), dpi=100)
        for cam in results["inputs"]["cameras"]:
            pts = [(f["index"], f[name]) for f in frames if f["camera"] == cam and f.get(name) is not None]
            if pts:
                x, y = zip(*pts, strict=True)
                ax.plot(x, y, marker=".", lw=1, label=cam)
        info = results["metrics"][name]
        ax.set_xlabel("frame index")
        ax.set_ylabel(f"{name}{' (' + info['unit'] + ')' if info['unit'] else ''}")
        ax.set_title(f"{name} per frame ({'higher' if info['higher_is_better'] else 'lower'} is better)",
                     fontsize=10)
        ax.grid(alpha=0.3)
        if len(results["inputs"]["cameras"]) <= 12:
            ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        file = img_dir / f"curve_{name}.png"
        fig.savefig(file)
        plt.close(fig)
        out.append((name, f"img/{file.name}"))
    return out


def _draw_regions(ax: Any, boxes: np.ndarray | None, outlines: list[np.ndarray] | None) -> None:
    from matplotlib.patches import Rectangle

    for x0, y0, x1, y1 in boxes if boxes is not None else []:
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False,
                               edgecolor=BOX_COLOUR, lw=1.2))
    for c in outlines or []:
        closed = np.vstack([c, c[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color=MASK_COLOUR, lw=0.8)


def _frame_figure(row: dict[str, Any], metric: str, results: dict[str, Any],
                  recorder: RegionRecorder | None, file: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    background = results["settings"].get("background", "white")
    pred = _read_frame(row["pred"], background)
    gt = _read_frame(row["gt"], background)
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
    fig.suptitle(f"camera {row['camera']}, frame {row['frame']}: {metric} = {value:.2f} dB",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(file)
    plt.close(fig)


def missing_objects(results: dict[str, Any], n: int = 8) -> list[tuple[dict, dict]]:
    """Up to ``n`` (frame row, object) pairs whose object the presence check found missing, in
    frame order (``objects`` in the frame rows, written when presence ran)."""
    out = []
    for row in results["frames"]:
        for obj in row.get("objects") or []:
            if obj.get("present") is False and len(out) < n:
                out.append((row, obj))
    return out


def _object_crops(row: dict[str, Any], obj: dict[str, Any], background: str, path: Path) -> None:
    """Ground-truth and predicted crop of one object side by side (its tight box, 50 % margin,
    at least 48 px), magnified to 160 px high with nearest-neighbour sampling."""
    import cv2

    gt, pred = _read_frame(row["gt"], background), _read_frame(row["pred"], background)
    h, w = gt.shape[:2]
    x0, y0, x1, y1 = obj["box"]
    half = max(24.0, 0.75 * max(x1 - x0, y1 - y0))
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    a, b = int(max(0, cx - half)), int(min(w, cx + half))
    c, d = int(max(0, cy - half)), int(min(h, cy + half))
    scale = 160 / max(1, d - c)
    tiles = [cv2.resize(np.ascontiguousarray(img[c:d, a:b]), None, fx=scale, fy=scale,
                        interpolation=cv2.INTER_NEAREST) for img in (gt, pred)]
    gap = np.ones((tiles[0].shape[0], 6, tiles[0].shape[2]), np.float32)
    both = np.concatenate([tiles[0], gap, tiles[1]], axis=1)
    if both.shape[2] == 1:
        both = np.repeat(both, 3, axis=2)
    cv2.imwrite(str(path), np.round(np.clip(both, 0, 1) * 255).astype(np.uint8)[..., ::-1])


def write_report(
    results: dict[str, Any],
    out_dir: str | Path,
    *,
    recorder: RegionRecorder | None = None,
    n_worst: int = 4,
    overwrite: bool = False,
) -> Path:
    """Write ``out_dir/index.html`` and its images (``out_dir/img/*.png``) for one results doc.

    Args:
        results: the results of ``dynaeval.score`` (or ``load_results``); the frames it lists
            must still be on disk for the worst-frame panels.
        out_dir: folder, created if missing.
        recorder: regions recorded during ``score`` (boxes and mask outlines are drawn when given).
        n_worst: how many worst frames to show.
        overwrite: replace an existing ``index.html``.

    Returns:
        Path of ``index.html`` (written last, atomically: a failed run leaves none).

    Raises:
        InputError: ``index.html`` exists and not ``overwrite``, ``out_dir`` is a file, or a frame
            listed in the results is gone.
    """
    from dynaeval.io.atomic import write_text_atomic
    from dynaeval.report.leaderboard import TABLE_CSS

    out_dir = Path(out_dir)
    index = out_dir / "index.html"
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError("report folder is a file; choose a folder", path=out_dir)
    if index.exists() and not overwrite:
        raise InputError("report exists; pass --overwrite or choose another --report folder",
                         path=index)
    img_dir = out_dir / "img"
    img_dir.mkdir(parents=True, exist_ok=True)
    title = f"dynaeval: {results['method']} on {results['scene']}"
    parts = [
        "<!DOCTYPE html>", "<html><head><meta charset='utf-8'>", f"<title>{escape(title)}</title>",
        f"<style>{TABLE_CSS}img{{max-width:100%;display:block;margin:0.5em 0}}"
        "details pre{font-size:12px;background:#f7f7f7;padding:1em}"
        ".curves img{display:inline-block;width:49%;margin:0}</style></head><body>",
        f"<h1>{escape(title)}</h1>",
        f"<p>{results['summary']['n_frames']} frames, {len(results['cameras'])} camera(s); "
        f"dynaeval {escape(results['dynaeval_version'])}, {escape(results['created'])}. "
        "Values are means of per-frame values.</p>",
        "<h2>Summary</h2>", _summary_html(results),
        "<h2>Per-frame curves</h2>", "<div class='curves'>",
        *(f"<img src='{escape(src)}' alt='{escape(name)} per frame'>"
          for name, src in _curves(results, img_dir)),
        "</div>",
        *_worst_html(results, recorder, n_worst, img_dir),
        *_missing_html(results, img_dir),
        *_details_html(results),
    ]
    return write_text_atomic(index, "\n".join(parts) + "\n", overwrite=overwrite)


def _worst_html(results: dict[str, Any], recorder: RegionRecorder | None, n_worst: int,
                img_dir: Path) -> list[str]:
    """The worst frames' panels (written into ``img_dir``) and their captions."""
    metric, worst = worst_frames(results, n_worst)
    parts = [f"<h2>Worst frames by {escape(metric)}</h2>"]
    if recorder is not None:
        parts.append("<p>Drawn on each panel: <span style='color:#b09000'>boxes</span> "
                     "(pixels of the focused_* metrics) and the <span style='color:#0097a7'>"
                     "motion-mask outline</span> (pixels of the masked_* metrics).</p>")
    if not worst:
        parts.append(f"<p>No frame has a defined {escape(metric)}.</p>")
    for i, row in enumerate(worst):
        file = img_dir / f"worst_{i:02d}.png"
        _frame_figure(row, metric, results, recorder, file)
        cap = ", ".join(f"{m} {row[m]:.4g}" for m in results["metrics"] if row.get(m) is not None)
        parts.append(f"<img src='img/{escape(file.name)}' alt='camera {escape(row['camera'])} "
                     f"frame {escape(row['frame'])}'><p>{escape(cap)}</p>")
    return parts


def _missing_html(results: dict[str, Any], img_dir: Path) -> list[str]:
    """Crops of the objects the presence check did not find (written into ``img_dir``)."""
    missing = missing_objects(results)
    if not missing:
        return []
    background = results["settings"].get("background", "white")
    parts = ["<h2>Objects missing from the prediction</h2><p>Ground truth (left) and "
             "prediction (right) around each object the presence check did not find "
             "(first frames in order).</p>"]
    for i, (row, obj) in enumerate(missing):
        file = img_dir / f"missing_{i:02d}.png"
        _object_crops(row, obj, background, file)
        cap = (f"camera {row['camera']} frame {row['frame']}: {obj['class']} {obj['id']} "
               + ", ".join(f"{k} {obj[k]:.3g}" for k in ("ncc", "psnr", "visibility")
                           if isinstance(obj.get(k), float)))
        parts.append(f"<img src='img/{file.name}' alt='{escape(cap)}'><p>{escape(cap)}</p>")
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

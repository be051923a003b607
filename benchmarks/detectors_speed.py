"""Milliseconds per 1080p frame of each detector dynaeval can run, through its own runtime.

    python benchmarks/detectors_speed.py [--repeats 5]      # Markdown table on stdout

Detectors: the bundled one (``dynaeval/models/detector.onnx``); ``fasterrcnn-mobilenet`` and
``retinanet`` exported by ``dynaeval.regions.fetch`` with **random weights** (this machine has no
network; the graph and its cost are the COCO model's, the boxes are not); ``yolov8n`` likewise
when the ``ultralytics`` package is installed. Each runs ``Detector.__call__`` (preparing the
input, onnxruntime, decoding, thresholds, NMS) on a 1920x1080 RGB photo (scikit-image's
``astronaut`` and ``coffee`` resized, alternating); one warm-up run, then the median of
``--repeats`` runs. The ratio column is against the bundled detector. Timings depend on the
machine and its load (uptime is printed).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def frames_1080p() -> list[np.ndarray]:
    import cv2
    from skimage import data

    return [cv2.resize(getattr(data, n)(), (1920, 1080), interpolation=cv2.INTER_LINEAR)
            for n in ("astronaut", "coffee")]


def detectors(folder: Path) -> list[tuple[str, str, Path | None]]:
    """``(name, what, onnx path)`` of every detector available here (path None: the bundled)."""
    from dynaeval.regions import fetch

    out: list[tuple[str, str, Path | None]] = [("bundled", "synthetic scenes, 416 px letterbox", None)]
    for name in ("fasterrcnn-mobilenet", "retinanet", "yolov8n"):
        try:
            path = fetch.fetch(name, folder=folder, pretrained=False, overwrite=True)
        except Exception as err:  # noqa: BLE001  (ultralytics missing: a row says so)
            out.append((name, f"not available: {err}", None))
            continue
        out.append((name, fetch.KNOWN[name].description + ", random weights", path))
    return out


def ms_per_frame(path: Path | None, frames: list[np.ndarray], repeats: int) -> float:
    from dynaeval.regions.detector import Detector, DetectorConfig

    det = Detector(DetectorConfig(model=path))
    det(frames[0])  # warm-up: session and allocations
    times = []
    for i in range(repeats):
        t0 = time.perf_counter()
        det(frames[i % len(frames)])
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    frames = frames_1080p()
    lines = ["| detector | what | ms per 1080p frame | x bundled |", "|---|---|---:|---:|"]
    base = None
    with tempfile.TemporaryDirectory() as tmp:
        for name, what, path in detectors(Path(tmp)):
            ms = None if what.startswith("not available") else ms_per_frame(path, frames, args.repeats)
            base = base or ms
            cells = ("n/a", "n/a") if ms is None else (f"{ms:.0f}", f"{ms / base:.1f}")
            lines.append(f"| {name} | {what} | {cells[0]} | {cells[1]} |")
            print(lines[-1], file=sys.stderr, flush=True)  # progress: the table comes at the end
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; median of "
          f"{args.repeats} runs, 1920x1080 frames\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()

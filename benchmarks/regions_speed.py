"""Wall-clock cost of motion weights/masks and of detector decoding, per 1080p frame.

    python benchmarks/regions_speed.py            # Markdown table on stdout

Motion: a synthetic 1920x1080 uint8 sequence (static noise texture, one moving 60x150 block) of
``--frames`` frames; IST with ``window`` >= T compares every frame with all others, i.e. ``T - 1``
frame differences per frame (a 25-frame window on a long sequence costs 50). Detector: a YOLO-style
ONNX graph (built with ``onnx.helper``) whose output is a constant ``(1, 84, 8400)`` of random
candidates, so the time is letterboxing + onnxruntime + decoding + NMS, not a network. Timings are
medians of ``--repeats`` runs, OpenCV limited to one thread; they depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def motion_rows(n_frames: int, repeats: int) -> list[tuple[str, float]]:
    from dynaeval.regions.motion import MotionConfig, importance_weights, motion_mask

    rng = np.random.default_rng(0)
    bg = rng.integers(60, 200, (1080, 1920, 3), dtype=np.uint8)
    frames = np.repeat(bg[None], n_frames, axis=0)
    for t in range(n_frames):
        frames[t, 400:550, 100 + 40 * t : 160 + 40 * t] = (230, 20, 20)
    per = 1.0 / n_frames
    return [
        ("ISG weights (median over all frames + weights)", per * median_time(lambda: importance_weights(frames, "isg"), repeats)),
        (f"IST weights ({n_frames - 1} differences per frame)", per * median_time(lambda: importance_weights(frames, "ist"), repeats)),
        ("ISG motion mask (weights + threshold + clean-up)", per * median_time(lambda: motion_mask(frames, MotionConfig()), repeats)),
    ]


def detector_row(repeats: int) -> tuple[str, float]:
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    from dynaeval.regions.detector import Detector, DetectorConfig

    rng = np.random.default_rng(0)
    pred = np.zeros((1, 84, 8400), np.float32)
    pred[0, 0:2] = rng.uniform(0, 640, (2, 8400))
    pred[0, 2:4] = rng.uniform(4, 80, (2, 8400))
    pred[0, 4:] = rng.uniform(0, 0.3, (80, 8400)) ** 2  # most candidates under the threshold
    pred[0, 4, rng.choice(8400, 300, replace=False)] = rng.uniform(0.3, 1.0, 300)  # 300 "persons"
    nodes = [
        helper.make_node("ReduceSum", ["images"], ["s"], keepdims=0),
        helper.make_node("Mul", ["s", "zero"], ["z"]),
        helper.make_node("Add", ["pred", "z"], ["output0"]),
    ]
    graph = helper.make_graph(
        nodes, "yolo_const",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, 640, 640])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, [1, 84, 8400])],
        initializer=[numpy_helper.from_array(pred, "pred"), numpy_helper.from_array(np.zeros((), np.float32), "zero")],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    image = np.random.default_rng(1).integers(0, 256, (1080, 1920, 3), dtype=np.uint8)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "yolo_const.onnx"
        onnx.save(model, str(path))
        det = Detector(DetectorConfig(model=path))
        n = len(det(image))
        return (f"YOLO-style decode of 8400 candidates, 300 above threshold -> {n} after NMS",
                median_time(lambda: det(image), repeats))


def main() -> None:
    import cv2

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    rows = motion_rows(args.frames, args.repeats) + [detector_row(args.repeats)]
    print("| step (1920x1080) | seconds per frame |")
    print("|---|---|")
    for name, sec in rows:
        print(f"| {name} | {sec:.3f} |")
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"\n(load average during the run: {load} on {os.cpu_count()} CPUs)")


if __name__ == "__main__":
    main()

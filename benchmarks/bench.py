"""Per-frame time and accuracy of dynaeval's metrics against their peers: ``python benchmarks/bench.py``.

For each frame size it times PSNR, SSIM and LPIPS (AlexNet with a *randomly initialised* backbone:
the pretrained one cannot be downloaded here, and the cost does not depend on the weights) for
dynaeval, scikit-image, torchmetrics and the lpips package where installed, and reports each one's
deviation from a float64 reference:

* PSNR: numpy, difference and mean in float64;
* SSIM: scikit-image's Gaussian SSIM on float64 input (float64 throughout; the tests hold
  ``dynaeval.metrics.ssim_reference``, an independent sliding-window float64 SSIM, to it at 1e-12);
* LPIPS: the lpips package's network converted to float64, on float64 input.

It also times the focused (boxes) and masked variants and measures how far the crop and map
definitions of focused SSIM / LPIPS are apart. The table is printed and written to
docs/benchmarks.md (``--out``, relative to the current directory: run it from the repository root)
with the command and the machine. Not part of the ``dynaeval`` wheel (it was ``python -m
dynaeval.bench`` until the benchmark left the package).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import dynaeval
from dynaeval import __version__

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))

DEFAULT_SIZES = ("1920x1080", "960x540")


def sample_pair(height: int, width: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A procedural 'pitch with players' frame, a degraded prediction and the player boxes.

    Returns ``(pred, gt, boxes)``: (H, W, 3) float32 in [0, 1] and (N, 4) int64 boxes. The
    prediction is the ground truth blurred and noised everywhere a little, and much more inside
    the boxes (a renderer that struggles with the moving players).
    """
    import cv2

    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    stripes = 0.5 + 0.08 * np.sin(x * (2 * np.pi / (width / 9)))
    grass = np.stack([0.2 * stripes, 0.9 * stripes, 0.25 * stripes], axis=-1)
    grass += 0.03 * rng.standard_normal((height, width, 3)).astype(np.float32)
    gt = grass
    boxes = []
    for _ in range(6):
        bh = int(height * rng.uniform(0.08, 0.2))
        bw = max(4, bh // 3)
        x0 = int(rng.integers(0, width - bw))
        y0 = int(rng.integers(0, height - bh))
        colour = rng.random(3).astype(np.float32)
        patch = colour + 0.15 * rng.standard_normal((bh, bw, 3)).astype(np.float32)
        gt[y0 : y0 + bh, x0 : x0 + bw] = patch
        boxes.append([x0 - bw, y0 - bh // 4, x0 + 2 * bw, y0 + bh + bh // 4])  # expanded box
    gt = np.clip(gt, 0, 1).astype(np.float32)
    pred = cv2.GaussianBlur(gt, (5, 5), 0.7) + 0.01 * rng.standard_normal(gt.shape).astype(np.float32)
    for x0, y0, x1, y1 in boxes:
        x0, y0 = max(0, x0), max(0, y0)
        region = pred[y0:y1, x0:x1]
        pred[y0:y1, x0:x1] = cv2.GaussianBlur(region, (9, 9), 2.5) + 0.05 * rng.standard_normal(
            region.shape
        ).astype(np.float32)
    return np.clip(pred, 0, 1).astype(np.float32), gt, np.array(boxes, dtype=np.int64)


def _time(fn: Callable[[], Any], repeats: int) -> tuple[float, float, Any]:
    """Minimum wall time and minimum CPU time (this process, all threads) in seconds of ``fn()``.

    One warm-up run first; slow paths (> 2 s) get 2 timed runs. The minimum is the run least
    disturbed by other jobs. CPU time is what the path costs on a machine shared with other
    jobs, where wall time mostly measures the wait for a core.
    """
    value = fn()
    walls: list[float] = []
    cpus: list[float] = []
    while len(walls) < (repeats if not walls or walls[0] < 2.0 else 2):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return min(walls), min(cpus), value


PEERS = ("skimage", "torchmetrics")


def _peers(selected: tuple[str, ...] = PEERS) -> dict[str, Any]:
    """The selected peer libraries that are installed (absent ones are left out of the table)."""
    found: dict[str, Any] = {}
    if "skimage" in selected:
        try:
            import skimage.metrics as skm

            found["skimage"] = skm
        except ImportError:
            pass
    if "torchmetrics" in selected:
        try:
            import torchmetrics.functional.image as tmf

            found["torchmetrics"] = tmf
        except ImportError:
            pass
    return found


def _nchw(a: np.ndarray) -> Any:
    import torch

    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)[None]))


def bench_size(
    height: int, width: int, repeats: int, with_lpips: bool, peers: tuple[str, ...] = PEERS
) -> list[dict[str, Any]]:
    """Rows ``{metric, impl, size, ms, dev}`` for one frame size."""
    from dynaeval import metrics as M
    from dynaeval.core.boxes import boxes_to_mask

    pred, gt, boxes = sample_pair(height, width)
    p64, g64 = pred.astype(np.float64), gt.astype(np.float64)
    size = f"{width}x{height}"
    peers = _peers(peers)
    rows: list[dict[str, Any]] = []

    def add(metric: str, impl: str, fn: Callable[[], Any], ref: float | None) -> float:
        wall, cpu, value = _time(fn, repeats)
        value = float(value)
        dev = None if ref is None else abs(value - ref)
        rows.append({"metric": metric, "impl": impl, "size": size, "ms": 1e3 * wall, "cpu_ms": 1e3 * cpu, "dev": dev, "value": value})
        return value

    # PSNR
    ref_psnr = 10 * math.log10(1.0 / float(np.mean((p64 - g64) ** 2)))
    add("psnr", "dynaeval", lambda: M.psnr(pred, gt), ref_psnr)
    if "skimage" in peers:
        add("psnr", "scikit-image", lambda: peers["skimage"].peak_signal_noise_ratio(gt, pred, data_range=1.0), ref_psnr)
    if "torchmetrics" in peers:
        tp, tg = _nchw(pred), _nchw(gt)
        add("psnr", "torchmetrics", lambda: peers["torchmetrics"].peak_signal_noise_ratio(tp, tg, data_range=1.0), ref_psnr)

    # SSIM
    sk_kw = {"gaussian_weights": True, "sigma": 1.5, "use_sample_covariance": False, "data_range": 1.0, "channel_axis": -1}
    ref_ssim = None
    if "skimage" in peers:
        ref_ssim = float(peers["skimage"].structural_similarity(p64, g64, **sk_kw))
    add("ssim", "dynaeval", lambda: M.ssim(pred, gt), ref_ssim)
    add("ssim", "dynaeval, 2 threads over bands", lambda: M.ssim(pred, gt, threads=2), ref_ssim)

    def gt_side_pass() -> float:
        # one of the fast path's four filter passes: the GT-side moment a per-GT cache could reuse
        import cv2

        from dynaeval.metrics.structural import _kernel

        k = _kernel()
        return float(cv2.sepFilter2D(gt - np.float32(0.5), cv2.CV_32F, k, k).mean())

    add("ssim", "GT-side filter pass alone (what caching mu_g saves per method)", gt_side_pass, None)
    if "skimage" in peers:
        add("ssim", "scikit-image (float32 in)", lambda: peers["skimage"].structural_similarity(pred, gt, **sk_kw), ref_ssim)
        add("ssim", "scikit-image (float64 in)", lambda: peers["skimage"].structural_similarity(p64, g64, **sk_kw), ref_ssim)
    if "torchmetrics" in peers:
        tp, tg = _nchw(pred), _nchw(gt)
        add(
            "ssim",
            "torchmetrics",
            lambda: peers["torchmetrics"].structural_similarity_index_measure(
                tp, tg, gaussian_kernel=True, sigma=1.5, kernel_size=11, data_range=1.0
            ),
            ref_ssim,
        )

    # decoding one ground-truth frame (8-bit PNG, as renders are stored) costs about one SSIM
    import tempfile

    import cv2

    from dynaeval.io.images import read_image

    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "gt.png"
        cv2.imwrite(str(png), cv2.cvtColor((gt * 255).round().astype(np.uint8), cv2.COLOR_RGB2BGR))
        add("decode", "dynaeval read_image (8-bit PNG -> float32)", lambda: float(read_image(png).mean()), None)

    # focused / masked PSNR and SSIM
    mask = boxes_to_mask(boxes, height, width)
    add("focused_psnr", "dynaeval", lambda: M.focused_psnr(pred, gt, boxes), None)
    add("masked_psnr", "dynaeval (box union as mask)", lambda: M.masked_psnr(pred, gt, mask), None)
    add("focused_ssim", "dynaeval crop (default)", lambda: M.focused_ssim(pred, gt, boxes), None)
    add("focused_ssim", "dynaeval map", lambda: M.focused_ssim(pred, gt, boxes, region_mode="map"), None)
    add("masked_ssim", "dynaeval (box union as mask)", lambda: M.masked_ssim(pred, gt, mask), None)

    if with_lpips:
        rows.extend(_bench_lpips(pred, gt, boxes, mask, size, repeats))
    return rows


def _bench_lpips(pred, gt, boxes, mask, size, repeats) -> list[dict[str, Any]]:  # noqa: ANN001
    import torch

    from dynaeval import metrics as M

    kw = {"pretrained_backbone": False, "seed": 0}
    model = M.load_lpips("alex", **kw)
    import copy

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model64 = copy.deepcopy(model).double()
    tp, tg = _nchw(pred) * 2 - 1, _nchw(gt) * 2 - 1
    with torch.no_grad():
        ref = float(model64(tp.double(), tg.double()).item())
    rows: list[dict[str, Any]] = []

    def add(metric: str, impl: str, fn: Callable[[], Any], ref_value: float | None) -> None:
        wall, cpu, value = _time(fn, repeats)
        value = float(value)
        dev = None if ref_value is None else abs(value - ref_value)
        rows.append({"metric": metric, "impl": impl, "size": size, "ms": 1e3 * wall, "cpu_ms": 1e3 * cpu, "dev": dev, "value": value})

    def package() -> float:
        with torch.no_grad():
            return float(model(tp, tg).item())

    model_cl = copy.deepcopy(model).to(memory_format=torch.channels_last)
    tpc = tp.contiguous(memory_format=torch.channels_last)
    tgc = tg.contiguous(memory_format=torch.channels_last)

    def package_channels_last() -> float:
        with torch.no_grad():
            return float(model_cl(tpc, tgc).item())

    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        small = (tp[..., :128, :128], tg[..., :128, :128])
        frozen = torch.jit.optimize_for_inference(torch.jit.freeze(torch.jit.trace(model, small)))

    def package_frozen() -> float:
        with torch.no_grad():
            return float(frozen(tp, tg).item())

    add("lpips", "dynaeval (alex, random backbone)", lambda: M.lpips(pred, gt, **kw), ref)
    add("lpips", "dynaeval backend=onnxruntime", lambda: M.lpips(pred, gt, backend="onnxruntime", **kw), ref)
    add("lpips", "lpips package, same network", package, ref)
    add("lpips", "lpips package, channels_last", package_channels_last, ref)
    add("lpips", "lpips package, TorchScript frozen (oneDNN)", package_frozen, ref)
    add("lpips_map", "dynaeval", lambda: float(M.lpips_map(pred, gt, **kw).mean()), None)
    add(
        "lpips_map",
        "dynaeval backend=onnxruntime",
        lambda: float(M.lpips_map(pred, gt, backend="onnxruntime", **kw).mean()),
        None,
    )
    add("focused_lpips", "dynaeval crop (default)", lambda: M.focused_lpips(pred, gt, boxes, **kw), None)
    add(
        "focused_lpips",
        "dynaeval crop, backend=onnxruntime",
        lambda: M.focused_lpips(pred, gt, boxes, backend="onnxruntime", **kw),
        None,
    )
    add("focused_lpips", "dynaeval map", lambda: M.focused_lpips(pred, gt, boxes, region_mode="map", **kw), None)
    add("masked_lpips", "dynaeval (box union as mask)", lambda: M.masked_lpips(pred, gt, mask, **kw), None)
    return rows


def backbone_macs(net: str, height: int, width: int) -> int:
    """Multiply-accumulates of the LPIPS backbone's convolutions on one (height, width) image
    (counted by forward hooks on the package's network; the lin layers add < 0.1 %)."""
    import torch

    from dynaeval import metrics as M

    model = M.load_lpips(net, pretrained_backbone=False)
    total = 0

    def hook(mod, inp, out) -> None:  # noqa: ANN001
        nonlocal total
        k = mod.kernel_size[0] * mod.kernel_size[1] * mod.in_channels // mod.groups
        total += out.numel() * k

    handles = [m.register_forward_hook(hook) for m in model.net.modules()
               if isinstance(m, torch.nn.Conv2d)]
    try:
        with torch.no_grad():
            model.net(torch.zeros(1, 3, height, width))
    finally:
        for h in handles:
            h.remove()
    return total


def sgemm_gflops(n: int = 2048, repeats: int = 5) -> float:
    """Single-precision matrix multiply rate of this process (GFLOP per CPU second, torch's
    current threads), best of ``repeats``: the rate no convolution of the same FLOPs beats."""
    import torch

    a, b = torch.randn(n, n), torch.randn(n, n)
    a @ b
    best = _time(lambda: a @ b, repeats)[1]
    return 2 * n**3 / best / 1e9


def lpips_floor(rows: list[dict[str, Any]]) -> str:
    """Markdown table: per size, the LPIPS pair's backbone FLOPs at this run's SGEMM rate (the
    arithmetic floor) against the measured LPIPS rows (CPU time)."""
    rate = sgemm_gflops()
    lines = [f"SGEMM 2048x2048 in this process: **{rate:.0f} GFLOP/s** (CPU time, torch threads as "
             "above).", "",
             "| size | backbone GFLOP per pair | floor CPU ms | implementation | CPU ms | / floor "
             "| package / it | package / floor |",
             "|---|---:|---:|---|---:|---:|---:|---:|"]
    for size in dict.fromkeys(r["size"] for r in rows if r["metric"] == "lpips"):
        w, h = (int(v) for v in size.split("x"))
        gflop = 2 * 2 * backbone_macs("alex", h, w) / 1e9  # two images, 2 FLOP per MAC
        floor = 1e3 * gflop / rate
        group = [r for r in rows if r["metric"] == "lpips" and r["size"] == size]
        package = next(r for r in group if r["impl"] == "lpips package, same network")
        for r in group:
            lines.append(f"| {size} | {gflop:.1f} | {floor:.0f} | {r['impl']} | {r['cpu_ms']:.0f} "
                         f"| {r['cpu_ms'] / floor:.2f} | {package['cpu_ms'] / r['cpu_ms']:.2f} "
                         f"| {package['cpu_ms'] / floor:.2f} |")
    return "\n".join(lines)


def sample_sequence(height: int, width: int, frames: int = 4, seed: int = 0) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``frames`` consecutive (gt, pred) frames of a static camera: the ``sample_pair`` pitch with a
    player-sized patch moving 1 % of the width per frame; predictions blurred and noised.

    Returns two lists of (H, W, 3) float32 frames in [0, 1] (ground truth, prediction).
    """
    import cv2

    rng = np.random.default_rng(seed)
    _, base, _ = sample_pair(height, width, seed)
    bh, bw = max(8, height // 8), max(4, height // 24)
    patch = np.clip(rng.random(3) + 0.1 * rng.standard_normal((bh, bw, 3)), 0, 1).astype(np.float32)
    gts, preds = [], []
    for i in range(frames):
        gt = base.copy()
        x0, y0 = width // 4 + i * max(1, width // 100), height // 2
        gt[y0 : y0 + bh, x0 : x0 + bw] = patch
        pred = cv2.GaussianBlur(gt, (5, 5), 1.0) + 0.01 * rng.standard_normal(gt.shape).astype(np.float32)
        gts.append(gt)
        preds.append(np.clip(pred, 0, 1).astype(np.float32))
    return gts, preds


def bench_sequence(height: int, width: int, repeats: int, with_lpips: bool) -> list[dict[str, Any]]:
    """Rows for the per-frame regions and temporal paths: motion masks, optical flow, warping
    (fast vs its float64 reference), the temporal metrics and the detector (when installed)."""
    from dynaeval.metrics.flow import FlowConfig, optical_flow, warp, warp_reference
    from dynaeval.metrics.temporal import TemporalConfig, temporal_metrics
    from dynaeval.regions.motion import MotionConfig, iter_motion_masks

    frames = 4
    gts, preds = sample_sequence(height, width, frames)
    size = f"{width}x{height}"
    rows: list[dict[str, Any]] = []

    def add(metric: str, impl: str, fn: Callable[[], Any], per: int, ref: float | None = None,
            value_of: Callable[[Any], float] = float) -> None:
        wall, cpu, value = _time(fn, repeats)
        v = value_of(value)
        dev = None if ref is None else abs(v - ref)
        rows.append({"metric": metric, "impl": impl, "size": size, "ms": 1e3 * wall / per,
                     "cpu_ms": 1e3 * cpu / per, "dev": dev, "value": v})

    add("motion_mask (isg)", "dynaeval, per frame of 4", lambda: list(iter_motion_masks(gts, MotionConfig())),
        frames, value_of=lambda ms: float(np.mean([m.mean() for m in ms])))
    add("motion_mask (ist)", "dynaeval, per frame of 4",
        lambda: list(iter_motion_masks(gts, MotionConfig(kind="ist", window=2))),
        frames, value_of=lambda ms: float(np.mean([m.mean() for m in ms])))
    for method in ("dis", "farneback"):
        cfg = FlowConfig(method=method)
        add("optical_flow", f"dynaeval {method}", lambda cfg=cfg: optical_flow(gts[0], gts[1], cfg), 1,
            value_of=lambda f: float(np.abs(f).mean()))
    flow = optical_flow(gts[1], gts[0], FlowConfig())
    ref_warp = float(warp_reference(gts[0].astype(np.float64), flow.astype(np.float64)).mean())
    add("warp", "dynaeval (cv2.remap)", lambda: warp(gts[0], flow), 1, ref_warp, lambda w: float(w.mean(dtype=np.float64)))
    region = [np.zeros((height, width), bool) for _ in range(frames)]
    for m in region:
        m[height // 2 - 10 : height // 2 + height // 8 + 10, width // 4 - 10 : width // 4 + width // 20 + 10] = True
    static = np.ones((height, width), bool)
    static[height // 2 - 20 :, :] = False
    tcfg = TemporalConfig(tlp=with_lpips)
    variants: list[tuple[str, dict[str, Any]]] = [("dynaeval, per frame of 4", {})]
    if with_lpips:
        from dynaeval import metrics as M

        variants = [
            ("dynaeval, per frame of 4 (LpipsFeatures: each frame's features once)",
             {"lpips_fn": M.perceptual.LpipsFeatures(pretrained_backbone=False, seed=0)}),
            ("dynaeval, per frame of 4 (LPIPS per pair: 4 backbone runs per pair)",
             {"lpips_fn": lambda a, b: M.lpips(a, b, pretrained_backbone=False, seed=0)}),
        ]
    for impl, kw in variants:
        add("temporal_metrics" + (" (with tLP)" if with_lpips else " (no tLP)"), impl,
            lambda kw=kw: temporal_metrics(iter(preds), iter(gts), static_mask=static,
                                           region_masks=region, config=tcfg, **kw),
            frames, value_of=lambda r: float(r["warp_error"].outcome.value))
    try:
        from dynaeval.regions.detector import DEFAULT_DETECTOR, Detector

        if DEFAULT_DETECTOR.is_file():
            det = Detector()
            add("detector", "dynaeval ONNX (shipped model)", lambda: det(gts[0]), 1,
                value_of=lambda d: float(len(d.records())))
    except ImportError:
        pass
    return rows


def speed_error_plot(rows: list[dict[str, Any]], path: Path) -> None:
    """Log-log scatter of CPU ms per frame against deviation from the float64 reference (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = [r for r in rows if r["dev"] is not None]
    sizes = list(dict.fromkeys(r["size"] for r in pts))
    fig, axes = plt.subplots(1, len(sizes), figsize=(6.5 * len(sizes), 5), squeeze=False)
    for ax, size in zip(axes[0], sizes, strict=True):
        for r in (r for r in pts if r["size"] == size):
            dev = max(r["dev"], 1e-17)
            marker = "o" if r["impl"].startswith("dynaeval") else "x"
            ax.scatter(r["cpu_ms"], dev, marker=marker)
            ax.annotate(f"{r['metric']}: {r['impl']}", (r["cpu_ms"], dev), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU ms per frame (min over runs)")
        ax.set_ylabel("abs. deviation from float64 reference (0 drawn at 1e-17)")
        ax.set_title(f"speed vs error, {size} (o dynaeval, x peers)")
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


_RUSAGE_WRAPPER = """
import resource, subprocess, sys
code = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode
u = resource.getrusage(resource.RUSAGE_CHILDREN)
print(code, u.ru_utime + u.ru_stime, u.ru_maxrss)
"""


def score_throughput(pred: str, gt: str, workers: tuple[int, ...], extra: list[str],
                     rounds: int = 1) -> list[dict[str, Any]]:
    """Run ``python -m dynaeval score PRED GT --workers N`` in a child process for each N,
    ``rounds`` times with the worker counts alternating (1, 2, 1, 2, ...: a machine that speeds up
    or slows down during the runs affects every count alike).

    Returns one row per N, its fastest round: ``{workers, frames, wall_s, wall_max_s, cpu_s, fps,
    max_rss_mb, rounds}`` (``wall_max_s``: the slowest round). CPU time and peak RSS come from
    ``getrusage(RUSAGE_CHILDREN)`` in a small wrapper process that starts the score: a process
    exec'd straight from this (large) one inherits this one's resident size as its
    ``ru_maxrss`` on Linux, which would hide the score's own peak.
    """
    runs: dict[int, list[dict[str, Any]]] = {n: [] for n in workers}
    for _ in range(max(1, rounds)):
        for n in workers:
            runs[n].append(_score_once(pred, gt, n, extra))
    rows = []
    for done in runs.values():
        best = min(done, key=lambda r: r["wall_s"])
        rows.append({**best, "wall_max_s": max(r["wall_s"] for r in done), "rounds": len(done)})
    return rows


def _score_once(pred: str, gt: str, n: int, extra: list[str]) -> dict[str, Any]:
    """One ``score_throughput`` run with ``n`` workers."""
    import json
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "results.json"
        cmd = [sys.executable, "-m", "dynaeval", "score", pred, gt, "--workers", str(n), "-q",
               "-o", str(out), *extra]
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _RUSAGE_WRAPPER, *cmd], capture_output=True,
                              text=True, check=False)
        wall = time.perf_counter() - t0
        code, cpu, rss = proc.stdout.split()[-3:] if proc.stdout.strip() else ("1", "0", "0")
        if proc.returncode != 0 or code != "0":
            raise RuntimeError(f"{' '.join(cmd)} failed ({code}): {proc.stderr[-2000:]}")
        frames = len(json.loads(out.read_text())["frames"])
    return {"workers": n, "frames": frames, "wall_s": wall, "cpu_s": float(cpu),
            "fps": frames / wall, "max_rss_mb": int(rss) / 1024, "command": " ".join(cmd[1:])}


def degrade_folder(src: str | Path, dst: str | Path, seed: int = 0) -> int:
    """Write a stand-in prediction for every PNG under ``src`` to the same relative path under
    ``dst``: Gaussian blur (5x5, sigma 1.2) plus Gaussian noise (sigma 3 of 255), 8-bit PNG.

    For throughput runs only (the cost of scoring does not depend on what the method did).
    Returns the number of frames written.
    """
    import cv2

    rng = np.random.default_rng(seed)
    src, dst = Path(src), Path(dst)
    count = 0
    for f in sorted(src.rglob("*.png")):
        img = cv2.imread(str(f), cv2.IMREAD_COLOR).astype(np.float32)
        out = cv2.GaussianBlur(img, (5, 5), 1.2) + rng.normal(0.0, 3.0, img.shape)
        target = dst / f.relative_to(src)
        target.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(target), np.clip(out, 0, 255).astype(np.uint8))
        count += 1
    return count


def sample_scene_crop_vs_map(with_lpips: bool = True) -> str:
    """Markdown table: focused SSIM/LPIPS by crop and by map on the bundled sample scene.

    Ground-truth boxes of ``dynaeval/data/sample/boxes.json`` expanded with the ``paper`` rule
    (clipped, merged), scored per frame; reports the mean over frames of each definition and the
    mean and largest absolute per-frame difference. LPIPS uses the random AlexNet backbone.
    """
    from dynaeval import metrics as M
    from dynaeval.io.images import read_image
    from dynaeval.regions.boxes_file import read_boxes_file, records_to_boxes
    from dynaeval.regions.expand import expand_boxes

    root = Path(dynaeval.__file__).resolve().parent / "data" / "sample"
    records = read_boxes_file(root / "boxes.json").boxes
    values: dict[str, list[tuple[float, float]]] = {"focused_ssim": [], "focused_lpips": []}
    for key in sorted(records):
        gt = read_image(root / "gt" / f"{key}.png")
        pred = read_image(root / "pred" / f"{key}.png")
        boxes = expand_boxes(records_to_boxes(records[key]), "paper", *gt.shape[:2])
        if len(boxes) == 0:
            continue
        values["focused_ssim"].append(
            (M.focused_ssim(pred, gt, boxes), M.focused_ssim(pred, gt, boxes, region_mode="map"))
        )
        if with_lpips:
            kw = {"pretrained_backbone": False, "seed": 0}
            values["focused_lpips"].append(
                (
                    M.focused_lpips(pred, gt, boxes, **kw),
                    M.focused_lpips(pred, gt, boxes, region_mode="map", **kw),
                )
            )
    lines = [
        "| metric | frames | mean crop (default) | mean map | mean map - crop | max abs. per-frame difference |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for metric, pairs in values.items():
        if not pairs:
            continue
        arr = np.array(pairs)
        diff = arr[:, 1] - arr[:, 0]
        lines.append(
            f"| {metric} | {len(arr)} | {arr[:, 0].mean():.4f} | {arr[:, 1].mean():.4f} "
            f"| {diff.mean():+.4f} | {np.abs(diff).max():.4f} |"
        )
    return "\n".join(lines)


def _machine() -> str:
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    return f"{os.cpu_count()} CPUs (`nproc`), {model}; load average at start {load}"


def _versions() -> str:
    from importlib.metadata import PackageNotFoundError, version

    names = ["numpy", "opencv-contrib-python-headless", "scikit-image", "torch", "torchmetrics", "lpips"]
    parts = [f"dynaeval {__version__}", f"Python {platform.python_version()}"]
    for name in names:
        try:
            parts.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            pass
    return ", ".join(parts)


def format_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of the rows, with each implementation's CPU time relative to dynaeval's."""
    base: dict[tuple[str, str], float] = {}
    for r in rows:  # the first dynaeval row of each metric and size is the default path
        if r["impl"].startswith("dynaeval") and "map" not in r["impl"].split():
            base.setdefault((r["metric"], r["size"]), r["cpu_ms"])
    lines = [
        "| metric | size | implementation | wall ms / frame | CPU ms / frame | CPU time x dynaeval | abs. deviation from float64 reference | value |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        key = (r["metric"], r["size"])
        ratio = f"{r['cpu_ms'] / base[key]:.2f}" if key in base and base[key] > 0 else "—"
        dev = "—" if r["dev"] is None else f"{r['dev']:.1e}"
        lines.append(
            f"| {r['metric']} | {r['size']} | {r['impl']} | {r['ms']:.1f} | {r['cpu_ms']:.1f} | {ratio} "
            f"| {dev} | {r['value']:.6f} |"
        )
    return "\n".join(lines)


def crop_vs_map(rows: list[dict[str, Any]]) -> str:
    """Markdown lines: value of the crop and map definitions of focused SSIM/LPIPS and their gap."""
    out = []
    for metric in ("focused_ssim", "focused_lpips"):
        for size in dict.fromkeys(r["size"] for r in rows):
            vals = {r["impl"].split()[1]: r for r in rows if r["metric"] == metric and r["size"] == size}
            if "crop" in vals and "map" in vals:
                c, m = vals["crop"], vals["map"]
                out.append(
                    f"| {metric} | {size} | {c['value']:.4f} | {m['value']:.4f} | {m['value'] - c['value']:+.4f} "
                    f"| {c['cpu_ms']:.0f} | {m['cpu_ms']:.0f} |"
                )
    head = [
        "| metric | size | crop (default) | map | map - crop | crop CPU ms | map CPU ms |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    return "\n".join(head + out)


def peer_ratios(rows: list[dict[str, Any]], tol: float = 1e-6) -> str:
    """Markdown table: per metric and size, dynaeval's default path against the fastest peer whose
    deviation from the float64 reference is within ``tol`` (equal accuracy), in CPU time."""
    lines = [
        f"| metric | size | dynaeval CPU ms | fastest peer within {tol:g} | peer CPU ms | peer / dynaeval |",
        "|---|---|---:|---|---:|---:|",
    ]
    keys = list(dict.fromkeys((r["metric"], r["size"]) for r in rows))
    for key in keys:
        group = [r for r in rows if (r["metric"], r["size"]) == key]
        ours = next((r for r in group if r["impl"].startswith("dynaeval")), None)
        peers = [r for r in group if not r["impl"].startswith("dynaeval") and r["dev"] is not None
                 and r["dev"] <= tol and "lpips package" not in r["impl"]]
        if ours is None or not peers:
            continue
        best = min(peers, key=lambda r: r["cpu_ms"])
        lines.append(f"| {key[0]} | {key[1]} | {ours['cpu_ms']:.1f} | {best['impl']} | {best['cpu_ms']:.1f} "
                     f"| {best['cpu_ms'] / ours['cpu_ms']:.2f} |")
    return "\n".join(lines)


_THREADS_CHILD = """
import copy, sys, time, warnings
import numpy as np, torch
warnings.simplefilter("ignore")
threads = int(sys.argv[1])
sys.path.insert(0, sys.argv[2])  # this file's folder
torch.set_num_threads(threads)
from dynaeval import metrics as M
from bench import _nchw, _time, sample_pair
p, g, _ = sample_pair(1080, 1920)
model = M.load_lpips("alex", pretrained_backbone=False)
mcl = copy.deepcopy(model).to(memory_format=torch.channels_last)
tp = (_nchw(p) * 2 - 1).contiguous(memory_format=torch.channels_last)
tg = (_nchw(g) * 2 - 1).contiguous(memory_format=torch.channels_last)
def cl():
    with torch.no_grad():
        return float(mcl(tp, tg).item())
paths = {
    "dynaeval (lpips package module)": lambda: M.lpips(p, g, pretrained_backbone=False),
    "lpips package, channels_last": cl,
    "dynaeval backend=onnxruntime": lambda: M.lpips(p, g, pretrained_backbone=False,
                                                    backend="onnxruntime", threads=threads),
}
for name, fn in paths.items():
    wall, cpu, _ = _time(fn, 3)
    print(name, "|", wall, cpu)
"""


def torch_threads_study() -> str:
    """Markdown table: LPIPS (1920x1080) with intra-op threads 1 and 2, OpenMP spinning on (the
    default) and off (``OMP_WAIT_POLICY=PASSIVE``), each setting in a fresh child process."""
    import subprocess

    lines = ["| threads | OMP_WAIT_POLICY | path | wall ms | CPU ms |", "|---:|---|---|---:|---:|"]
    for threads, policy in ((1, None), (2, None), (2, "PASSIVE")):
        env = dict(os.environ)
        env.pop("OMP_WAIT_POLICY", None)
        if policy:
            env["OMP_WAIT_POLICY"] = policy
        out = subprocess.run([sys.executable, "-c", _THREADS_CHILD, str(threads),
                              str(Path(__file__).resolve().parent)], env=env,
                             capture_output=True, text=True, check=True).stdout
        for line in out.strip().splitlines():
            name, times = line.rsplit("|", 1)
            wall, cpu = (float(v) for v in times.split())
            lines.append(f"| {threads} | {policy or '(unset: spinning)'} | {name.strip()} "
                         f"| {1e3 * wall:.0f} | {1e3 * cpu:.0f} |")
    return "\n".join(lines)


def _throughput_table(rows: list[dict[str, Any]]) -> str:
    """Markdown rows of ``score_throughput``; speed-up: wall of the first row's worker count over
    this row's (best rounds)."""
    lines = ["| workers | frames | wall s (best; slowest) | speed-up | CPU s | frames / s (wall) "
             "| CPU s / frame | peak RSS MB |", "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['workers']} | {r['frames']} | {r['wall_s']:.1f}; {r['wall_max_s']:.1f} "
                     f"| {rows[0]['wall_s'] / r['wall_s']:.2f} | {r['cpu_s']:.1f} | {r['fps']:.3f} "
                     f"| {r['cpu_s'] / r['frames']:.2f} | {r['max_rss_mb']:.0f} |")
    return "\n".join(lines)


COMMAND = "python benchmarks/bench.py"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default=",".join(DEFAULT_SIZES), help="comma-separated WxH list")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per path (minimum reported)")
    parser.add_argument("--no-lpips", action="store_true", help="skip the LPIPS paths")
    parser.add_argument("--no-sequence", action="store_true",
                        help="skip motion masks, optical flow, temporal metrics and the detector")
    parser.add_argument("--out", default="docs/benchmarks.md", help="markdown file to write ('-': none)")
    parser.add_argument("--plot", default=None,
                        help="speed-vs-error PNG to write (default: img/bench_speed_error.png next to "
                        "--out; '-': none)")
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=1,
        help="torch intra-op threads for LPIPS/torchmetrics (default 1: on a shared 2-core machine "
        "a second spinning OpenMP thread doubles LPIPS' CPU time, see --threads-study; 0 keeps "
        "torch's default)",
    )
    parser.add_argument("--threads-study", action="store_true",
                        help="also time LPIPS with torch threads 1 / 2 / 2 without OpenMP spinning")
    parser.add_argument("--peers", default=",".join(PEERS), help="comma-separated peers to compare")
    parser.add_argument("--score", nargs=2, metavar=("PRED", "GT"), action="append",
                        help="also time whole `dynaeval score PRED GT` runs (frames/s, peak RSS); "
                        "repeatable")
    parser.add_argument("--degrade", nargs=2, metavar=("SRC", "DST"),
                        help="only write blurred+noised stand-in predictions of the PNGs in SRC to "
                        "DST (for --score) and exit")
    parser.add_argument("--make-job", metavar="DIR",
                        help="first write benchmarks.temporal_speed.make_job's 1080p job (the bundled "
                        "sample upscaled, 2 cameras x 8 frames) to DIR/{pred,gt} unless it is there, "
                        "so --score DIR/pred DIR/gt runs on a fresh machine")
    parser.add_argument("--score-workers", default="1,2", help="worker counts for --score")
    parser.add_argument("--score-rounds", type=int, default=3,
                        help="rounds of --score runs, worker counts alternating (fastest reported)")
    parser.add_argument("--score-args", default="", help="extra arguments for --score (one string)")
    return parser


def _sizes(text: str) -> list[tuple[int, int]]:
    """``"1920x1080,960x540"`` -> ``[(1080, 1920), (540, 960)]`` (height, width)."""
    sizes = []
    for item in text.split(","):
        w, h = (int(v) for v in item.lower().split("x"))
        sizes.append((h, w))
    return sizes


def _measure(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every timed path of every frame size: the rows of the main table."""
    rows: list[dict[str, Any]] = []
    for h, w in _sizes(args.sizes):
        rows.extend(bench_size(h, w, args.repeats, not args.no_lpips, tuple(args.peers.split(","))))
        if not args.no_sequence:
            rows.extend(bench_sequence(h, w, args.repeats, not args.no_lpips))
    return rows


def _head_section(command: str, started: str, machine: str, args: argparse.Namespace,
                  rows: list[dict[str, Any]], table: str) -> list[str]:
    """Title, provenance, how to read the numbers, the main table and the peer ratios."""
    return [
        "# Benchmarks",
        "",
        f"Command: `{command}` — run {started}.",
        f"Machine: {machine}.",
        f"Versions: {_versions()}; torch threads: {args.torch_threads or 'default'}.",
        "",
        "Minimum over the timed runs (after one warm-up run) of the wall and the CPU time (this",
        "process, all its threads) per frame of one prediction/ground-truth pair (float32 RGB, the",
        "procedural pitch-with-players frame of `benchmarks.bench.sample_pair`). On a machine shared",
        "with other jobs the wall time mostly measures the wait for a core: compare CPU times, and",
        "ratios measured in the same run. References: PSNR in float64 numpy; SSIM = scikit-image on",
        "float64 input; LPIPS = the same network in float64; warp = `warp_reference` in float64.",
        "LPIPS uses AlexNet with a random backbone (the pretrained one is not downloadable here; the",
        "cost does not depend on the weights); torchmetrics' LPIPS is absent because it needs the",
        "pretrained backbone. torchmetrics' SSIM pads the border instead of skipping it, hence its",
        "deviation. Sequence paths (motion masks, flow, temporal metrics) run on",
        "`benchmarks.bench.sample_sequence` (4 frames, a patch moving 1 % of the width per frame).",
        "",
        table,
        "",
        "## Against the fastest peer at equal accuracy",
        "",
        "CPU time of the fastest peer whose deviation from the float64 reference is within 1e-6,",
        "divided by dynaeval's default path (above 1: dynaeval is faster).",
        "",
        peer_ratios(rows),
        "",
    ]


def _lpips_floor_section(rows: list[dict[str, Any]]) -> list[str]:
    return [
        "## LPIPS against its arithmetic floor",
        "",
        "The pair's cost is the AlexNet backbone run on both images (conv FLOPs counted by",
        "`backbone_macs`); no implementation of the same float32 network can run it faster",
        "than a large matrix multiply of the same FLOPs (`sgemm_gflops`, measured in this",
        "process). `package / floor` is therefore the largest speed-up over the package any",
        "equal-precision fast path could show here.",
        "",
        lpips_floor(rows),
        "",
    ]


def _plot_section(args: argparse.Namespace, rows: list[dict[str, Any]]) -> list[str]:
    """Draws the speed-vs-error plot unless ``--plot -`` (or ``--out -`` without ``--plot``)."""
    plot = args.plot
    if plot is None:
        plot = "-" if args.out == "-" else str(Path(args.out).parent / "img" / "bench_speed_error.png")
    if plot == "-":
        return []
    speed_error_plot(rows, Path(plot))
    rel = os.path.relpath(plot, Path(args.out).parent if args.out != "-" else ".")
    return ["## Speed against error", "", f"![CPU time vs deviation]({rel})", ""]


def _threads_section() -> list[str]:
    return [
        "## Torch threads on a shared machine",
        "",
        "LPIPS of one 1920x1080 pair, each setting in a fresh process (`--threads-study`;",
        "onnxruntime gets the same number of intra-op threads, never spinning). With two",
        "intra-op threads OpenMP's waiting threads spin: when the other thread waits for a core",
        "that other jobs hold, the spinning burns CPU for nothing. Scoring therefore",
        "parallelises over frames (`--workers`) with one torch thread each; set",
        "`OMP_WAIT_POLICY=PASSIVE` before starting Python if you raise torch's threads.",
        "",
        torch_threads_study(),
        "",
    ]


def _score_section(args: argparse.Namespace, pred_dir: str, gt_dir: str) -> list[str]:
    """Whole ``dynaeval score`` runs of one ``--score PRED GT`` pair, one per worker count."""
    extra = args.score_args.split()
    workers = tuple(int(v) for v in args.score_workers.split(","))
    tp = score_throughput(pred_dir, gt_dir, workers, extra, args.score_rounds)
    return [
        f"## Whole `dynaeval score` runs: {gt_dir}",
        "",
        f"`python -m dynaeval score {pred_dir} {gt_dir} --workers N -q -o TMP "
        f"{args.score_args}`, each in a child process, {args.score_rounds} rounds with the worker "
        "counts alternating; each count's fastest round (its CPU time and peak resident memory",
        "(`ru_maxrss`) from `getrusage(RUSAGE_CHILDREN)` in a small wrapper process).",
        "",
        _throughput_table(tp),
        "",
    ]


def _crop_vs_map_section(gap: str, sample_gap: str) -> list[str]:
    return [
        "## Focused metrics: crop vs map",
        "",
        "Six expanded player boxes; the prediction is degraded a little everywhere and much",
        "more inside the boxes (see `sample_pair`). `map - crop` is the measured difference",
        "between the two definitions (docs/metrics.md).",
        "",
        gap,
        "",
        "On the bundled sample scene (`dynaeval/data/sample`, 256x144, one player and the ball,",
        "generator boxes expanded with the `paper` rule; predictions are the ground truth",
        "degraded by `reference_models.sample`):",
        "",
        sample_gap,
        "",
    ]


def _write(text: str, out: str) -> None:
    print(text)
    if out != "-":
        from benchmarks.sections import keep_sections

        Path(out).parent.mkdir(parents=True, exist_ok=True)
        old = Path(out).read_text() if Path(out).exists() else ""
        Path(out).write_text(keep_sections(old, text))  # other scripts' sections stay
        print(f"written to {out}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.degrade:
        n = degrade_folder(*args.degrade)
        print(f"{n} frames written to {args.degrade[1]}")
        return 0
    if args.make_job:
        from benchmarks.temporal_speed import make_job

        make_job(args.make_job)
    if args.torch_threads > 0 and not args.no_lpips:
        import torch

        torch.set_num_threads(args.torch_threads)
    machine = _machine()
    from benchmarks.sections import command_line, utc_stamp

    started = utc_stamp()
    rows = _measure(args)
    table = format_table(rows)
    gap = crop_vs_map(rows)
    sample_gap = sample_scene_crop_vs_map(not args.no_lpips)
    command = command_line(COMMAND, argv)
    parts = _head_section(command, started, machine, args, rows, table)
    if not args.no_lpips:
        parts += _lpips_floor_section(rows)
    parts += _plot_section(args, rows)
    if args.threads_study and not args.no_lpips:
        parts += _threads_section()
    for pred_dir, gt_dir in args.score or []:
        parts += _score_section(args, pred_dir, gt_dir)
    parts += _crop_vs_map_section(gap, sample_gap)
    _write("\n".join(parts), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

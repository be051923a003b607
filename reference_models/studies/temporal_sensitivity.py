"""Sensitivity study of the temporal metrics (issue 5): injected artefacts, flow accuracy, timing.

Starting from a ground-truth sequence of one static camera, inject (a) brightness flicker,
(b) frame drops (frame t shows frame t-1 again), (c) a ball that fades out on alternate frames,
(d) static vs temporally varying noise of the same per-frame PSNR, at several strengths, and
score each with per-frame PSNR/SSIM and the temporal metrics. Also: optical-flow endpoint error
against the exact flow, and time per frame pair at 960x540 and 1920x1080.

Ground truth, ``--source``: ``scenes`` (default) renders one static camera of
``reference_models.scenes`` (players-stadium, small) with its exact flow, boxes and a ball-less
render; ``synthetic`` uses a procedural 2-D soccer-like sequence made here
(``synthetic_sequence``: striped textured pitch, lines, crowd, textured players and a ball at
constant sub-pixel velocities, exact forward flow) at any resolution, and also times the metrics
at 960x540 and 1920x1080 (rendering hd scenes takes minutes per frame on this machine).

LPIPS: the pretrained AlexNet backbone is not available offline, so tLP uses the lpips package's
calibrated linear layers on a *random* AlexNet backbone (``pretrained_backbone=False, seed=0``):
the numbers show the metric's behaviour, not calibrated LPIPS values.

Deterministic: fixed seeds, no timing in the tables except the timing table.

    python -m reference_models.studies.temporal_sensitivity --write                     # scenes
    python -m reference_models.studies.temporal_sensitivity --source synthetic --write  # + timing
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

from dynaeval.core.boxes import mask_to_box
from dynaeval.metrics import lpips as lpips_metric
from dynaeval.metrics import psnr_from_stats, squared_error_stats, ssim
from dynaeval.metrics.flow import FlowCache, FlowConfig, optical_flow
from dynaeval.metrics.temporal import TemporalConfig, TemporalRun, temporal_metrics
from reference_models.common.paths import docs_dir
from reference_models.studies._doc import replace_block

DOC = "temporal-metrics.md"  # in the repository's docs/ (reference_models.common.paths)
BEGIN, END = "<!-- BEGIN temporal_sensitivity -->", "<!-- END temporal_sensitivity -->"
BEGIN_SCENES = "<!-- BEGIN temporal_sensitivity scenes -->"
END_SCENES = "<!-- END temporal_sensitivity scenes -->"


# ------------------------------------------------------------------------------ ground truth


@dataclass
class Sequence:
    frames: list[np.ndarray]
    """T frames (H, W, 3) float32 in [0, 1]."""
    frames_no_ball: list[np.ndarray]
    """The same frames rendered without the ball."""
    flows: list[np.ndarray]
    """T-1 exact forward flows t -> t+1, (H, W, 2) float32 px (dx, dy)."""
    boxes: list[np.ndarray]
    """Per frame, (N, 4) int64 boxes around players and ball (2 px margin)."""
    static: np.ndarray
    """(H, W) bool: pixels no moving object covers in any frame (2 px margin)."""


def _smooth_noise(rng: np.random.Generator, h: int, w: int, sigma: float, c: int = 1) -> np.ndarray:
    import cv2

    n = rng.random((h, w, c)).astype(np.float32)
    n = cv2.GaussianBlur(n, (0, 0), sigma).reshape(h, w, c)
    return (n - n.mean()) / (n.std() + 1e-8)


def synthetic_sequence(h: int = 270, w: int = 480, n_frames: int = 12, seed: int = 0) -> Sequence:
    """A static-camera soccer-like sequence with exact flow; sizes scale with ``h``."""
    import cv2

    rng = np.random.default_rng(seed)
    s = h / 135.0
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    # static background: crowd above, striped grass with texture and white lines below
    horizon = int(0.28 * h)
    crowd = 0.5 + 0.18 * _smooth_noise(rng, h, w, 0.8 * s, 3)
    grass = np.array([0.22, 0.48, 0.17], np.float32) * (
        1.0 + 0.12 * np.sign(np.sin(xx / (w / 12) * np.pi))[..., None]
    )
    grass = grass + 0.03 * _smooth_noise(rng, h, w, 1.2 * s, 1)
    bg = np.where((yy < horizon)[..., None], crowd, grass)
    line = (np.abs(yy - 0.62 * h) < 1.0 * s) | ((np.abs(xx - 0.5 * w) < 1.0 * s) & (yy >= horizon))
    bg[line] = 0.9
    bg = np.clip(bg, 0.02, 0.98).astype(np.float32)

    # moving objects: (centre x, centre y, vx, vy, half width, half height, colour, texture)
    objects = []
    for k in range(6):
        colour = np.array([0.75, 0.12, 0.1] if k % 2 else [0.1, 0.2, 0.7], np.float32)
        cx, cy = rng.uniform(0.15 * w, 0.85 * w), rng.uniform(0.4 * h, 0.85 * h)
        vx, vy = rng.uniform(-2.2, 2.2) * s, rng.uniform(-0.8, 0.8) * s
        objects.append((cx, cy, vx, vy, 3.0 * s, 8.0 * s, colour, 0.08))
    ball = (
        0.3 * w,
        0.7 * h,
        3.7 * s,
        -1.3 * s,
        2.0 * s,
        2.0 * s,
        np.array([0.95, 0.95, 0.92], np.float32),
        0.3,
    )

    def render(t: int, with_ball: bool) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        img = bg.copy()
        flow = np.zeros((h, w, 2), np.float32)
        masks = []
        drawn = sorted(objects, key=lambda o: o[1] + o[3] * t) + ([ball] if with_ball else [])
        for cx, cy, vx, vy, rx, ry, colour, tex in drawn:
            x, y = cx + vx * t, cy + vy * t
            u, v = xx - x, yy - y  # object coordinates: the texture moves with the object
            m = (u / rx) ** 2 + (v / ry) ** 2 <= 1.0
            pattern = 1.0 + tex * np.sin(2.1 * u / s) * np.cos(1.7 * v / s) - 0.5 * tex * (v > 0)
            img[m] = np.clip(colour * pattern[m][:, None], 0, 1)
            flow[m] = (vx, vy)
            masks.append(m)
        return img, masks, flow

    frames, frames_nb, flows, boxes = [], [], [], []
    covered = np.zeros((h, w), bool)
    for t in range(n_frames):
        img, masks, flow = render(t, True)
        frames.append(img)
        frames_nb.append(render(t, False)[0])
        if t < n_frames - 1:
            flows.append(flow)
        b = [mask_to_box(m) for m in masks if m.any()]
        b = np.array(b, np.int64).reshape(-1, 4) + np.array([-2, -2, 2, 2])
        boxes.append(b)
        for m in masks:
            covered |= m
    static = ~cv2.dilate(covered.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    return Sequence(frames, frames_nb, flows, boxes, static)


def scene_sequence(
    preset: str = "players-stadium",
    camera: str = "eval00",
    n_frames: int = 12,
    size: str = "small",
    seed: int = 0,
) -> Sequence:
    """Frames of one static camera of ``reference_models.scenes`` with its exact flow and boxes.

    The ball-less frames are rendered with ``hide=("ball",)`` (no pixels, no shadow). Static
    mask: pixels whose instance id is 0 (static world) in every frame and whose colour never
    changes by more than 1/255 from frame 0 (that excludes moving shadows), minus a 2 px margin.
    """
    import cv2

    from reference_models.scenes import CameraRenderer, build_scene

    scene = build_scene(preset, seed=seed, size=size)
    n_frames = min(n_frames, scene.n_frames)
    renderer = CameraRenderer(scene.camera(camera), scene.sun, scene.seed, scene.spp)
    frames, frames_nb, flows, boxes = [], [], [], []
    moving = None
    for t in range(n_frames):
        nxt = scene.bodies(t + 1) if t + 1 < scene.n_frames else None
        view = renderer.render(scene.bodies(t), nxt)
        frames.append(view.rgb.astype(np.float32))
        frames_nb.append(renderer.render(scene.bodies(t, ("ball",)), None).rgb.astype(np.float32))
        if t < n_frames - 1:
            flows.append(view.flow.astype(np.float32))
        b = np.array([o["box"] for o in view.boxes], np.int64).reshape(-1, 4)
        boxes.append(b + np.array([-2, -2, 2, 2]))
        # objects, and what they change on the static world (shadows): not static
        changed = (view.ids > 0) | (np.abs(view.rgb - frames[0]).max(axis=-1) > 1.0 / 255)
        moving = changed if moving is None else moving | changed
    static = ~cv2.dilate(moving.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    return Sequence(frames, frames_nb, flows, boxes, static)


# ------------------------------------------------------------------------------ artefacts


def inject_flicker(gt: Sequence, amp: float) -> list[np.ndarray]:
    """Frame t scaled by 1 + amp * (+1, -1, +1, ...), clipped to [0, 1]."""
    return [np.clip(f * (1 + amp * (-1) ** t), 0, 1) for t, f in enumerate(gt.frames)]


def inject_drops(gt: Sequence, fraction: float, seed: int = 1) -> list[np.ndarray]:
    """A fraction of frames (never the first) replaced by the previous shown frame; nested sets."""
    n = len(gt.frames)
    order = np.random.default_rng(seed).permutation(np.arange(1, n))
    dropped = set(order[: int(round(fraction * (n - 1)))].tolist())
    out = []
    for t, f in enumerate(gt.frames):
        out.append(out[-1] if t in dropped else f)
    return out


def inject_ball_blink(gt: Sequence, alpha: float) -> list[np.ndarray]:
    """On odd frames the ball fades by ``alpha`` (1 = gone: the frame rendered without it)."""
    return [
        (1 - alpha) * f + alpha * nb if t % 2 else f
        for t, (f, nb) in enumerate(zip(gt.frames, gt.frames_no_ball, strict=True))
    ]


def inject_noise(gt: Sequence, sigma: float, varying: bool, seed: int = 2) -> list[np.ndarray]:
    """Gaussian noise: one field for all frames (static) or that field's pixels shuffled anew each
    frame (varying), so both have the same noise values, hence the same per-frame PSNR."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0, sigma, gt.frames[0].shape).astype(np.float32)
    out = []
    for f in gt.frames:
        n = rng.permutation(noise.reshape(-1, 3)).reshape(noise.shape) if varying else noise
        out.append(np.clip(f + n, 0, 1))
    return out


# ------------------------------------------------------------------------------ scoring


def _lpips_fn(a: np.ndarray, b: np.ndarray) -> float:
    return lpips_metric(a, b, net="alex", pretrained_backbone=False, seed=0)


COLUMNS = [
    "psnr",
    "ssim",
    "lpips",
    "warp_error",
    "signed",
    "tof",
    "tlp",
    "flicker",
    "focused_warp_error",
    "focused_tof",
    "focused_tlp",
    "focused_flicker",
]


def score(pred: list[np.ndarray], gt: Sequence, cache: FlowCache) -> dict[str, float | None]:
    pairs = list(zip(pred, gt.frames, strict=True))
    pooled = sum((squared_error_stats(p, g) for p, g in pairs[1:]), squared_error_stats(*pairs[0]))
    row: dict[str, float | None] = {
        # pooled over frames: a mean of per-frame PSNRs is inf as soon as one frame is exact
        "psnr": psnr_from_stats(pooled),
        "ssim": float(np.mean([ssim(p, g) for p, g in pairs])),
        "lpips": float(np.mean([_lpips_fn(p, g) for p, g in pairs])),
    }
    res = temporal_metrics(
        pred,
        gt.frames,
        static_mask=gt.static,
        region_masks=gt.boxes,
        lpips_fn=_lpips_fn,
        run=TemporalRun(flow_cache=cache),
    )
    row.update({k: term.outcome.value for k, term in res.items()})
    row["signed"] = res["warp_error"].parts["signed"]
    return row


def _fmt(v: float | None, name: str) -> str:
    if v is None:
        return "null"
    if name == "psnr":
        return "inf" if not np.isfinite(v) else f"{v:.2f}"
    if name == "ssim":
        return f"{v:.4f}"
    if "warp_error" in name or name == "signed":
        v = v * 1e3
    return "0" if v == 0 else f"{v:.3g}"


TEMPORAL_COLUMNS = [c for c in COLUMNS if c not in ("psnr", "ssim", "lpips", "signed")]


def artefact_tables(gt: Sequence) -> str:
    cache = FlowCache()
    cases = [
        (
            "(a) brightness flicker, amplitude",
            [0.0, 0.01, 0.02, 0.05, 0.1],
            lambda a: inject_flicker(gt, a),
        ),
        (
            "(b) dropped frames (shown twice), fraction",
            [0.0, 0.1, 0.3, 0.5],
            lambda a: inject_drops(gt, a),
        ),
        (
            "(c) ball fading on odd frames, opacity lost",
            [0.0, 0.25, 0.5, 1.0],
            lambda a: inject_ball_blink(gt, a),
        ),
        (
            "(d) static noise, sigma",
            [0.01, 0.02, 0.05],
            lambda a: inject_noise(gt, a, varying=False),
        ),
        (
            "(d) temporally varying noise, sigma",
            [0.01, 0.02, 0.05],
            lambda a: inject_noise(gt, a, varying=True),
        ),
    ]
    header = "| artefact | strength | " + " | ".join(COLUMNS) + " |"
    lines = [header, "|" + "---|" * (len(COLUMNS) + 2)]
    notes = []
    rows_by_case = {}
    for label, strengths, make in cases:
        rows = [score(make(a), gt, cache) for a in strengths]
        rows_by_case[label] = rows
        for a, row in zip(strengths, rows, strict=True):
            lines.append(
                f"| {label} | {a:g} | " + " | ".join(_fmt(row[c], c) for c in COLUMNS) + " |"
            )
        if label.startswith("(d)"):
            continue
        flat = [c for c in TEMPORAL_COLUMNS if all(r[c] == 0 for r in rows)]
        bad = [
            c
            for c in TEMPORAL_COLUMNS
            if c not in flat and not all(x[c] < y[c] for x, y in zip(rows, rows[1:], strict=False))
        ]
        notes.append(
            f"- {label}: strictly increasing in strength: every temporal metric except "
            f"{', '.join(bad) or 'none'}; identically 0 (blind to it): {', '.join(flat) or 'none'}."
        )
    s_rows = rows_by_case["(d) static noise, sigma"]
    v_rows = rows_by_case["(d) temporally varying noise, sigma"]
    both = list(zip(s_rows, v_rows, strict=True))
    higher = [c for c in TEMPORAL_COLUMNS if all(v[c] > s_[c] for s_, v in both)]
    notes.append(
        "- (d) at every sigma, varying noise scores worse than static noise on: "
        f"{', '.join(higher)}; largest per-frame gap between them: "
        f"PSNR {max(abs(s_['psnr'] - v['psnr']) for s_, v in both):.3f} dB, "
        f"SSIM {max(abs(s_['ssim'] - v['ssim']) for s_, v in both):.4f}, "
        f"LPIPS {max(abs(s_['lpips'] - v['lpips']) for s_, v in both):.4f}."
    )
    lines += ["", *notes]
    lines.append("")
    lines.append(
        f"Flow cache over the whole table: {cache.misses} flows computed, {cache.hits} reused "
        "(ground-truth pairs are estimated once for all 19 rows)."
    )
    return "\n".join(lines)


def flow_accuracy(gt: Sequence) -> str:
    moving = [np.any(f != 0, axis=-1) for f in gt.flows]
    configs = [
        ("dis ultrafast", FlowConfig(dis_preset="ultrafast")),
        ("dis fast", FlowConfig(dis_preset="fast")),
        ("dis medium (default)", FlowConfig(dis_preset="medium")),
        ("farneback (TecoGAN parameters)", FlowConfig(method="farneback")),
        ("tvl1 (OpenCV defaults)", FlowConfig(method="tvl1")),
    ]
    lines = [
        "| estimator | EPE all pixels (px) | EPE moving pixels (px) | EPE static pixels (px) |",
        "|---|---|---|---|",
    ]
    for name, cfg in configs:
        e_all, e_mov, e_sta = [], [], []
        for t, exact in enumerate(gt.flows):
            est = optical_flow(gt.frames[t], gt.frames[t + 1], cfg)
            epe = np.linalg.norm(est - exact, axis=-1)
            e_all.append(epe.mean())
            e_mov.append(epe[moving[t]].mean())
            e_sta.append(epe[~moving[t]].mean())
        lines.append(
            f"| {name} | {np.mean(e_all):.3f} | {np.mean(e_mov):.3f} | {np.mean(e_sta):.3f} |"
        )
    return "\n".join(lines)


def timing() -> str:
    import torch

    lines = [
        "| resolution | flow + warp metrics per pair (s) | + tLP (random-backbone AlexNet, 2 LPIPS per pair) (s) |",
        "|---|---|---|",
    ]
    for h, w in ((540, 960), (1080, 1920)):
        gt = synthetic_sequence(h, w, n_frames=3, seed=0)
        pred = inject_noise(gt, 0.02, varying=True)
        no_lp = TemporalConfig(tlp=False)
        temporal_metrics(pred[:2], gt.frames[:2], config=no_lp)  # warm-up
        t0 = time.perf_counter()
        temporal_metrics(pred, gt.frames, config=no_lp, static_mask=gt.static)
        flows = (time.perf_counter() - t0) / 2
        _lpips_fn(pred[0], pred[1])  # warm-up: builds the network
        t0 = time.perf_counter()
        temporal_metrics(pred, gt.frames, static_mask=gt.static, lpips_fn=_lpips_fn)
        full = (time.perf_counter() - t0) / 2
        lines.append(f"| {w}x{h} | {flows:.2f} | {full:.2f} |")
    lines.append("")
    lines.append(
        f"torch threads: {torch.get_num_threads()}; machine: 2 CPU cores shared with other jobs."
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--source",
        choices=("scenes", "synthetic"),
        default="scenes",
        help="ground truth: reference_models.scenes players-stadium (default) or the 2-D sequence",
    )
    parser.add_argument("--write", action="store_true", help=f"replace the study block in docs/{DOC}")
    parser.add_argument(
        "--no-timing", action="store_true", help="skip the (machine-dependent) timing"
    )
    args = parser.parse_args()
    if args.source == "scenes":
        gt = scene_sequence()
        what = (
            "Ground truth: `reference_models.scenes`, preset `players-stadium`, size `small` "
            "(320x180), camera `eval00`, frames 0-11 (11 pairs), seed 0; exact flow and boxes "
            "from the generator, ball-less frames rendered with `hide=('ball',)`."
        )
        begin, end = BEGIN_SCENES, END_SCENES
    else:
        gt = synthetic_sequence()
        what = "Ground truth: `synthetic_sequence(h=270, w=480, n_frames=12, seed=0)` (11 pairs)."
        begin, end = BEGIN, END
    parts = [
        what + " psnr: pooled over frames (dB); ssim, lpips: mean over frames; warp_error columns "
        "and `signed` (the mean signed warp-error difference) are x 1e-3; lpips and tlp on a "
        "random-backbone AlexNet.",
        "",
        artefact_tables(gt),
        "",
        "Optical flow against the exact flow of the same sequence (mean endpoint error over the 11 "
        "forward pairs):",
        "",
        flow_accuracy(gt),
    ]
    if args.source == "synthetic" and not args.no_timing:
        parts += [
            "",
            "Time per frame pair, `temporal_metrics` (DIS medium), mean of 2 pairs:",
            "",
            timing(),
        ]
    block = "\n".join(parts)
    print(block)
    if args.write:
        replace_block(docs_dir() / DOC, begin, end, block)


if __name__ == "__main__":
    main()

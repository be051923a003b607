"""What the video metrics add (issue 19): JOD and FLIP beside per-frame PSNR/SSIM and the temporal
terms, on injected artefacts of a static-camera sequence with exact ground truth, and their cost.

Ground truth: ``reference_models.studies.temporal_sensitivity.synthetic_sequence`` (a procedural
soccer-like sequence with exact flow and boxes: crowd stands above the horizon, a striped pitch,
six textured players and a ball, and the same frames rendered without the ball). Artefacts, each at several strengths:

(a) flicker of the stands only: the crowd (above the horizon) scaled by 1 + a (-1)^t;
(b) a ball that blinks: on odd frames it fades by alpha (1 = gone);
(c) frame drops: a fraction of the frames shows the previous frame again;
(d) static vs temporally varying Gaussian noise of equal per-frame PSNR (the same noise values,
    shuffled anew each frame for the varying one).

Each prediction is scored with PSNR (pooled over frames: a mean of per-frame values is infinite as
soon as one frame is exact, as dropped frames often are), SSIM and FLIP (means of per-frame
values), the temporal terms (warp error, tOF, flicker; DIS flow, no
tLP), and JOD: ColorVideoVDP (``jod``, standard_fhd, 30 fps), its focused window (``focused_jod``,
the union of the players' and ball's boxes over the clip, ``dynaeval.metrics.jod.focus_window``),
and FovVideoVDP (``fvvdp``) when ``pyfvvdp`` is installed. Then the cost of JOD and FLIP per
1920x1080 frame on this machine, measured in the run.

    python -m reference_models.studies.video_quality --write          # docs/video-quality.md
    python -m reference_models.studies.video_quality --tiny           # what CI runs (no doc)

Deterministic except the timing table. torch runs single-threaded (``torch.set_num_threads(1)``):
the machine's 2 cores are shared.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numpy as np

from dynaeval.metrics import psnr_from_stats, squared_error_stats, ssim
from dynaeval.metrics.temporal import TemporalConfig, temporal_metrics
from reference_models.common.paths import docs_dir
from reference_models.studies._doc import replace_block
from reference_models.studies.temporal_sensitivity import (
    Sequence,
    inject_ball_blink,
    inject_drops,
    inject_noise,
    synthetic_sequence,
)

DOC = "video-quality.md"
BEGIN, END = "<!-- BEGIN video_quality -->", "<!-- END video_quality -->"
FPS = 30.0


@dataclass(frozen=True)
class Size:
    """How big the study is: the full one writes the doc, the tiny one is CI's."""

    h: int
    w: int
    n_frames: int
    strengths: dict[str, list[float]]
    timing_frames: int


FULL = Size(135, 240, 24, {
    "stands": [0.0, 0.02, 0.05, 0.1],
    "blink": [0.25, 0.5, 1.0],
    "drops": [0.1, 0.3, 0.5],
    "noise": [0.01, 0.03],
}, timing_frames=4)
TINY = Size(54, 96, 10, {"stands": [0.05], "blink": [1.0], "drops": [0.3], "noise": [0.03]},
            timing_frames=0)


def stands_mask(gt: Sequence) -> np.ndarray:
    """(H, W) bool: the crowd stands, the rows above ``synthetic_sequence``'s horizon (0.28 h)."""
    h, w = gt.frames[0].shape[:2]
    mask = np.zeros((h, w), bool)
    mask[: int(0.28 * h)] = True
    return mask


def inject_stands_flicker(gt: Sequence, amp: float, stands: np.ndarray) -> list[np.ndarray]:
    """The stands' pixels of frame t scaled by 1 + amp (-1)^t (clipped to [0, 1]); the pitch,
    players and ball unchanged."""
    out = []
    for t, f in enumerate(gt.frames):
        g = f.copy()
        g[stands] = np.clip(f[stands] * (1 + amp * (-1) ** t), 0, 1)
        out.append(g)
    return out


def cases(gt: Sequence, size: Size) -> list[tuple[str, float, list[np.ndarray]]]:
    """(artefact, strength, predicted frames) of every row of the table."""
    stands = stands_mask(gt)
    s = size.strengths
    out = [("none (identical)", 0.0, list(gt.frames))]
    out += [("(a) stands flicker, amplitude", a, inject_stands_flicker(gt, a, stands))
            for a in s["stands"] if a > 0]
    out += [("(b) ball blinks, opacity lost", a, inject_ball_blink(gt, a)) for a in s["blink"]]
    out += [("(c) frames dropped, fraction", a, inject_drops(gt, a)) for a in s["drops"]]
    for sigma in s["noise"]:
        out.append(("(d) static noise, sigma", sigma, inject_noise(gt, sigma, varying=False)))
        out.append(("(d) varying noise, sigma", sigma, inject_noise(gt, sigma, varying=True)))
    return out


# ------------------------------------------------------------------------------ scoring


def _models() -> dict[str, object]:
    """The JOD models installed: cvvdp always (the study needs dynaeval[video]), fvvdp if there."""
    from dynaeval.metrics.jod import load_model

    out = {"jod": load_model("cvvdp")}
    try:
        out["fvvdp"] = load_model("fvvdp")
    except ImportError:
        pass
    return out


def _flip_mean(pred: list[np.ndarray], gt: list[np.ndarray]) -> float:
    from dynaeval.metrics.flip import flip

    return math.fsum(flip(p, g) for p, g in zip(pred, gt, strict=True)) / len(gt)


def score(pred: list[np.ndarray], gt: Sequence, models: dict[str, object]) -> dict[str, float | None]:
    """Every column of one row."""
    from dynaeval.metrics.jod import focus_window, jod

    pairs = list(zip(pred, gt.frames, strict=True))
    pooled = sum((squared_error_stats(p, g) for p, g in pairs[1:]), squared_error_stats(*pairs[0]))
    row: dict[str, float | None] = {
        "psnr": psnr_from_stats(pooled),
        "ssim": float(np.mean([ssim(p, g) for p, g in pairs])),
        "flip": _flip_mean(pred, gt.frames),
    }
    res = temporal_metrics(pred, gt.frames, static_mask=gt.static, config=TemporalConfig(tlp=False))
    row.update({k: res[k].outcome.value for k in ("warp_error", "tof", "flicker")})
    h, w = gt.frames[0].shape[:2]
    window = focus_window(gt.boxes, h, w)
    for name, metric in models.items():
        row[name] = jod(pred, gt.frames, fps=FPS, metric=metric)
        if name == "jod":
            row["focused_jod"] = jod(pred, gt.frames, fps=FPS, metric=metric, window=window)
    return row


COLUMNS = ["psnr", "ssim", "flip", "warp_error", "tof", "flicker", "jod",
           "focused_jod", "fvvdp"]


def _fmt(v: float | None, name: str) -> str:
    if v is None:
        return "null"
    if name == "psnr":
        return "inf" if not math.isfinite(v) else f"{v:.2f}"
    if name in ("ssim", "flip"):
        return f"{v:.4f}"
    if name in ("jod", "focused_jod", "fvvdp"):
        return f"{v:.3f}"
    if name == "warp_error":
        v = v * 1e3
    return "0" if v == 0 else f"{v:.3g}"


def table(rows: list[tuple[str, float, dict]], columns: list[str]) -> str:
    lines = ["| artefact | strength | " + " | ".join(columns) + " |",
             "|" + "---|" * (len(columns) + 2)]
    for label, a, row in rows:
        lines.append(f"| {label} | {a:g} | " + " | ".join(_fmt(row.get(c), c) for c in columns)
                     + " |")
    return "\n".join(lines)


def _spearman(x: list[float], y: list[float]) -> float:
    from scipy.stats import spearmanr

    return float(spearmanr(x, y).statistic)


def findings(rows: list[tuple[str, float, dict]]) -> list[str]:
    """Sentences computed from the rows: where JOD separates what PSNR/SSIM cannot, and how JOD
    ranks the artefacts against the temporal terms."""
    out = []
    by = {(label, a): row for label, a, row in rows}
    for sigma in sorted({a for label, a, _ in rows if label.startswith("(d) static")}):
        s, v = by["(d) static noise, sigma", sigma], by["(d) varying noise, sigma", sigma]
        out.append(
            f"- (d) sigma {sigma:g}: per-frame PSNR {s['psnr']:.2f} vs {v['psnr']:.2f} dB "
            f"(gap {abs(s['psnr'] - v['psnr']):.3f}), SSIM gap {abs(s['ssim'] - v['ssim']):.4f}, "
            f"FLIP gap {abs(s['flip'] - v['flip']):.4f}; JOD static {s['jod']:.3f} vs varying "
            f"{v['jod']:.3f} (gap {s['jod'] - v['jod']:+.3f} JOD); flicker {s['flicker']:.3g} vs "
            f"{v['flicker']:.3g}.")
    for prefix in ("(c)", "(b)", "(a)"):
        sub = [(a, r) for label, a, r in rows if label.startswith(prefix)]
        if len(sub) < 2:
            continue
        mono = all(x["jod"] > y["jod"] for (_, x), (_, y) in zip(sub, sub[1:], strict=False))
        values = ", ".join(f"{r['jod']:.3f}" for _, r in sub)
        out.append(f"- {prefix}: JOD {'falls strictly' if mono else 'does not fall strictly'} "
                   f"with strength ({values}).")
    damaged = [r for label, _, r in rows if not label.startswith("none")]
    if len(damaged) >= 4:
        jods = [r["jod"] for r in damaged]
        corr = {k: _spearman(jods, [r[k] for r in damaged]) for k in
                ("psnr", "ssim", "flip", "warp_error", "tof", "flicker")}
        out.append("- Spearman rank correlation of JOD with each metric over the "
                   f"{len(damaged)} damaged rows (JOD: higher is better, so a metric that agrees "
                   "and is lower-is-better correlates negatively): " + ", ".join(
                       f"{k} {v:+.2f}" for k, v in corr.items()) + ".")
    return out


def timing(models: dict[str, object], n: int) -> str:
    """JOD (each model) and FLIP per 1920x1080 frame, measured now on ``n`` frames."""
    from dynaeval.metrics.flip import flip
    from dynaeval.metrics.jod import jod

    gt = synthetic_sequence(1080, 1920, n_frames=n, seed=0)
    pred = inject_noise(gt, 0.02, varying=True)
    lines = ["| metric | s per 1920x1080 frame | frames timed |", "|---|---|---|"]
    for name, metric in models.items():
        t0 = time.perf_counter()
        jod(pred, gt.frames, fps=FPS, metric=metric)
        lines.append(f"| {name} ({type(metric).__module__.split('.')[0]}) | "
                     f"{(time.perf_counter() - t0) / n:.2f} | {n} |")
    t0 = time.perf_counter()
    for p, g in zip(pred, gt.frames, strict=True):
        flip(p, g)
    lines.append(f"| flip (flip-evaluator) | {(time.perf_counter() - t0) / n:.2f} | {n} |")
    return "\n".join(lines)


def run(size: Size) -> tuple[str, list[tuple[str, float, dict]]]:
    """The study's Markdown block and its rows."""
    import torch

    torch.set_num_threads(1)
    gt = synthetic_sequence(size.h, size.w, n_frames=size.n_frames, seed=0)
    what = (f"Ground truth: `synthetic_sequence(h={size.h}, w={size.w}, n_frames={size.n_frames}, "
            "seed=0)`")
    models = _models()
    rows = [(label, a, score(pred, gt, models)) for label, a, pred in cases(gt, size)]
    columns = [c for c in COLUMNS if c in rows[0][2]]
    parts = [
        f"{what}, played at {FPS:g} fps on `standard_fhd`. psnr: pooled over frames (dB); "
        "ssim, flip: means over frames; warp_error x 1e-3; tof in px; flicker on the "
        "static pixels; jod / focused_jod: ColorVideoVDP, whole frame / the players' and ball's "
        "window over the clip; fvvdp: FovVideoVDP (K-Planes' JOD).",
        "",
        table(rows, columns),
        "",
        *findings(rows),
    ]
    if size.timing_frames:
        parts += ["", f"Cost per 1920x1080 frame on this machine (2 shared CPU cores, torch "
                      f"{torch.get_num_threads()} thread; {size.timing_frames} frames of "
                      "`synthetic_sequence(1080, 1920)` with varying noise):", "",
                  timing(models, size.timing_frames)]
    return "\n".join(parts), rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiny", action="store_true", help="CI's size (no timing, no doc)")
    parser.add_argument("--write", action="store_true", help=f"replace the block in docs/{DOC}")
    args = parser.parse_args(argv)
    block, _ = run(TINY if args.tiny else FULL)
    print(block)
    if args.write and not args.tiny:
        replace_block(docs_dir() / DOC, BEGIN, END, block)


if __name__ == "__main__":
    main()

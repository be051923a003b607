"""PSNR against training wall time, from the runs' own logs (no number typed by hand)::

    python -m reference_models.common.curves RUN [RUN ...] --out docs/img/models_psnr_time.png

Plots the logged eval-camera PSNR of every run against its training seconds and prints a
Markdown table per run: steps, training minutes, iterations/s, last eval PSNR, parameters,
checkpoint size, and — when ``RUN/results.json`` from ``dynaeval score`` exists — its whole-frame,
focused and masked PSNR. With ``--data DATA`` (a generator dataset) it also says whether the ball
survives: PSNR inside the ball's boxes (``DATA/boxes.json``) of the rendered frames, next to the
same PSNR of the ground truth rendered *without* the ball (what a model that drops the ball gets).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from dynaeval.errors import InputError


def read_log(run: Path) -> list[dict]:
    """The run's ``log.jsonl`` records; InputError when there is none."""
    path = Path(run) / "log.jsonl"
    if not path.is_file():
        raise InputError("no log.jsonl: not a training run", path=run)
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def run_summary(run: Path) -> dict:
    """One table row of a run (see module doc)."""
    import torch

    log = read_log(run)
    evals = [r for r in log if "eval_psnr" in r]
    ckpt = Path(run) / "checkpoint.pt"
    state = torch.load(ckpt, weights_only=False)["model"] if ckpt.is_file() else {}
    row = {
        "run": Path(run).name,
        "steps": log[-1]["step"],
        "train_min": log[-1]["train_seconds"] / 60.0,
        "it_per_s": log[-1]["step"] / log[-1]["train_seconds"],
        "eval_psnr": evals[-1]["eval_psnr"] if evals else None,
        "params_M": sum(v.numel() for k, v in state.items() if v.is_floating_point()) / 1e6,
        "ckpt_MB": ckpt.stat().st_size / 1e6 if ckpt.is_file() else None,
    }
    res = Path(run) / "results.json"
    if res.is_file():
        summary = json.loads(res.read_text())["summary"]
        for key in ("psnr", "focused_psnr", "masked_psnr"):
            row[f"score_{key}"] = summary.get(key)
    return row


def ball_psnr(run: Path, data: Path) -> dict:
    """``ball_psnr`` (dB) of ``RUN/pred`` inside the visible ball boxes vs the ground truth, and
    ``noball_psnr``: the generator's render of the same frames with the ball hidden, scored the
    same way. The model keeps the ball where ``ball_psnr`` clearly beats ``noball_psnr``."""
    import numpy as np

    from dynaeval.io.images import read_image
    from dynaeval.metrics import psnr
    from reference_models.scenes import build_scene, render_view

    meta = json.loads((Path(data) / "metadata.json").read_text())
    boxes = json.loads((Path(data) / "boxes.json").read_text())
    scene = build_scene(meta["preset"], meta["seed"], meta["size"], meta["width"], meta["height"],
                        meta["frames"], meta["fps"], meta["spp"])
    got, base = [], []
    for pred in sorted((Path(run) / "pred").glob("*/*.png")):
        key = f"{pred.parent.name}/{pred.stem}"
        ball = [b["box"] for b in boxes.get(key, []) if b["class"] == "ball" and b["visible"] > 0.5]
        if not ball:
            continue
        gt = read_image(Path(data) / "images" / f"{key}.png")
        noball = render_view(scene, pred.parent.name, int(pred.stem), hide=("ball",)).rgb
        noball = np.round(np.clip(noball, 0, 1) * 255) / 255
        got.append(psnr(read_image(pred), gt, boxes=np.array(ball)))
        base.append(psnr(noball.astype(np.float32), gt, boxes=np.array(ball)))
    if not got:
        return {"ball_psnr": None, "noball_psnr": None}
    return {"ball_psnr": float(np.mean(got)), "noball_psnr": float(np.mean(base))}


def plot(runs: list[Path], out: Path) -> None:
    """Eval PSNR (dB) against training minutes, one line per run, written to ``out`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
    for run in runs:
        evals = [r for r in read_log(run) if "eval_psnr" in r]
        ax.plot([r["train_seconds"] / 60 for r in evals], [r["eval_psnr"] for r in evals],
                marker="o", label=Path(run).name)
    ax.set_xlabel("training wall time (min, 1 thread on a shared 2-core machine)")
    ax.set_ylabel("eval-camera PSNR (dB)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)


def _fmt(v: object) -> str:
    if v is None:
        return "n/a"
    return f"{v:.2f}" if isinstance(v, float) else str(v)


def markdown_table(rows: list[dict]) -> str:
    """The rows as a Markdown table (columns: the union of the rows' keys, in order)."""
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_fmt(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 done, 2 bad input)."""
    p = argparse.ArgumentParser(prog="python -m reference_models.common.curves",
                                description="PSNR-vs-time curves and a table from training runs.")
    p.add_argument("runs", nargs="+", type=Path, help="run folders (log.jsonl, checkpoint.pt)")
    p.add_argument("--out", type=Path, required=True, help="PNG file for the curves")
    p.add_argument("--data", type=Path, help="generator dataset: add the ball-survival columns")
    args = p.parse_args(argv)
    try:
        plot(args.runs, args.out)
        rows = [run_summary(r) for r in args.runs]
        if args.data is not None:
            rows = [{**row, **ball_psnr(r, args.data)} for row, r in zip(rows, args.runs, strict=True)]
        print(markdown_table(rows))
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

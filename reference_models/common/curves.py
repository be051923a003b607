"""PSNR against training time, from the runs' own logs (no number typed by hand)::

    python -m reference_models.common.curves RUN [RUN ...] --out docs/img/models_psnr_time.png

Plots the logged eval-camera PSNR of every run against its training CPU seconds (wall seconds
for runs that logged none) and prints a Markdown table per run: steps, training minutes (wall
and CPU), rays per step, iterations/s, last eval PSNR, parameters,
checkpoint size, and — when ``RUN/results.json`` from ``dynaeval score`` exists — its whole-frame,
focused, masked and per-object (tight box) PSNR.
Whether the ball survives is dynaeval's own ``presence_ball`` (``dynaeval.metrics.presence``),
read from the results like the other scores.
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
    """One table row of a run (see module doc). A folder with ``results.json`` but no log (e.g.
    the constant-colour baseline) gets the score columns only."""
    import torch

    res = Path(run) / "results.json"
    if not (Path(run) / "log.jsonl").is_file() and res.is_file():
        return {"run": Path(run).name, **_scores(res)}
    log = read_log(run)
    evals = [r for r in log if "eval_psnr" in r]
    ckpt = Path(run) / "checkpoint.pt"
    state = torch.load(ckpt, map_location="cpu", weights_only=False)["model"] if ckpt.is_file() else {}
    row = {
        "run": Path(run).name,
        "steps": log[-1]["step"],
        "train_min": log[-1]["train_seconds"] / 60.0,
        "cpu_min": (log[-1]["train_cpu_seconds"] / 60.0 if "train_cpu_seconds" in log[-1]
                    else None),
        "rays_per_step": json.loads((Path(run) / "config.json").read_text())["train_config"][
            "batch_rays"] if (Path(run) / "config.json").is_file() else None,
        "it_per_s": log[-1]["step"] / log[-1]["train_seconds"],
        "eval_psnr": evals[-1]["eval_psnr"] if evals else None,
        "params_M": sum(v.numel() for k, v in state.items() if v.is_floating_point()) / 1e6,
        "ckpt_MB": ckpt.stat().st_size / 1e6 if ckpt.is_file() else None,
    }
    return {**row, **_scores(res)} if res.is_file() else row


def _scores(results: Path) -> dict:
    summary = json.loads(results.read_text())["summary"]
    keys = ("psnr", "focused_psnr", "masked_psnr", "tight_psnr_person", "tight_psnr_ball",
            "presence_person", "presence_ball")
    return {f"score_{k}": summary.get(k) for k in keys}


def plot(runs: list[Path], out: Path) -> None:
    """Eval PSNR (dB) against training minutes, one line per run, written to ``out`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
    for run in runs:
        if not (Path(run) / "log.jsonl").is_file():
            continue  # a baseline without training has no curve
        evals = [r for r in read_log(run) if "eval_psnr" in r]
        cpu = bool(evals) and "train_cpu_seconds" in evals[0]
        ax.plot([r["train_cpu_seconds" if cpu else "train_seconds"] / 60 for r in evals],
                [r["eval_psnr"] for r in evals], marker="o",
                label=Path(run).name + ("" if cpu else " (wall time)"))
    ax.set_xlabel("training time (min of one core's CPU time; wall time where marked)")
    ax.set_ylabel("eval-camera PSNR (dB)")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend()
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)


def strip(runs: list[Path], gt_images: Path, view: str, out: Path,
          crop: tuple[int, int, int, int] | None = None, scale: int = 1) -> None:
    """Ground truth then each run's prediction of ``view`` (``camera/frame``) side by side, with
    the folder names written on them, saved to ``out`` (PNG). ``crop`` ``(x0, y0, x1, y1)``
    pixels (max exclusive) cuts every image first; ``scale`` enlarges it (nearest neighbour)."""
    import cv2
    import numpy as np

    tiles = [("ground truth", Path(gt_images) / f"{view}.png")]
    tiles += [(Path(r).name, Path(r) / "pred" / f"{view}.png") for r in runs]
    imgs = []
    for name, path in tiles:
        img = cv2.imread(str(path))
        if img is None:
            raise InputError(f"no image for {view}", path=path)
        if crop is not None:
            x0, y0, x1, y1 = crop
            img = np.ascontiguousarray(img[y0:y1, x0:x1])
            if img.size == 0:
                raise InputError(f"crop {crop} is outside the image", path=path)
        if scale > 1:
            img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        cv2.putText(img, name, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
        imgs.append(img)
    cols = 3
    while len(imgs) % cols:
        imgs.append(np.zeros_like(imgs[0]))
    rows = [np.concatenate(imgs[i:i + cols], 1) for i in range(0, len(imgs), cols)]
    out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out), np.concatenate(rows, 0))


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
    p.add_argument("--strip", nargs=3, metavar=("GT_IMAGES", "CAMERA/FRAME", "PNG"),
                   help="also write the ground truth and every run's prediction of one view")
    p.add_argument("--crop", nargs=4, type=int, metavar=("X0", "Y0", "X1", "Y1"),
                   help="--strip: cut this pixel box (max exclusive) from every image")
    p.add_argument("--scale", type=int, default=1, help="--strip: enlarge by this factor")
    args = p.parse_args(argv)
    try:
        if args.strip:
            strip(args.runs, Path(args.strip[0]), args.strip[1], Path(args.strip[2]),
                  tuple(args.crop) if args.crop else None, max(args.scale, 1))
        plot(args.runs, args.out)
        print(markdown_table([run_summary(r) for r in args.runs]))
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The tiny dataset every reference-model test trains on (4 training cameras, 1 eval, 8 frames)."""

from pathlib import Path

import numpy as np

from reference_models.scenes import render_scene

PRESET = "single-player-closeup"


def render_tiny(out: Path) -> Path:
    """Render the tiny close-up scene into ``out`` (about a second) and return it."""
    render_scene(PRESET, out, size="tiny", seed=0)
    return out


def constant_colour_psnr(train_images: np.ndarray, eval_images: np.ndarray) -> float:
    """Whole-frame PSNR (dB) of the baseline that paints every eval pixel the mean training colour."""
    from dynaeval.metrics import psnr

    mean = np.round(train_images.reshape(-1, 3).mean(0)).astype(np.uint8)
    return float(np.mean([psnr(np.broadcast_to(mean, im.shape), im, data_range=255.0)
                          for im in eval_images]))


def check_tiny_run(spec, data: Path, run: Path, sampling: str = "uniform") -> dict:
    """Train ``spec``'s tiny preset, render the eval camera, score it with ``dynaeval score``;
    assert what every model must do and return the numbers for the caller's own checks."""
    import json

    from dynaeval.cli import main as dynaeval_main
    from reference_models.common.cli import main
    from reference_models.common.data import load_dataset

    assert main(spec, ["train", str(data), "--out", str(run), "--size", "tiny", "--sampling",
                       sampling, "--quiet"]) == 0
    log = [json.loads(line) for line in (run / "log.jsonl").read_text().splitlines()]
    assert log[-1]["loss"] < 0.7 * log[0]["loss"], "the loss did not go down"
    ds = load_dataset(data)
    baseline = constant_colour_psnr(ds.train.images, ds.eval.images)
    assert log[-1]["eval_psnr"] > baseline + 1.0, (log[-1]["eval_psnr"], baseline)
    assert main(spec, ["render", str(run), "--quiet"]) == 0
    written = sorted(p.relative_to(run / "pred").as_posix() for p in (run / "pred").rglob("*.png"))
    assert written == [f"eval00/{f:04d}.png" for f in range(8)]
    out = run / "results.json"
    assert dynaeval_main(["score", str(run / "pred"), str(data / "images"), "--focus", "motion",
                          "--no-lpips", "--no-temporal", "-o", str(out), "-q"]) == 0
    results = json.loads(out.read_text())
    assert results["summary"]["psnr"] > baseline + 1.0
    return {"log": log, "baseline": baseline, "results": results}

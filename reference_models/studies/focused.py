"""Default vs focused metrics on the synthetic scenes (docs/focused-metrics.md), like the seed
study's table: predictions that differ from the ground truth only outside the focus boxes, only
inside them, or in both, scored by ``dynaeval.score`` with the generator's exact boxes.

    python -m reference_models.studies.focused [--write]

Conditions, each applied to every frame of the evaluation camera ``eval00``:

* ``stands blurred``: Gaussian blur (sigma 2 px) outside the expanded boxes — a badly
  reconstructed stadium, the player perfect (the seed study's model (d) inverted);
* ``player blurred``: the same blur inside the players' instance masks only — a soft player;
* ``player missing``: the frame rendered without the players (the pitch behind them is right);
* ``ball missing``: the frame rendered without the ball;
* ``both blurred``: blur everywhere.

Focused metrics use the paper's expansion (width x7, height x2.5) of the exact boxes, merged.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from reference_models.common.paths import docs_dir
from reference_models.studies._doc import replace_block

DOC = "focused-metrics.md"  # in the repository's docs/ (reference_models.common.paths)
BEGIN, END = "<!-- BEGIN focused_study -->", "<!-- END focused_study -->"
PRESETS = ("single-player-closeup", "single-player-broadcast", "players-stadium")
CONDITIONS = ("stands blurred", "player blurred", "player missing", "ball missing", "both blurred")
FRAMES = 6
CAMERA = "eval00"


def _blur(img: np.ndarray, sigma: float = 2.0) -> np.ndarray:
    import cv2

    return cv2.GaussianBlur(img, (0, 0), sigmaX=sigma, borderType=cv2.BORDER_REFLECT)


def _write(path: Path, rgb: np.ndarray) -> None:
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)[..., ::-1])


def make_condition(scene, frame: int, condition: str, boxes: np.ndarray) -> np.ndarray:
    """The prediction of ``condition`` for one frame (float32 RGB in [0, 1])."""
    from dynaeval.core.boxes import boxes_to_mask
    from reference_models.scenes import render_view

    view = render_view(scene, CAMERA, frame)
    rgb = view.rgb
    if condition == "player missing":
        return render_view(scene, CAMERA, frame, hide=("person",)).rgb
    if condition == "ball missing":
        return render_view(scene, CAMERA, frame, hide=("ball",)).rgb
    if condition == "both blurred":
        return _blur(rgb)
    out = rgb.copy()
    if condition == "stands blurred":
        outside = ~boxes_to_mask(boxes, *rgb.shape[:2])
        out[outside] = _blur(rgb)[outside]
    else:  # player blurred
        person_ids = [b["id"] for b in view.boxes if b["class"] == "person"]
        inside = np.isin(view.ids, person_ids)
        out[inside] = _blur(rgb)[inside]
    return out


def study(preset: str, root: Path, size: str = "small") -> list[dict]:
    """Score every condition of one preset; rows of the table."""
    import json

    import dynaeval
    from dynaeval.core.boxes import boxes_to_mask
    from dynaeval.regions import ExpandConfig, expand_boxes, records_to_boxes
    from dynaeval.regions.focus import FocusConfig
    from reference_models.scenes import build_scene, render_view

    scene = build_scene(preset, seed=0, size=size, frames=FRAMES)
    gt_dir, boxes = root / preset / "gt", {}
    expanded = {}
    for f in range(FRAMES):
        view = render_view(scene, CAMERA, f)
        _write(gt_dir / CAMERA / f"{f:04d}.png", view.rgb)
        boxes[f"{CAMERA}/{f:04d}"] = view.boxes
        expanded[f] = expand_boxes(records_to_boxes(view.boxes), ExpandConfig.preset("paper"),
                                   *view.rgb.shape[:2])
    boxes_file = root / preset / "boxes.json"
    boxes_file.write_text(json.dumps(boxes))
    rows = []
    for condition in CONDITIONS:
        pred_dir = root / preset / condition.replace(" ", "-")
        for f in range(FRAMES):
            _write(pred_dir / CAMERA / f"{f:04d}.png", make_condition(scene, f, condition,
                                                                      expanded[f]))
        res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, progress=False,
                             focus=FocusConfig(source="boxes", boxes_file=str(boxes_file),
                                               masked=False))
        s = res["summary"]
        frac = np.mean([boxes_to_mask(expanded[f], scene.height, scene.width).mean()
                        for f in range(FRAMES)])
        rows.append({"preset": preset, "condition": condition, "psnr": s["psnr"],
                     "focused_psnr": s["focused_psnr"], "ssim": s["ssim"],
                     "focused_ssim": s["focused_ssim"], "presence_person": s.get("presence_person"),
                     "presence_ball": s.get("presence_ball"), "box_fraction": float(frac)})
    return rows


def _f(v, fmt: str, inf_if_none: bool = False) -> str:
    if v is None:
        return "∞" if inf_if_none else "n/a"
    return format(v, fmt)


def table(rows: list[dict]) -> str:
    lines = ["| scene | prediction | PSNR | focused PSNR | SSIM | focused SSIM | presence person "
             "| presence ball | frame area in boxes |", "|---" * 9 + "|"]
    for r in rows:
        lines.append(
            f"| {r['preset']} | {r['condition']} | {_f(r['psnr'], '.2f', True)} | "
            f"{_f(r['focused_psnr'], '.2f', True)} | {_f(r['ssim'], '.4f')} | "
            f"{_f(r['focused_ssim'], '.4f')} | {_f(r['presence_person'], '.2f')} | "
            f"{_f(r['presence_ball'], '.2f')} | {r['box_fraction']:.1%} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m reference_models.studies.focused",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help=f"write the table into docs/{DOC}")
    parser.add_argument("--size", default="small", help="generator size (default small)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [r for p in PRESETS for r in study(p, Path(tmp), args.size)]
    block = (f"Command: `python -m reference_models.studies.focused --write` (size {args.size}, "
             f"camera {CAMERA}, frames 0-{FRAMES - 1}, seed 0). PSNR of a prediction identical "
             "to the ground truth in the scored pixels is +∞, shown as such.\n\n" + table(rows))
    print(block)
    if args.write:
        replace_block(docs_dir() / DOC, BEGIN, END, block)
    return 0


if __name__ == "__main__":
    sys.exit(main())

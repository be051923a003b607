"""Regenerate the sample scene shipped in ``dynaeval/data/sample`` (``dynaeval demo`` scores it).

    python -m reference_models.sample [--out dynaeval/data/sample]

Ground truth: two cameras (the held-out ``eval00`` and the training camera ``cam07``) of the
``single-player-closeup`` preset, 256x144 px, 8 frames, rendered by ``reference_models.scenes``;
``boxes.json`` holds the generator's exact boxes (the ``--focus boxes:FILE`` format).

Predictions (method ``sample-degraded``) are **not a model's output**: they are the ground truth
with the failures dynamic NeRFs show on soccer scenes, injected deterministically so that the demo
exercises every kind of metric:

* the player is blurred (Gaussian, sigma 2 px, inside its dilated instance mask) — a soft,
  under-fitted dynamic object;
* the ball disappears on odd frames (the pixels come from a render with the ball hidden, so the
  pitch and the ball's shadow behind it are right) — the ball that "vanishes";
* the static world is slightly blurred (sigma 0.6 px) and carries low-amplitude noise that changes
  every frame — the flicker on the stands that temporal metrics catch.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

from reference_models.common.paths import repo_root

SAMPLE_CAMERAS = ("eval00", "cam07")
SIZE = {"width": 256, "height": 144, "frames": 8}
PRESET, SEED = "single-player-closeup", 0


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    import cv2

    return cv2.GaussianBlur(img, (0, 0), sigmaX=sigma, borderType=cv2.BORDER_REFLECT)


def degrade(rgb: np.ndarray, ids: np.ndarray, classes: dict[int, str], no_ball: np.ndarray | None,
            rng: np.random.Generator) -> np.ndarray:
    """The sample's stand-in prediction for one frame (see the module docstring).

    Args:
        rgb: (H, W, 3) float32 ground truth in [0, 1].
        ids: (H, W) uint16 instance ids (0 static world).
        classes: instance id -> class name.
        no_ball: (H, W, 3) float32 render without the ball, or None to keep the ball.
        rng: generator for the per-frame noise.

    Returns:
        (H, W, 3) float32 in [0, 1].
    """
    import cv2

    out = _blur(rgb, 0.6)
    out = out + rng.normal(0.0, 0.012, size=out.shape).astype(np.float32)
    person = np.isin(ids, [i for i, c in classes.items() if c == "person"]).astype(np.uint8)
    person = cv2.dilate(person, np.ones((5, 5), np.uint8)).astype(bool)
    out[person] = _blur(rgb, 2.0)[person]
    if no_ball is not None:
        ball = np.isin(ids, [i for i, c in classes.items() if c == "ball"]).astype(np.uint8)
        ball = cv2.dilate(ball, np.ones((3, 3), np.uint8)).astype(bool)
        out[ball] = no_ball[ball]
    return np.clip(out, 0.0, 1.0)


def _write_png(path: Path, rgb: np.ndarray) -> None:
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    u8 = np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)
    if not cv2.imwrite(str(path), np.ascontiguousarray(u8[..., ::-1]),
                       [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"cannot write {path}")


def make_sample(out: Path) -> dict:
    """Render ground truth and degraded predictions into ``out`` (replaced if present)."""
    from reference_models.scenes import build_scene, render_view

    scene = build_scene(PRESET, seed=SEED, size="small", **SIZE)
    tmp = out.with_name(out.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    boxes: dict[str, list] = {}
    rng = np.random.default_rng(SEED)
    for cam in SAMPLE_CAMERAS:
        for f in range(scene.n_frames):
            view = render_view(scene, cam, f)
            classes = {b["id"]: b["class"] for b in view.boxes}
            no_ball = render_view(scene, cam, f, hide=("ball",)).rgb if f % 2 else None
            key = f"{cam}/{f:04d}"
            boxes[key] = view.boxes
            _write_png(tmp / "gt" / f"{key}.png", view.rgb)
            _write_png(tmp / "pred" / f"{key}.png", degrade(view.rgb, view.ids, classes,
                                                            no_ball, rng))
    (tmp / "boxes.json").write_text(json.dumps(boxes, indent=1, sort_keys=True) + "\n")
    info = {"preset": PRESET, "seed": SEED, **SIZE, "cameras": list(SAMPLE_CAMERAS),
            "predictions": "ground truth degraded by reference_models.sample.degrade "
                           "(not a model's output)",
            "command": "python -m reference_models.sample"}
    (tmp / "sample.json").write_text(json.dumps(info, indent=1) + "\n")
    shutil.rmtree(out, ignore_errors=True)
    tmp.rename(out)
    return info


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m reference_models.sample",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=None,
                        help="default: dynaeval/data/sample of the repository (DYNAEVAL_REPO or the "
                        "clone above the current directory)")
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = repo_root() / "dynaeval" / "data" / "sample"
    info = make_sample(args.out)
    size = sum(p.stat().st_size for p in args.out.rglob("*") if p.is_file())
    print(f"sample written to {args.out} ({size / 1e6:.2f} MB): {info}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

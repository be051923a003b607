"""Motion masks vs the scene generator's exact instance masks, and what shadows do to them.

For each preset and camera, every frame is rendered twice: as is, and with all players and the ball
hidden (no pixels, no shadow). Pixels that differ between the two (max over channels > 2/255) but
belong to no instance are the objects' *shadows* (plus anti-aliased edges). Reported per mask kind:

* IoU with the instance mask (ids > 0), and with instance + shadow;
* recall (instance pixels inside the mask) and precision (mask pixels on an instance);
* the share of false-positive mask pixels that lie in a shadow.

Values are means over frames that show at least one instance pixel.

A second table shows the cost of a lighter clean-up: the share of pixels marked as moving in a
*static* sequence (the first empty frame of each preset's first camera, repeated, plus Gaussian
noise of sigma 2/255 and 5/255, as compressed video has).

    python benchmarks/motion_mask_iou.py --size small --cameras 2      # Markdown table on stdout
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from dynaeval.regions.motion import MotionConfig, motion_mask
from reference_models.scenes import PRESETS, CameraRenderer, build_scene

VARIANTS = {
    "isg (default)": MotionConfig(),
    "isg, no dilation": replace(MotionConfig(), dilate_radius=0),
    "isg, light clean-up": MotionConfig(open_radius=0, close_radius=1, min_area=4, dilate_radius=1),
    "ist (default, window 25)": MotionConfig(kind="ist"),
}


def render_camera(preset: str, camera_index: int, size: str, seed: int):
    """Camera name, (T, H, W, 3) frames, (T, H, W) instance and shadow masks, (T, H, W, 3) frames
    with every object hidden."""
    scene = build_scene(preset, seed=seed, size=size)
    cam = scene.cameras[camera_index]
    renderer = CameraRenderer(scene.camera(cam.name), scene.sun, scene.seed, scene.spp)
    rgb, inst, shadow, empties = [], [], [], []
    for t in range(scene.n_frames):
        full = renderer.render(scene.bodies(t), None)
        empty = renderer.render(scene.bodies(t, ("person", "ball")), None)
        ids = full.ids > 0
        rgb.append(full.rgb)
        inst.append(ids)
        shadow.append((np.abs(full.rgb - empty.rgb).max(axis=-1) > 2 / 255) & ~ids)
        empties.append(empty.rgb)
    return cam.name, np.stack(rgb), np.stack(inst), np.stack(shadow), np.stack(empties)


def scores(mask: np.ndarray, inst: np.ndarray, shadow: np.ndarray) -> dict[str, float]:
    """Means over frames with instance pixels of IoU, recall, precision, FP-in-shadow share."""
    rows = []
    for m, i, s in zip(mask, inst, shadow, strict=True):
        if not i.any():
            continue
        fp = m & ~i
        rows.append(
            (
                (m & i).sum() / (m | i).sum(),
                (m & (i | s)).sum() / (m | i | s).sum(),
                (m & i).sum() / i.sum(),
                (m & i).sum() / max(m.sum(), 1),
                (fp & s).sum() / fp.sum() if fp.any() else 0.0,
            )
        )
    a = np.array(rows, dtype=np.float64)
    keys = ("iou", "iou_with_shadow", "recall", "precision", "fp_in_shadow")
    return {k: float(v) for k, v in zip(keys, a.mean(axis=0), strict=True)} | {"frames": len(rows)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="small", help="scene size preset (tiny/small/hd)")
    ap.add_argument("--cameras", type=int, default=2, help="first N cameras of each preset")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.time()
    print("| preset | camera | mask | IoU | IoU (instance + shadow) | recall | precision | FP in shadow | frames |")
    print("|---|---|---|---|---|---|---|---|---|")
    statics = {}
    for preset in PRESETS:
        for k in range(args.cameras):
            cam, rgb, inst, shadow, empty = render_camera(preset, k, args.size, args.seed)
            if k == 0:
                statics[preset] = empty[0]
            for name, cfg in VARIANTS.items():
                r = scores(motion_mask(rgb, cfg), inst, shadow)
                print(
                    f"| {preset} | {cam} | {name} | {r['iou']:.3f} | {r['iou_with_shadow']:.3f} | "
                    f"{r['recall']:.3f} | {r['precision']:.3f} | {r['fp_in_shadow']:.3f} | {r['frames']} |",
                    flush=True,
                )
    print("\n| preset | mask | moving share, static + noise 2/255 | moving share, static + noise 5/255 |")
    print("|---|---|---|---|")
    rng = np.random.default_rng(args.seed)
    for preset, frame in statics.items():
        seqs = [
            np.clip(frame[None] + rng.normal(0, sigma / 255, (24, *frame.shape)), 0, 1).astype(np.float32)
            for sigma in (2, 5)
        ]
        for name, cfg in VARIANTS.items():
            shares = [float(motion_mask(seq, cfg).mean()) for seq in seqs]
            print(f"| {preset} | {name} | {shares[0]:.4f} | {shares[1]:.4f} |", flush=True)
    print(f"\n({time.time() - t0:.0f} s, size {args.size}, seed {args.seed})")


if __name__ == "__main__":
    main()

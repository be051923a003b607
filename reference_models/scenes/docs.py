"""Figures and measurements for ``docs/scenes.md``.

    python -m reference_models.scenes.docs figures RENDERS_DIR docs/img   # frames + layout plot
    python -m reference_models.scenes.docs bench [--hd]                   # culling cost, hd view
    python -m reference_models.scenes.docs ball-sizes                     # ball width on screen

``RENDERS_DIR`` holds the three presets rendered at the default size (one sub-folder per preset).
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

import numpy as np

from reference_models.scenes.presets import PRESETS, build_scene
from reference_models.scenes.render import CameraRenderer, intersect_body
from reference_models.scenes.world import HALF_LENGTH, HALF_WIDTH, _quads

SHOWN = {"single-player-closeup": ["eval00"], "single-player-broadcast": ["cam03"],
         "players-stadium": ["cam02", "eval00"]}
"""Views copied into the docs per preset (frame ``FRAME``)."""
FRAME = 10
"""Frame shown in the docs."""


def copy_frames(renders: Path, img_dir: Path) -> list[Path]:
    """Copy the ``SHOWN`` views of frame ``FRAME`` to ``img_dir/scenes_<preset>_<camera>.png``."""
    img_dir.mkdir(parents=True, exist_ok=True)
    out = []
    for preset, cams in SHOWN.items():
        for cam in cams:
            dst = img_dir / f"scenes_{preset}_{cam}.png"
            shutil.copyfile(renders / preset / "images" / cam / f"{FRAME:04d}.png", dst)
            out.append(dst)
    return out


def layout_plot(path: Path, seed: int = 0) -> None:
    """Top view of the pitch, stands and every preset's cameras (dots: train, stars: eval)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    for ax, preset in zip(axes, PRESETS, strict=True):
        scene = build_scene(preset, seed=seed, size="small")
        ax.add_patch(plt.Rectangle((-HALF_LENGTH, -HALF_WIDTH), 2 * HALF_LENGTH, 2 * HALF_WIDTH,
                                   color="#3a7d3a", alpha=0.35))
        for m, p0, e1, e2 in _quads():
            c = np.array([p0, p0 + e1, p0 + e1 + e2, p0 + e2, p0])
            ax.plot(c[:, 0], c[:, 1], color="grey" if m == 2 else "k", lw=0.6)
        lim = 95 if preset == "players-stadium" else (12 if preset == "single-player-closeup" else 70)
        for cam in scene.cameras:
            eye, fwd = cam.centre, -cam.c2w[:3, 2]
            ev = cam.name.startswith("eval")
            ax.plot(eye[0], eye[1], "*" if ev else "o", color="C3" if ev else "C0", ms=9 if ev else 4)
            ax.arrow(eye[0], eye[1], 0.1 * lim * fwd[0], 0.1 * lim * fwd[1], color="C3" if ev else "C0", width=0.002 * lim,
                     head_width=0.02 * lim, length_includes_head=True)
        for b in scene.bodies(FRAME):
            ax.plot(b.a[:, 0].mean(), b.a[:, 1].mean(), "k." if b.cls == "person" else "y.", ms=4)
        ax.set_title(f"{preset}: {len(scene.train_cameras)} train, {len(scene.eval_cameras)} eval")
        ax.set_aspect("equal")
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim * 0.75, lim * 0.75)
        ax.set_xlabel("x (m)")
    axes[0].set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=70)
    plt.close(fig)


def bench(repeats: int = 3, hd: bool = False) -> dict[str, float]:
    """Seconds per view of a small stadium camera with all objects, one player, none; one player
    cast against the whole sample grid without culling; with ``hd``: an hd view (static world
    cast, then one frame)."""
    scene = build_scene("players-stadium", seed=0, size="small")
    cam = scene.camera("cam00")
    renderer = CameraRenderer(cam, scene.sun, scene.seed, scene.spp)
    players = [i for i, c in scene.classes.items() if c == "person"]

    def timed(hide):
        start = time.perf_counter()
        for f in range(repeats):
            renderer.render(scene.bodies(f, hide), scene.bodies(f + 1, hide))
        return (time.perf_counter() - start) / repeats

    res = {"players": len(players),
           "stadium_cam00_all_objects_s": timed(()),
           "stadium_cam00_one_player_s": timed(tuple(players[1:]) + ("ball",)),
           "stadium_cam00_static_only_s": timed(("person", "ball"))}
    body = scene.bodies(0)[1]
    start = time.perf_counter()
    intersect_body(cam.centre, cam.ray_grid(renderer.k)[0], body)
    res["one_player_whole_grid_unculled_s"] = time.perf_counter() - start
    if hd:
        big = build_scene("players-stadium", seed=0, size="hd", frames=2)
        start = time.perf_counter()
        r = CameraRenderer(big.camera("eval00"), big.sun, big.seed, big.spp)
        res["hd_eval00_static_world_s"] = time.perf_counter() - start
        start = time.perf_counter()
        r.render(big.bodies(0), big.bodies(1))
        res["hd_eval00_frame_s"] = time.perf_counter() - start
    return res


def ball_sizes(seed: int = 0) -> list[str]:
    """Projected ball diameter (pixels, ``2 r f / depth``) over every camera and frame in which the
    ball's centre is inside the image, per preset, size and camera split."""
    from reference_models.scenes.actors import BALL_RADIUS, Ball

    lines = []
    for preset, size, split in [("players-stadium", "hd", "train"), ("players-stadium", "small", "train"),
                                ("players-stadium", "small", "eval"),
                                ("single-player-broadcast", "small", "all"),
                                ("single-player-closeup", "small", "all")]:
        scene = build_scene(preset, seed=seed, size=size)
        names = {"train": scene.train_cameras, "eval": scene.eval_cameras,
                 "all": [c.name for c in scene.cameras]}[split]
        sizes, views = [], 0
        for f in range(scene.n_frames):
            centres = [a.body(scene.time_of(f)).a for a in scene.actors if isinstance(a, Ball)]
            for name in names:
                cam, views = scene.camera(name), views + 1
                for c in centres:
                    uv, depth = cam.project(c)
                    if depth[0] > 0 and 0 <= uv[0, 0] < cam.width and 0 <= uv[0, 1] < cam.height:
                        sizes.append(2 * BALL_RADIUS * cam.fx / depth[0])
        d = np.array(sizes)
        lines.append(f"{preset} {size} {split}: {len(d)} ball images in {views} views, diameter px "
                     f"min {d.min():.2f} median {np.median(d):.2f} max {d.max():.2f}")
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m reference_models.scenes.docs")
    sub = p.add_subparsers(dest="command", required=True)
    f = sub.add_parser("figures")
    f.add_argument("renders", type=Path)
    f.add_argument("img_dir", type=Path)
    b = sub.add_parser("bench")
    b.add_argument("--hd", action="store_true", help="also time an hd view (~2 GB, a minute)")
    sub.add_parser("ball-sizes")
    args = p.parse_args(argv)
    if args.command == "figures":
        for path in copy_frames(args.renders, args.img_dir):
            print(path)
        layout_plot(args.img_dir / "scenes_camera_layouts.png")
        print(args.img_dir / "scenes_camera_layouts.png")
    elif args.command == "ball-sizes":
        print("\n".join(ball_sizes()))
    else:
        for k, v in bench(hd=args.hd).items():
            print(f"{k}: {v:.3f}" if isinstance(v, float) else f"{k}: {v}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Render a whole preset to files: images, depth, masks, flow, boxes.json, transforms.json."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from dynaeval.errors import InputError
from reference_models.scenes.presets import Scene, build_scene
from reference_models.scenes.render import CameraRenderer, View
from reference_models.scenes.world import world_extent

GENERATOR_VERSION = "1"
"""Bumped whenever a change alters rendered bytes for the same preset and seed."""


def render_view(scene: Scene, camera: str, frame: int, spp: int | None = None,
                hide: tuple = ()) -> View:
    """Render one view in memory: ``camera`` name, ``frame`` in ``[0, n_frames)``.

    ``hide``: class names (``"ball"``, ``"person"``) or ids left out entirely (no pixels, no
    shadow, no box). The flow of the last frame is None. For many frames of one camera, reuse a
    ``CameraRenderer`` (``render_scene`` does) to intersect the static world once.
    """
    if not 0 <= frame < scene.n_frames:
        raise InputError(f"frame must be in [0, {scene.n_frames}), got {frame}")
    renderer = CameraRenderer(scene.camera(camera), scene.sun, scene.seed, spp or scene.spp)
    return _render(scene, renderer, frame, hide)


def _render(scene: Scene, renderer: CameraRenderer, frame: int, hide: tuple) -> View:
    nxt = scene.bodies(frame + 1, hide) if frame + 1 < scene.n_frames else None
    return renderer.render(scene.bodies(frame, hide), nxt)


def _c2w_list(c2w: np.ndarray) -> list[list[float]]:
    return [[round(float(v), 9) for v in row] for row in c2w]


def transforms(scene: Scene) -> dict:
    """nerfstudio-style ``transforms.json`` content (OPENCV model, zero distortion)."""
    frames = []
    for cam in scene.cameras:
        for f in range(scene.n_frames):
            stem = f"{cam.name}/{f:04d}"
            entry = {
                "file_path": f"images/{stem}.png",
                "depth_file_path": f"depth/{stem}.npy",
                "instance_mask_path": f"masks/{stem}.png",
                "camera": cam.name,
                "frame": f,
                "time": f / (scene.n_frames - 1) if scene.n_frames > 1 else 0.0,
                "transform_matrix": _c2w_list(cam.c2w),
                "fl_x": cam.fx, "fl_y": cam.fy, "cx": cam.cx, "cy": cam.cy,
                "w": cam.width, "h": cam.height,
                "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0,
            }
            if f + 1 < scene.n_frames:
                entry["flow_file_path"] = f"flow/{stem}.npy"
            frames.append(entry)
    train = [e["file_path"] for e in frames if e["camera"] in scene.train_cameras]
    evals = [e["file_path"] for e in frames if e["camera"] in scene.eval_cameras]
    return {"camera_model": "OPENCV", "train_cameras": scene.train_cameras,
            "eval_cameras": scene.eval_cameras, "train_filenames": train, "val_filenames": evals,
            "test_filenames": evals, "frames": frames}


def metadata(scene: Scene, spp: int, hide: tuple) -> dict:
    """``metadata.json`` content: everything that determines the render (no timings)."""
    return {
        "generator": "reference_models.scenes", "generator_version": GENERATOR_VERSION,
        "preset": scene.preset, "seed": scene.seed, "size": scene.size,
        "width": scene.width, "height": scene.height, "frames": scene.n_frames, "fps": scene.fps,
        "spp": spp, "hide": [str(h) for h in hide], "cameras": [c.name for c in scene.cameras],
        "classes": {"0": "static", **{str(k): v for k, v in scene.classes.items()}},
        "action": scene.action,
        "world": {"units": "metres", "axes": "x along the pitch length, y across, z up; pitch in z=0",
                  "pitch": [105.0, 68.0], "sun_direction": [float(v) for v in scene.sun],
                  "extent": world_extent().tolist()},
        "depth": "float32 .npy, z-depth in metres along the optical axis, 0 = sky",
        "flow": "float32 .npy (H, W, 2), pixels (dx, dy) to the next frame; none for the last frame",
        "masks": "uint16 PNG, 0 = static world, else the instance id of 'classes'",
        "visible": "fraction of the object's in-image pixels (object rendered alone, pixel "
                   "centres) that are not occluded",
    }


def _write_json(path: Path, obj: object) -> None:
    path.write_text(json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n")


def render_scene(preset: str, out_dir: str | Path, size: str = "small", seed: int = 0,
                 width: int | None = None, height: int | None = None, frames: int | None = None,
                 fps: float | None = None, spp: int | None = None, hide: tuple = (),
                 cameras: tuple[str, ...] | None = None, overwrite: bool = False,
                 progress: Callable[[int, int], None] | None = None) -> dict:
    """Render every camera and frame of ``preset`` into ``out_dir``; return the metadata.

    Files: ``images/<camera>/<frame>.png`` (8-bit sRGB), ``depth/...npy``, ``masks/...png``
    (uint16), ``flow/...npy`` (not for the last frame), ``boxes.json``, ``transforms.json``,
    ``metadata.json`` (all byte-identical for the same arguments) and ``timing.json`` (render
    seconds, the one file that differs between runs). ``cameras`` renders only those (e.g. a few
    views at hd); ``progress(done, total)`` is called after each view. Raises InputError for bad
    arguments or a non-empty ``out_dir`` without ``overwrite`` (with it, files are written over;
    files of an earlier, larger render that this one does not produce are left as they were).
    """
    import cv2

    scene = build_scene(preset, seed, size, width, height, frames, fps, spp)
    if cameras:
        keep = [scene.camera(name) for name in dict.fromkeys(cameras)]
        scene = replace(scene, cameras=keep,
                        eval_cameras=[c.name for c in keep if c.name in scene.eval_cameras])
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder; choose another path", path=out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise InputError("output folder is not empty; choose a new folder or pass overwrite=True "
                         "(--overwrite)", path=out)
    start = time.perf_counter()
    boxes: dict[str, list] = {}
    total, done = len(scene.cameras) * scene.n_frames, 0
    bodies = [scene.bodies(f, hide) for f in range(scene.n_frames)]  # shared by all cameras
    for cam in scene.cameras:
        for sub in ("images", "depth", "masks", "flow"):
            (out / sub / cam.name).mkdir(parents=True, exist_ok=True)
        renderer = CameraRenderer(cam, scene.sun, scene.seed, scene.spp)
        for f in range(scene.n_frames):
            view = renderer.render(bodies[f], bodies[f + 1] if f + 1 < scene.n_frames else None)
            stem = f"{cam.name}/{f:04d}"
            rgb8 = np.round(view.rgb * 255).astype(np.uint8)
            cv2.imwrite(str(out / "images" / f"{stem}.png"), rgb8[..., ::-1])
            cv2.imwrite(str(out / "masks" / f"{stem}.png"), view.ids)
            np.save(out / "depth" / f"{stem}.npy", view.depth)
            if view.flow is not None:
                np.save(out / "flow" / f"{stem}.npy", view.flow)
            boxes[stem] = view.boxes
            done += 1
            if progress is not None:
                progress(done, total)
    seconds = time.perf_counter() - start
    meta = metadata(scene, scene.spp, hide)
    _write_json(out / "boxes.json", boxes)
    _write_json(out / "transforms.json", transforms(scene))
    _write_json(out / "metadata.json", meta)
    _write_json(out / "timing.json", {"render_seconds": round(seconds, 3), "views": total,
                                      "seconds_per_view": round(seconds / total, 4)})
    return {**meta, "render_seconds": seconds}

"""Synthetic soccer scenes with exact ground truth (RGB, depth, instance masks, flow, boxes).

    from reference_models.scenes import build_scene, render_view, render_scene
    scene = build_scene("single-player-closeup", seed=0, size="tiny")
    view = render_view(scene, "cam00", frame=3, hide=("ball",))   # arrays in memory
    render_scene("players-stadium", "out/stadium", size="small")    # files on disk

Command line: ``python -m reference_models.scenes render PRESET OUT [--size ...]``. See
``docs/scenes.md`` for conventions and formats.
"""

from reference_models.scenes.camera import Camera, look_at
from reference_models.scenes.output import render_scene, render_view, transforms
from reference_models.scenes.presets import PRESETS, SIZES, Scene, build_scene
from reference_models.scenes.render import CameraRenderer, View

__all__ = ["PRESETS", "SIZES", "Camera", "CameraRenderer", "Scene", "View", "build_scene",
           "look_at", "render_scene", "render_view", "transforms"]

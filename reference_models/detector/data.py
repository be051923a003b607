"""Training and evaluation views for the default detector, rendered from the synthetic scenes.

A *sample* is one rendered view: ``{"preset", "seed", "camera", "frame", "image", "boxes"}`` with
``image`` ``(H, W, 3)`` uint8 sRGB at the size it was rendered, and ``boxes`` the generator's exact
records ``{"class", "id", "box", "visible"}`` (max-exclusive pixels). Samples of one (preset, seed)
form a *shard*, cached as a pickle under ``<cache>/<split>/<preset>-<seed>.pkl`` so a long render
can be resumed and training reads what is there.

Training seeds and evaluation seeds never overlap (``TRAIN_SEED0`` vs ``EVAL_SEED0``).
"""

from __future__ import annotations

import pickle
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from reference_models.scenes import PRESETS, CameraRenderer, build_scene

TRAIN_SEED0 = 1000
"""Training scenes use seeds ``TRAIN_SEED0, TRAIN_SEED0 + 1, ...``."""
EVAL_SEED0 = 0
"""Held-out evaluation scenes use seeds ``EVAL_SEED0, EVAL_SEED0 + 1, ...`` (below ``TRAIN_SEED0``)."""


@dataclass(frozen=True)
class RenderPlan:
    """How many views to render per scene and at which sizes."""

    seeds: int = 48
    """Scenes (seeds) per preset."""
    cameras: int = 2
    """Cameras drawn per scene (evaluation cameras included in the draw)."""
    frames: int = 3
    """Frames drawn per camera (the static world is intersected once per camera)."""
    min_width: int = 96
    """Smallest image width in px (widths are drawn log-uniformly in [min_width, max_width])."""
    max_width: int = 800
    """Largest image width in px."""
    spp_max_pixels: int = 400 * 225
    """Views with at most this many pixels are rendered with 4 samples per pixel, larger ones 1."""
    n_frames: int = 24
    """Length of the animation the frames are drawn from (the generator's ``small`` length)."""


TINY_PLAN = RenderPlan(seeds=2, cameras=1, frames=2, min_width=64, max_width=128, n_frames=8)
"""A render plan that takes seconds (tests)."""


def _draw_size(rng: np.random.Generator, plan: RenderPlan) -> tuple[int, int]:
    w = float(np.exp(rng.uniform(np.log(plan.min_width), np.log(plan.max_width))))
    aspect = 0.5625 if rng.random() < 0.7 else float(rng.uniform(0.4, 1.0))
    width = max(16, int(round(w / 2)) * 2)
    height = max(16, int(round(width * aspect / 2)) * 2)
    return width, height


def render_shard(preset: str, seed: int, plan: RenderPlan, rng_seed: int | None = None) -> list[dict]:
    """Render the views of one scene: random size, ``plan.cameras`` cameras x ``plan.frames`` frames.

    Deterministic for (preset, seed, plan, rng_seed). Images are uint8 ``(H, W, 3)`` RGB.
    """
    rng = np.random.default_rng([seed, PRESETS.index(preset), 0 if rng_seed is None else rng_seed])
    width, height = _draw_size(rng, plan)
    spp = 4 if width * height <= plan.spp_max_pixels else 1
    scene = build_scene(preset, seed=seed, size="small", width=width, height=height,
                        frames=plan.n_frames, spp=spp)
    cams = rng.choice(len(scene.cameras), size=min(plan.cameras, len(scene.cameras)), replace=False)
    out = []
    for ci in sorted(int(c) for c in cams):
        cam = scene.cameras[ci]
        renderer = CameraRenderer(cam, scene.sun, scene.seed, scene.spp)
        frames = rng.choice(scene.n_frames, size=min(plan.frames, scene.n_frames), replace=False)
        for f in sorted(int(x) for x in frames):
            view = renderer.render(scene.bodies(f), None)  # no flow needed
            out.append({"preset": preset, "seed": seed, "camera": cam.name, "frame": f,
                        "image": np.round(view.rgb * 255).astype(np.uint8), "boxes": view.boxes})
    return out


def render_eval_shard(preset: str, seed: int, width: int, height: int, cameras: int = 4,
                      frames: int = 2, spp: int = 4) -> list[dict]:
    """Held-out views of one scene at a fixed size: every evaluation camera, then training cameras
    evenly spread, up to ``cameras``; ``frames`` frames spread over the 24-frame animation."""
    scene = build_scene(preset, seed=seed, size="small", width=width, height=height, spp=spp)
    evals = [c for c in scene.cameras if c.name in scene.eval_cameras]
    trains = [c for c in scene.cameras if c.name not in scene.eval_cameras]
    n_train = max(0, cameras - len(evals))
    pick = evals[:cameras] + [trains[int(i)] for i in
                              np.round(np.linspace(0, len(trains) - 1, n_train)).astype(int)][:n_train]
    idx = np.round(np.linspace(0, scene.n_frames - 1, frames + 2)[1:-1]).astype(int)
    out = []
    for cam in pick:
        renderer = CameraRenderer(cam, scene.sun, scene.seed, scene.spp)
        for f in idx:
            view = renderer.render(scene.bodies(int(f)), None)
            out.append({"preset": preset, "seed": seed, "camera": cam.name, "frame": int(f),
                        "image": np.round(view.rgb * 255).astype(np.uint8), "boxes": view.boxes})
    return out


def shard_path(cache: Path, split: str, preset: str, seed: int) -> Path:
    """Where the shard of (split, preset, seed) is cached."""
    return Path(cache) / split / f"{preset}-{seed}.pkl"


def cached_shard(path: Path, make: Callable[[], list[dict]]) -> list[dict]:
    """Load the shard at ``path``, or make it and write it atomically (tmp file + rename)."""
    path = Path(path)
    if path.is_file():
        with path.open("rb") as f:
            return pickle.load(f)
    samples = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    with tmp.open("wb") as f:
        pickle.dump(samples, f, protocol=pickle.HIGHEST_PROTOCOL)
    tmp.replace(path)
    return samples


def training_samples(cache: Path, plan: RenderPlan, presets: tuple[str, ...] = PRESETS,
                     progress: Callable[[str], None] | None = None) -> list[dict]:
    """All training samples of ``plan`` (rendered once into ``cache``, then read back)."""
    samples: list[dict] = []
    for i in range(plan.seeds):  # interleave presets so a partial cache is balanced
        for preset in presets:
            seed = TRAIN_SEED0 + i
            path = shard_path(cache, f"train-{plan.max_width}", preset, seed)
            samples += cached_shard(path, lambda p=preset, s=seed: render_shard(p, s, plan))
            if progress is not None:
                progress(f"{preset} seed {seed}: {len(samples)} views")
    return samples

"""K-Planes' field for the shared model: configuration, presets, and the encoding builder.

"Model only what a scene needs" (``dynamic_box=True``): the static stadium needs no time planes.
A static three-plane field (xy, xz, yz) covers the whole contracted world, and the three
space-time planes (xt, yt, zt) exist only inside the box the motion masks say moves
(``reference_models.common.importance.moving_box``), at their own, finer resolution over that
box. Inside it the features are ``static(x) * time_factor(x, t)`` — exactly K-Planes' product,
with the time planes starting at 1 — and outside the time factor is 1. With
``dynamic_planes="space-time"`` (``-dynbox-fine``) the factor over the box is all six planes,
each starting at 1: the world's space planes have cells of ~13 cm over the close-up scene box
(128 of 256 cells cover it), the box's own planes ~4.5 cm, about a pixel of the player.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import nn

from dynaeval.errors import InputError
from reference_models.common.data import Dataset
from reference_models.common.encodings import PlaneEncoding
from reference_models.common.footprint import VIEWS_NEEDED, footprint_resolution
from reference_models.common.importance import moving_box
from reference_models.common.rays import contract
from reference_models.common.seed import seed_preset
from reference_models.common.train import ModelSpec, standard_presets


@dataclass
class KPlanesConfig:
    """K-Planes encoding sizes (K-Planes DyNeRF hybrid: 64 base, scales 1/2/4/8, F=16, T=150)."""

    resolution: int = 64
    """Space resolution of the coarsest scale (cells per axis over the contracted world)."""
    scales: tuple[int, ...] = (1, 2, 4)
    """Multipliers of ``resolution``, one plane set per scale (capped at ``max_resolution``)."""
    features: int = 16
    """Features per plane and scale (F)."""
    max_resolution: int = 256
    """Cap on any space resolution (planes above 256^2 cost much more on CPU)."""
    time_resolution: int | None = None
    """Cells along time; None: the number of frames (knots on frames, as the ball needs)."""
    dynamic_box: bool = False
    """Time planes only inside the box the motion masks say moves, a static field elsewhere."""
    dynamic_resolution: int = 32
    """``dynamic_box``: space cells of the coarsest time planes across the moving box."""
    footprint: bool = False
    """Size the world planes per axis from the training cameras' pixel footprint on the scene's
    extent (``common.footprint.footprint_resolution``, computed when a run starts and kept in
    its ``config.json``): the finest scale gets those cells, coarser scales ``1 / scale`` of
    them; ``resolution`` and ``max_resolution`` then do not size the world planes."""
    footprint_quantile: float = 0.75
    """``footprint``: the quantile of the pixels' needs the finest planes meet."""
    footprint_max: int = 1024
    """``footprint``: cap on the cells of any axis."""
    footprint_views: int = VIEWS_NEEDED
    """``footprint``: training cameras that must resolve a surface point for a pixel of it to
    ask its cells (``common.footprint.covered_asks``; 1: the pixel footprint alone)."""
    dynamic_planes: str = "time"
    """``dynamic_box``: planes of the factor over the moving box: ``time`` (xt, yt, zt) or
    ``space-time`` (all six, every one starting at 1: the box also gets its own fine space
    planes, so a player keeps detail finer than the world planes' cells)."""


class _ScaleRows(torch.autograd.Function):
    @staticmethod
    def forward(ctx, f, idx, factor):  # noqa: ANN001
        rows = f.index_select(0, idx)
        ctx.save_for_backward(idx, rows, factor)
        ctx.mark_dirty(f)
        return f.index_copy_(0, idx, rows * factor)

    @staticmethod
    def backward(ctx, g):  # noqa: ANN001
        idx, rows, factor = ctx.saved_tensors
        g_rows = g.index_select(0, idx)
        return g.clone().index_copy_(0, idx, g_rows * factor), None, g_rows * rows


def scale_rows(f: torch.Tensor, idx: torch.Tensor, factor: torch.Tensor) -> torch.Tensor:
    """``f`` (N, C) with its rows ``idx`` (M,) int64 multiplied by ``factor`` (M, C), *in place*
    (``f`` must be a fresh result that nothing else needs, e.g. an encoding's output);
    differentiable in ``f`` and ``factor``. One gather and one scatter each way, where
    ``f[sel] = f[sel] * factor`` on a copy costs autograd a clone, masks and their backward."""
    return _ScaleRows.apply(f, idx, factor)


class DynamicBoxEncoding(nn.Module):
    """Static planes everywhere, times a time factor inside the moving box (see module doc)."""

    def __init__(self, cfg: KPlanesConfig, n_frames: int, box_grid: np.ndarray,
                 world_resolution: list[int] | None = None) -> None:
        super().__init__()
        t_res = max(cfg.time_resolution or n_frames, 2)
        base, cap = world_cells(cfg, world_resolution)
        self.static = PlaneEncoding(base, t_res, tuple(cfg.scales), cfg.features, cap,
                                    planes="space")
        if cfg.dynamic_planes not in ("time", "space-time"):
            raise InputError(f"dynamic_planes must be 'time' or 'space-time', got {cfg.dynamic_planes!r}")
        # ``time``: the factor over the moving box (its planes also hold space-only ones with
        # ``dynamic_planes="space-time"``; the name stays so checkpoints keep their keys)
        self.time = PlaneEncoding(cfg.dynamic_resolution, t_res, tuple(cfg.scales), cfg.features,
                                  cfg.max_resolution, planes=cfg.dynamic_planes, factor=True)
        self.out_dim = self.static.out_dim
        box = torch.as_tensor(box_grid, dtype=torch.float32)
        self.register_buffer("centre", 0.5 * (box[0] + box[1]))
        self.register_buffer("half_size", (0.5 * (box[1] - box[0])).clamp_min(1e-6))
        self.static_only = False
        """Skip the time factor (the same field while its planes are all 1: static warm-up)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(N, 4) grid coordinates in [-1, 1] -> (N, out_dim) features."""
        local = (x[:, :3] - self.centre) / self.half_size
        f = self.static(x)
        if self.static_only:
            return f
        idx = (local.abs() <= 1.0).all(-1).nonzero()[:, 0]
        if idx.numel() == 0:
            return f
        factor = self.time(torch.cat([local.index_select(0, idx), x[:, 3:].index_select(0, idx)], -1))
        return scale_rows(f, idx, factor)

    def regularizers(self) -> dict[str, torch.Tensor]:
        """The static planes' TV plus the time planes' TV, smoothness and L1."""
        a, b = self.static.regularizers(), self.time.regularizers()
        return {**b, "tv": a["tv"] + b["tv"]}


class NothingMoves(InputError):
    """A ``dynamic_box`` preset on a scene whose training cameras' motion masks find no moving
    region (far cameras at small sizes: the players are a few pixels); the plain preset fits it."""


def world_cells(cfg: KPlanesConfig, world_resolution: list[int] | None
                ) -> tuple[int | list[int], int | list[int]]:
    """(coarsest-scale cells, cap) of the world planes: the config's, or per axis from the
    footprint rule's finest cells ``world_resolution`` (x, y, z)."""
    if world_resolution is None:
        return cfg.resolution, cfg.max_resolution
    top = max(cfg.scales)
    return [max(2, int(r) // top) for r in world_resolution], [int(r) for r in world_resolution]


def scene_extras(cfg: KPlanesConfig, data: Dataset) -> dict:
    """``scene`` entries a run computes once from its training data: with ``footprint`` the world
    planes' finest cells per axis (``world_resolution``), with ``dynamic_box`` the moving box
    in metres (``moving_box``)."""
    out = {}
    if cfg.footprint:
        out["world_resolution"] = list(footprint_resolution(
            data.train, data.box, data.extent, quantile=cfg.footprint_quantile,
            max_cells=cfg.footprint_max, views_needed=cfg.footprint_views))
    return {**out, **find_moving_box(cfg, data)}


def find_moving_box(cfg: KPlanesConfig, data: Dataset) -> dict:
    """``scene`` entries for ``dynamic_box``: the moving box in metres (empty without it)."""
    if not cfg.dynamic_box:
        return {}
    found = moving_box(data.train, data.box)
    if found is None:
        raise NothingMoves("the motion masks of the training cameras found nothing that moves; "
                           "train the plain model (without dynamic_box)", path=data.root)
    return {"moving_box": found.tolist()}


def build_encoding(cfg: KPlanesConfig, scene: dict) -> nn.Module:
    """The encoding for a scene: six planes, or with ``dynamic_box`` static planes plus time
    planes over ``scene["moving_box"]`` (``scene["n_frames"]`` sets the default time cells)."""
    t_res = cfg.time_resolution or int(scene["n_frames"])
    world = scene.get("world_resolution")
    if cfg.footprint and world is None:
        raise InputError("a footprint preset needs scene['world_resolution'] (computed when the "
                         "run starts); this run's config.json has none")
    if not cfg.dynamic_box:
        base, cap = world_cells(cfg, world)
        return PlaneEncoding(base, max(t_res, 2), tuple(cfg.scales), cfg.features, cap)
    corners = contract(torch.tensor(scene["moving_box"]), torch.tensor(scene["box"]))
    return DynamicBoxEncoding(cfg, int(scene["n_frames"]), corners.numpy(), world)


PRESETS = standard_presets(
    tiny=KPlanesConfig(resolution=16, scales=(1, 2), features=8),
    small=KPlanesConfig())
for _name in ("tiny", "small"):
    _model, _render, _train = PRESETS[_name]
    _dynbox = replace(_model, dynamic_box=True, dynamic_resolution=_model.resolution // 2)
    PRESETS[f"{_name}-dynbox"] = (_dynbox, _render, _train)
    PRESETS[f"{_name}-dynbox-fine"] = (replace(_dynbox, dynamic_planes="space-time"), _render, _train)
    PRESETS[f"{_name}-fp"] = (replace(_model, footprint=True), _render, _train)
    PRESETS[f"{_name}-dynbox-fine-fp"] = (replace(_dynbox, dynamic_planes="space-time",
                                                  footprint=True), _render, _train)
"""``tiny``: tests (seconds); ``small``: the documented runs (see ``standard_presets``);
``-dynbox``: the same with ``dynamic_box``; ``-dynbox-fine``: with the six-plane factor over the
moving box (``dynamic_planes="space-time"``); ``-fp``: world planes sized per axis by the cameras'
pixel footprint (``footprint=True``; ``-dynbox-fine-fp`` both)."""

SEED = KPlanesConfig(resolution=64, scales=(1, 2, 4, 8, 16, 32), features=16, max_resolution=2048)
"""The seed study's K-Planes (for a GPU): K-Planes' DyNeRF planes (64 cells at the coarsest
scale, 16 features) with the seed's "two additional scales ... multiscale resolutions from 2^6 to
2^11" (scales 1 to 32: 64 to 2,048 cells, so the cap is 2,048); time cells on the frames (the
seed does not state its own; K-Planes' DyNeRF has 150 for 300 frames). 273M field parameters at
24 frames (1.1 GB of float32; ~4.4 GB with the gradients and Adam's two moments)."""
PRESETS["seed"] = seed_preset(SEED)

SPEC = ModelSpec("kplanes", KPlanesConfig, PRESETS, build_encoding, scene_extras)
"""What the shared CLI and training loop need to run K-Planes."""

"""How many grid cells each world axis needs: the training cameras' pixel footprint on the scene.

A plane of the contracted world (``rays.contract``) resolves nothing finer than its cells, so a
pixel of a far surface should move at least one cell. For each training camera (its first view;
cameras are static) rays through a regular grid of pixels are followed to where they leave the
scene's extent (the generator's ``world.extent``: pitch, boards and stands; the pitch is its
floor), whose face stands in for the surface the pixel sees. The neighbouring pixels' rays met
on the same face give the contracted step of one pixel along each grid axis (a grazing view of
the pitch moves far along it); the cells an axis needs are
``2 / step`` (the grid spans ``[-1, 1]``), counted over the pixels whose step moves that axis
(at least ``axis_share`` of their largest axis step: a pixel looking along ``x`` says nothing of
``x``). The rule takes a ``quantile`` of those needs, rounds up to a multiple of ``multiple`` and
caps the result at ``max_cells``.

Inside the inner box a cell is a fixed length, so near surfaces (the pitch at a camera's feet)
ask the most; beyond it the contraction is angular, so a frontal wall at 30 m asks what one at
90 m does, and oblique far surfaces (the stands seen along the pitch) ask more. On the close-up
scene (30 cameras 4–8 m from the player, the stands 40–90 m away) the median pixel asks ~270
cells along x and y and ~135 along z, the 75th percentile ~420 / ~415 / ~290 (-> 448, 448, 320):
the isotropic 256 cells of the ``small`` presets are too coarse along x and y, and the flat inner
box (17 m across, 3 m high) means z needs fewer cells than x and y.
"""

from __future__ import annotations

import numpy as np
import torch

from dynaeval.errors import InputError
from reference_models.common.data import Views
from reference_models.common.rays import contract, pixel_rays


def exit_face(origin: torch.Tensor, directions: torch.Tensor, extent: torch.Tensor
              ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Where rays from ``origin`` (3,) inside the box ``extent`` (2, 3) along unit ``directions``
    (N, 3) leave it: distance (N,) float64 metres (0 for an origin outside the box), the axis (N,)
    int64 of the face they cross and that face's coordinate (N,) float64 metres."""
    t_lo = (extent[0] - origin) / directions
    t_hi = (extent[1] - origin) / directions
    far = torch.maximum(t_lo, t_hi).nan_to_num(nan=float("inf"))
    dist, axis = far.min(dim=-1)
    upper = directions.gather(1, axis[:, None])[:, 0] > 0
    plane = torch.where(upper, extent[1][axis], extent[0][axis])
    return dist.clamp_min(0.0), axis, plane


def exit_distance(origin: torch.Tensor, directions: torch.Tensor, extent: torch.Tensor
                  ) -> torch.Tensor:
    """Distance (N,) float64 metres along unit ``directions`` (N, 3) from ``origin`` (3,) inside the
    box ``extent`` (2, 3) to where each ray leaves it (0 for an origin outside the box)."""
    return exit_face(origin, directions, extent)[0]


def pixel_steps(views: Views, box: np.ndarray, extent: np.ndarray, every: int = 4) -> np.ndarray:
    """(P, 3) float64 contracted-grid step of one pixel along x, y, z, for every ``every``-th pixel
    row and column of each training camera's first view, at the distance where the pixel's ray
    leaves ``extent`` (2, 3) metres; ``box`` (2, 3) is the model's inner box."""
    b, ext = torch.as_tensor(box, dtype=torch.float64), torch.as_tensor(extent, dtype=torch.float64)
    rows, cols = torch.meshgrid(torch.arange(0, views.height, every),
                                torch.arange(0, views.width, every), indexing="ij")
    rows, cols = rows.reshape(-1), cols.reshape(-1)
    out = []
    for idx in views.camera_sequences().values():
        c2w = torch.as_tensor(views.c2w[idx[0]], dtype=torch.float64).expand(len(rows), 4, 4)
        intr = torch.as_tensor(views.intrinsics[idx[0]], dtype=torch.float64).expand(len(rows), 4)
        origin = c2w[0, :3, 3]

        def rays(r: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
            return pixel_rays(c2w, intr, r, c)[1]

        d = rays(rows, cols)
        t, axis, plane = exit_face(origin, d, ext)
        here = contract(origin + t[:, None] * d, b)
        keep = t > 0
        steps = []
        for dr, dc in ((0, 1), (1, 0)):  # the next pixel's ray on the same face
            dn = rays(rows + dr, cols + dc)
            tn = (plane - origin[axis]) / dn.gather(1, axis[:, None])[:, 0]
            keep &= torch.isfinite(tn) & (tn > 0)
            steps.append((contract(origin + tn.nan_to_num(0.0)[:, None] * dn, b) - here).abs())
        out.append(torch.maximum(*steps)[keep])
    return torch.cat(out).numpy()


def footprint_resolution(views: Views, box: np.ndarray, extent: np.ndarray | None,
                         quantile: float = 0.75, multiple: int = 64, max_cells: int = 1024,
                         axis_share: float = 0.25, every: int = 4) -> tuple[int, int, int]:
    """Cells (x, y, z) of the finest world planes over the contracted world (see module doc).

    Args:
        views: training views (the first view of each camera is used).
        box: (2, 3) inner scene box (metres) of the model's contraction.
        extent: (2, 3) box (metres) holding everything but the sky; None raises InputError.
        quantile: which of the pixels' needs the grid meets (0.5: the median pixel).
        multiple: cells are rounded up to a multiple of this (and are at least this).
        max_cells: cap per axis (memory: a 1024 x 1024 x 16 plane is 64 MB, Adam keeps 3).
        axis_share: a pixel counts for an axis when its step there is at least this share of
            its largest axis step.
        every: pixel stride of the sampled grid.

    Returns:
        Cells per axis, each a multiple of ``multiple`` in ``[multiple, max_cells]``.
    """
    if extent is None:
        raise InputError("the footprint rule needs the scene's extent (metadata.json "
                         "world.extent, written by reference_models.scenes); render the scene "
                         "again or use a preset without footprint planes")
    if not 0.0 < quantile <= 1.0:
        raise InputError(f"quantile must be in (0, 1], got {quantile}")
    steps = pixel_steps(views, box, extent, every)
    if len(steps) == 0:
        raise InputError("no training pixel sees the scene's extent (cameras outside it?)")
    largest = steps.max(axis=1, keepdims=True)
    cells = []
    for axis in range(3):
        s = steps[:, axis][(steps[:, axis] >= axis_share * largest[:, 0]) & (steps[:, axis] > 0)]
        need = float(np.quantile(2.0 / s, quantile)) if len(s) else float(multiple)
        cells.append(int(min(max(np.ceil(need / multiple) * multiple, multiple), max_cells)))
    return cells[0], cells[1], cells[2]

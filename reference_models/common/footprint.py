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

A pixel asks only what enough cameras can pin down (``covered_asks``): its surface point is
projected into every training camera (the extent is a box the cameras stand in, so no part of it
hides another), each camera that sees it asks ``2 / step`` of its own pixel there, and the pixel's
ask is limited to the ``views_needed``-th largest of those (0 where fewer cameras see the point:
the coarse grid is all the rig constrains there). A stretch of stand seen by one far camera then
asks for no fine cells however small that camera's pixels are; more cameras never lower a point's
ask.

Inside the inner box a cell is a fixed length, so near surfaces (the pitch at a camera's feet)
ask the most; beyond it the contraction is angular, so a frontal wall at 30 m asks what one at
90 m does, and oblique far surfaces (the stands seen along the pitch) ask more. On the close-up
scene (30 cameras 4–8 m from the player, the stands 40–90 m away) the median pixel asks ~270
cells along x and y and ~135 along z, the 75th percentile ~420 / ~415 / ~290 (-> 448, 448, 320):
the isotropic 256 cells of the ``small`` presets are too coarse along x and y, and the flat inner
box (17 m across, 3 m high) means z needs fewer cells than x and y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from dynaeval.errors import InputError
from reference_models.common.data import Views
from reference_models.common.rays import contract, pixel_rays

VIEWS_NEEDED = 3
"""Training cameras that must resolve a surface point for a pixel of it to ask its cells, unless
told otherwise (``covered_asks``; ``KPlanesConfig.footprint_views``)."""


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


def _face_steps(c2w: torch.Tensor, intr: torch.Tensor, rows: torch.Tensor, cols: torch.Tensor,
                axis: torch.Tensor, plane: torch.Tensor, box: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
    """One camera's contracted-grid step of one pixel on given faces.

    Args:
        c2w: (4, 4) float64 camera-to-world; intr: (4,) float64 ``fx, fy, cx, cy`` pixels.
        rows, cols: (N,) pixel indices (int64, or float64 for points between pixel centres).
        axis: (N,) int64 axis of the face each pixel's ray meets; plane: (N,) float64 its
            coordinate (metres).
        box: (2, 3) float64 inner box (metres) of the contraction.

    Returns:
        ``steps`` (N, 3) float64: the contracted distance along x, y, z from where the pixel's ray
        meets the face to where the next column's and the next row's rays do (the larger of the
        two per axis); ``keep`` (N,) bool: all three rays meet the face in front of the camera.
    """
    n = len(rows)
    c2w, intr, origin = c2w.expand(n, 4, 4), intr.expand(n, 4), c2w[:3, 3]
    keep = torch.ones(n, dtype=torch.bool)
    points = []
    for dr, dc in ((0, 0), (0, 1), (1, 0)):
        d = pixel_rays(c2w, intr, rows + dr, cols + dc)[1]
        t = (plane - origin[axis]) / d.gather(1, axis[:, None])[:, 0]
        keep &= torch.isfinite(t) & (t > 0)
        points.append(contract(origin + t.nan_to_num(0.0)[:, None] * d, box))
    return torch.maximum((points[1] - points[0]).abs(), (points[2] - points[0]).abs()), keep


@dataclass
class PixelSamples:
    """Every ``every``-th pixel row and column of each training camera's first view, followed to
    where its ray leaves the scene's extent."""

    steps: np.ndarray
    """(P, 3) float64 contracted-grid step of one pixel along x, y, z there (``_face_steps``)."""
    points: np.ndarray
    """(P, 3) float64 world point (metres) where the ray leaves the extent."""
    axis: np.ndarray
    """(P,) int64 axis of the extent face the point lies on."""
    plane: np.ndarray
    """(P,) float64 coordinate (metres) of that face."""
    camera: np.ndarray
    """(P,) int64 which camera's pixel: an index into ``views.camera_sequences()``'s order."""


def pixel_samples(views: Views, box: np.ndarray, extent: np.ndarray, every: int = 4
                  ) -> PixelSamples:
    """The sampled pixels of the training cameras and their one-pixel steps on the extent (see
    ``PixelSamples``); ``box`` (2, 3) is the model's inner box, ``extent`` (2, 3) the scene's,
    both metres. Pixels of a camera outside the extent, or whose neighbours' rays miss the face,
    are left out."""
    b, ext = torch.as_tensor(box, dtype=torch.float64), torch.as_tensor(extent, dtype=torch.float64)
    rows, cols = torch.meshgrid(torch.arange(0, views.height, every),
                                torch.arange(0, views.width, every), indexing="ij")
    rows, cols = rows.reshape(-1), cols.reshape(-1)
    parts: list[list[torch.Tensor]] = [[], [], [], [], []]
    for cam, idx in enumerate(views.camera_sequences().values()):
        c2w = torch.as_tensor(views.c2w[idx[0]], dtype=torch.float64)
        intr = torch.as_tensor(views.intrinsics[idx[0]], dtype=torch.float64)
        origin = c2w[:3, 3]
        d = pixel_rays(c2w.expand(len(rows), 4, 4), intr.expand(len(rows), 4), rows, cols)[1]
        t, axis, plane = exit_face(origin, d, ext)
        steps, keep = _face_steps(c2w, intr, rows, cols, axis, plane, b)
        keep &= t > 0
        for part, v in zip(parts, (steps, origin + t[:, None] * d, axis, plane,
                                   torch.full_like(axis, cam)), strict=True):
            part.append(v[keep])
    return PixelSamples(*(torch.cat(p).numpy() for p in parts))


def pixel_steps(views: Views, box: np.ndarray, extent: np.ndarray, every: int = 4) -> np.ndarray:
    """(P, 3) float64 contracted-grid step of one pixel along x, y, z, for every ``every``-th pixel
    row and column of each training camera's first view, at the distance where the pixel's ray
    leaves ``extent`` (2, 3) metres; ``box`` (2, 3) is the model's inner box."""
    return pixel_samples(views, box, extent, every).steps


def axis_asks(steps: np.ndarray, axis_share: float) -> np.ndarray:
    """(N, 3) float64 cells each axis needs, ``2 / step``, from one-pixel ``steps`` (N, 3); NaN
    where the step does not move that axis (below ``axis_share`` of its largest axis step)."""
    moves = (steps >= axis_share * steps.max(axis=1, keepdims=True)) & (steps > 0)
    with np.errstate(divide="ignore"):
        return np.where(moves, 2.0 / np.where(moves, steps, 1.0), np.nan)


def camera_asks(views: Views, samples: PixelSamples, box: np.ndarray, axis_share: float = 0.25
                ) -> np.ndarray:
    """(P, C, 3) float64: what each of the C training cameras (first views) asks of each sample's
    surface point along x, y, z — ``2 / step`` of its own pixel there (``axis_asks``) where the
    point projects into its image (in front, inside the frame; the extent is a box the cameras
    stand in, so nothing of it hides another part of it), 0 where the camera does not see the
    point or its step there does not move that axis."""
    b = torch.as_tensor(box, dtype=torch.float64)
    x = torch.as_tensor(samples.points)
    axis, plane = torch.as_tensor(samples.axis), torch.as_tensor(samples.plane)
    out = np.zeros((len(x), len(views.camera_sequences()), 3))
    for cam, idx in enumerate(views.camera_sequences().values()):
        c2w = torch.as_tensor(views.c2w[idx[0]], dtype=torch.float64)
        intr = torch.as_tensor(views.intrinsics[idx[0]], dtype=torch.float64)
        local = (x - c2w[:3, 3]) @ c2w[:3, :3]  # camera frame: -Z forward, +Y up
        depth = -local[:, 2]
        fx, fy, cx, cy = intr.unbind()
        u = cx + fx * local[:, 0] / depth.clamp_min(1e-9)
        v = cy - fy * local[:, 1] / depth.clamp_min(1e-9)
        seen = (depth > 0) & (u >= 0) & (u < views.width) & (v >= 0) & (v < views.height)
        steps, keep = _face_steps(c2w, intr, v - 0.5, u - 0.5, axis, plane, b)
        asks = np.nan_to_num(axis_asks(steps.numpy(), axis_share), nan=0.0)
        out[:, cam] = np.where((seen & keep).numpy()[:, None], asks, 0.0)
    return out


def covered_asks(views: Views, samples: PixelSamples, box: np.ndarray, views_needed: int,
                 axis_share: float = 0.25) -> np.ndarray:
    """(P, 3) float64 cells each sample's pixel asks along x, y, z once its surface point must be
    resolved by ``views_needed`` cameras: its own ask (``axis_asks``: NaN where its step does
    not move that axis) limited to the ``views_needed``-th largest ask of the cameras that see
    the point (its own camera among them); 0 where fewer cameras see it (the coarse grid does).
    More cameras never lower a point's ask; ``views_needed=1`` gives each pixel its own ask."""
    own = axis_asks(samples.steps, axis_share)
    if views_needed == 1:
        return own
    asks = camera_asks(views, samples, box, axis_share)
    asks[np.arange(len(own)), samples.camera] = np.nan_to_num(own, nan=0.0)
    if asks.shape[1] < views_needed:
        kth = np.zeros_like(own)
    else:
        kth = -np.partition(-asks, views_needed - 1, axis=1)[:, views_needed - 1]
    return np.minimum(own, kth)  # NaN stays NaN


def footprint_resolution(views: Views, box: np.ndarray, extent: np.ndarray | None,
                         quantile: float = 0.75, multiple: int = 64, max_cells: int = 1024,
                         axis_share: float = 0.25, every: int = 4, views_needed: int = VIEWS_NEEDED
                         ) -> tuple[int, int, int]:
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
        views_needed: cameras that must resolve a surface point for a pixel to ask its cells
            (``covered_asks``; 1: every pixel asks its own, the rule without coverage).

    Returns:
        Cells per axis, each a multiple of ``multiple`` in ``[multiple, max_cells]``.
    """
    if extent is None:
        raise InputError("the footprint rule needs the scene's extent (metadata.json "
                         "world.extent, written by reference_models.scenes); render the scene "
                         "again or use a preset without footprint planes")
    if not 0.0 < quantile <= 1.0:
        raise InputError(f"quantile must be in (0, 1], got {quantile}")
    if views_needed < 1:
        raise InputError(f"views_needed must be at least 1, got {views_needed}")
    samples = pixel_samples(views, box, extent, every)
    if len(samples.steps) == 0:
        raise InputError("no training pixel sees the scene's extent (cameras outside it?)")
    asks = covered_asks(views, samples, box, views_needed, axis_share)
    cells = []
    for axis in range(3):
        a = asks[:, axis][~np.isnan(asks[:, axis])]
        need = float(np.quantile(a, quantile)) if len(a) else float(multiple)
        cells.append(int(min(max(np.ceil(need / multiple) * multiple, multiple), max_cells)))
    return cells[0], cells[1], cells[2]

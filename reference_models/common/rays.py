"""Rays of pinhole cameras and the map from world points to the models' grid coordinates.

Conventions: camera-to-world in the nerfstudio / OpenGL convention (the camera looks down -Z, +Y
up), pixel ``(col, row)`` has its centre at ``(col + 0.5, row + 0.5)``; world in metres.

Unbounded scenes: points are first normalised so the inner scene box becomes ``[-1, 1]^3`` (per
axis), then contracted (mip-NeRF 360, with the L-infinity norm as in nerfstudio's grids)::

    contract(p) = p                          if |p|_inf <= 1
                  (2 - 1 / |p|_inf) p / |p|_inf   otherwise          (in [-2, 2]^3)

and halved, so the whole world maps into ``[-1, 1]^3``: half of every grid axis covers the box,
the other half everything out to infinity (the pitch to the horizon, the stands).
"""

from __future__ import annotations

import torch


def pixel_rays(c2w: torch.Tensor, intrinsics: torch.Tensor, rows: torch.Tensor,
               cols: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Rays through pixel centres.

    Args:
        c2w: (N, 4, 4) float32 (or float64) camera-to-world of each ray's view.
        intrinsics: (N, 4) ``fx, fy, cx, cy`` in pixels, of ``c2w``'s dtype.
        rows, cols: (N,) int64 pixel indices.

    Returns:
        ``origins`` (N, 3) and unit ``directions`` (N, 3) of ``c2w``'s dtype, world metres.
    """
    fx, fy, cx, cy = intrinsics.unbind(-1)
    u = cols.to(c2w.dtype) + 0.5
    v = rows.to(c2w.dtype) + 0.5
    d_cam = torch.stack([(u - cx) / fx, -(v - cy) / fy, -torch.ones_like(u)], dim=-1)
    d = torch.einsum("nij,nj->ni", c2w[:, :3, :3], d_cam)
    return c2w[:, :3, 3].clone(), d / d.norm(dim=-1, keepdim=True)


def contract(x: torch.Tensor, box: torch.Tensor) -> torch.Tensor:
    """World points (..., 3) metres -> grid coordinates (..., 3) in [-1, 1] (see module doc).

    ``box``: (2, 3) float32 inner box ``[min, max]``; its inside maps to ``[-0.5, 0.5]^3``.
    """
    centre, half = 0.5 * (box[0] + box[1]), 0.5 * (box[1] - box[0])
    p = (x - centre) / half
    n = p.abs().amax(dim=-1, keepdim=True).clamp_min(1e-9)
    out = torch.where(n <= 1.0, p, (2.0 - 1.0 / n) * p / n)
    return 0.5 * out


def spacing_to_distance(s: torch.Tensor, near: float, t_lin: float, far: float) -> torch.Tensor:
    """Map the spacing coordinate ``s`` in [0, 1] to ray distances (metres).

    Linear from ``near`` to ``t_lin`` for ``s`` in [0, 0.5], then linear in disparity (``1 / t``)
    from ``t_lin`` to ``far`` (nerfacto's piecewise sampler): as many samples inside the box as
    beyond it, out to the horizon.
    """
    lin = near + (t_lin - near) * (s / 0.5)
    disp = 1.0 / (1.0 / t_lin + (1.0 / far - 1.0 / t_lin) * ((s - 0.5) / 0.5))
    return torch.where(s < 0.5, lin, disp)

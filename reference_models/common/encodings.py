"""Feature encodings shared by the models: K-Planes' multiscale planes and view-direction harmonics.

An *encoding* maps space-time grid coordinates ``(N, 4)`` float32 in ``[-1, 1]`` (x, y, z after
``rays.contract``, then ``t`` mapped from [0, 1]) to ``(N, out_dim)`` features, and reports its
own regularisers. Both the K-Planes field and the density-only proposal fields are built from
``PlaneEncoding``.
"""

from __future__ import annotations

import itertools

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from reference_models.common.plane_kernels import (
    plane_product,
    plane_tv,
    uses_fused_lookup,
    uses_fused_tv,
)


class _SquaredDifferenceMean(torch.autograd.Function):
    """``mean(diff(p, dim)^2)`` with a hand-written backward: one pass for the gradient
    ``2 (d[i-1] - d[i]) / n`` instead of autograd's several (plane TV is a third of a small
    training step on the CPU otherwise)."""

    @staticmethod
    def forward(ctx, p, dim):  # noqa: ANN001
        d = p.diff(dim=dim)
        ctx.save_for_backward(d, p)
        ctx.dim = dim
        return d.square().mean()

    @staticmethod
    def backward(ctx, g):  # noqa: ANN001
        d, p = ctx.saved_tensors
        n = p.shape[ctx.dim]
        grad = torch.zeros_like(p)  # p's memory format (channels_last planes): no layout copies
        grad.narrow(ctx.dim, 1, n - 1).add_(d)
        grad.narrow(ctx.dim, 0, n - 1).sub_(d)
        return grad.mul_(2.0 * g / d.numel()), None


def squared_difference_mean(p: torch.Tensor, dim: int) -> torch.Tensor:
    """Mean of the squared first differences of ``p`` along ``dim`` (a scalar tensor)."""
    return _SquaredDifferenceMean.apply(p, dim)


def _per_axis(cells: int | tuple[int, ...]) -> list[int]:
    """Cells along x, y, z: one number for all three axes, or one per axis."""
    out = [int(cells)] * 3 if isinstance(cells, int | np.integer) else [int(c) for c in cells]
    if len(out) != 3 or min(out) < 2:
        raise ValueError(f"expected one resolution or three (x, y, z), each >= 2; got {cells!r}")
    return out


class TexelPlanes(nn.ParameterList):
    """``PlaneEncoding``'s plane parameters, stored (1, H, W, F) and read and written in
    checkpoints as (1, F, H, W) (``channels_last`` strides): the shapes every checkpoint had, so
    runs trained before the layout changed load, and theirs load in older code.

    The layout is for torch's fused Adam, which copies a ``channels_last`` tensor into a
    contiguous one and back on every step (37 ms against 5 ms for a 768 x 768 x 16 plane on one
    core): 255 -> 238 ms CPU a 2,048-ray close-up study step (issue 40)."""

    def _save_to_state_dict(self, destination, prefix, keep_vars):  # noqa: ANN001
        for name, p in self._parameters.items():
            if p is not None:
                view = p.permute(0, 3, 1, 2)
                destination[prefix + name] = view if keep_vars else view.detach()

    def _load_from_state_dict(self, state_dict, prefix, *args):  # noqa: ANN001, ANN002
        for name in self._parameters:
            key = prefix + name
            if key in state_dict and state_dict[key].dim() == 4:
                state_dict[key] = state_dict[key].permute(0, 2, 3, 1)
        super()._load_from_state_dict(state_dict, prefix, *args)


class PlaneEncoding(nn.Module):
    """K-Planes (Fridovich-Keil et al. 2023): the six coordinate planes of 4D space-time.

    Within a scale, the features of the planes ``xy, xz, yz, xt, yt, zt`` (bilinear lookups) are
    multiplied; across scales they are concatenated, so ``out_dim = features * len(scales)``.
    Space-only planes start uniform in [0.1, 0.5], planes with a time axis start at 1 (so a
    static scene needs no change in them). ``planes="space"`` keeps only the three space planes
    (a static field), ``planes="time"`` only the three with a time axis (a time factor).
    ``factor=True`` starts every plane at 1: a multiplicative factor on another field that
    changes nothing until trained. ``static_only`` (set by the training loop's static warm-up) skips the planes with a time
    axis: while they are still 1 this is the same field (up to the rounding of a bilinear
    look-up of ones) at half the look-ups. ``resolution`` and ``max_resolution`` are one number
    for every space axis or three (x, y, z): cells per axis of the coarsest scale and the cap.
    """

    def __init__(self, resolution: int | tuple[int, int, int], time_resolution: int,
                 scales: tuple[int, ...], features: int,
                 max_resolution: int | tuple[int, int, int] = 256, planes: str = "space-time",
                 factor: bool = False) -> None:
        super().__init__()
        all_pairs = list(itertools.combinations(range(4), 2))
        choice = {"space-time": all_pairs, "space": [p for p in all_pairs if 3 not in p],
                  "time": [p for p in all_pairs if 3 in p]}
        if planes not in choice:
            raise ValueError(f"planes must be one of {', '.join(choice)}, got {planes!r}")
        self.pairs = choice[planes]
        self.features, self.scales = features, tuple(scales)
        self.static_only = False
        """Skip the planes with a time axis (the same field while they are all 1: static warm-up)."""
        self.out_dim = features * len(self.scales)
        self.planes = TexelPlanes()
        """The planes' parameters, each (1, H, W, F) float32: a texel's features contiguous (the
        CPU look-up reads them so, ``plane_kernels``) in a layout the fused Adam updates without
        copies; ``plane(k)`` is the (1, F, H, W) view every computation reads."""
        self.plane_pairs: list[tuple[int, int]] = []
        """Axes ``(a, b)`` of each plane in ``planes`` (columns along ``a``, rows along ``b``)."""
        base, cap = _per_axis(resolution), _per_axis(max_resolution)
        for s in self.scales:
            res = [min(r * s, c) for r, c in zip(base, cap, strict=True)] + [time_resolution]
            for a, b in self.pairs:
                self.plane_pairs.append((a, b))
                size = [res[b], res[a]]
                if 3 in (a, b) or factor:
                    plane = torch.ones(1, features, *size)
                else:
                    plane = torch.empty(1, features, *size).uniform_(0.1, 0.5)
                self.planes.append(nn.Parameter(plane.permute(0, 2, 3, 1).contiguous()))

    def plane(self, k: int) -> torch.Tensor:
        """Plane ``k`` as (1, F, H, W) (rows along its second axis, columns along its first): a
        view of its parameter in ``channels_last`` memory format, differentiable."""
        return self.planes[k].permute(0, 3, 1, 2)

    def views(self) -> list[torch.Tensor]:
        """Every plane as ``plane(k)`` gives it, in ``plane_pairs`` order."""
        return [self.plane(k) for k in range(len(self.planes))]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(N, 4) coordinates in [-1, 1] -> (N, out_dim) features. On the CPU (coordinates
        without a gradient) each scale is one compiled look-up of all its planes
        (``plane_kernels.plane_product``); elsewhere ``grid_sample``, the same values."""
        out, n_pairs = [], len(self.pairs)
        for s in range(len(self.scales)):
            used = [(k, pair) for k, pair in enumerate(self.plane_pairs[s * n_pairs:(s + 1) * n_pairs],
                                                       start=s * n_pairs)
                    if not (self.static_only and pair[1] == 3)]
            planes = [self.plane(k) for k, _ in used]
            if not used:
                out.append(x.new_ones(x.shape[0], self.features))
            elif uses_fused_lookup(x, planes):
                out.append(plane_product(x, planes, [pair for _, pair in used]))
            else:
                out.append(grid_sample_product(x, planes, [pair for _, pair in used]))
        return torch.cat(out, dim=-1)

    def _time_planes(self) -> list[torch.Tensor]:
        return [p for p, (_, b) in zip(self.views(), self.plane_pairs, strict=True) if b == 3]

    def regularizers(self) -> dict[str, torch.Tensor]:
        """Unweighted K-Planes regularisers (scalars): ``tv`` (squared first differences along
        every space axis of every plane), ``time_smooth`` (squared second differences along time)
        and ``time_l1`` (``|1 - plane|`` of the planes with a time axis: stay static unless the
        images say otherwise)."""
        tv = torch.zeros((), device=self.planes[0].device)
        for p, (_, b) in zip(self.views(), self.plane_pairs, strict=True):
            if uses_fused_tv(p):  # rows run along axis b: time on a plane with a time axis
                tv = tv + plane_tv(p, rows=b != 3)
                continue
            if b != 3:
                tv = tv + squared_difference_mean(p, -2)
            tv = tv + squared_difference_mean(p, -1)
        times = self._time_planes()
        if not times:
            return {"tv": tv}
        smooth = sum((p[..., 2:, :] - 2 * p[..., 1:-1, :] + p[..., :-2, :]).square().mean()
                     for p in times if p.shape[-2] > 2)
        l1 = sum((1.0 - p).abs().mean() for p in times)
        return {"tv": tv, "time_smooth": torch.as_tensor(smooth, dtype=torch.float32, device=tv.device), "time_l1": l1}


def grid_sample_product(x: torch.Tensor, planes: list[torch.Tensor], pairs: list[tuple[int, int]]
                        ) -> torch.Tensor:
    """The product of ``F.grid_sample`` bilinear look-ups (``align_corners=True``: -1 and 1 are
    the first and last texels; border padding) of ``planes`` (each (1, F, H_p, W_p)) at (N, D)
    coordinates in [-1, 1], plane p read at column ``x[:, a]``, row ``x[:, b]`` for ``(a, b) =
    pairs[p]``: (N, F), on any device, differentiable in the planes and the coordinates. The
    reference of ``plane_kernels.plane_product``."""
    prod = None
    for plane, (a, b) in zip(planes, pairs, strict=True):
        grid = x[:, [a, b]].view(1, 1, -1, 2)  # grid_sample: (x, y) = (width, height) axes
        f = F.grid_sample(plane, grid, mode="bilinear", padding_mode="border",
                          align_corners=True)[0, :, 0].t()
        prod = f if prod is None else prod * f
    return prod


def spherical_harmonics(d: torch.Tensor) -> torch.Tensor:
    """Real spherical harmonics of degree 0..3 of unit directions (N, 3) -> (N, 16) float32."""
    x, y, z = d.unbind(-1)
    xx, yy, zz = x * x, y * y, z * z
    return torch.stack([
        torch.full_like(x, 0.28209479177387814),
        -0.48860251190291987 * y, 0.48860251190291987 * z, -0.48860251190291987 * x,
        1.0925484305920792 * x * y, -1.0925484305920792 * y * z,
        0.94617469575755997 * zz - 0.31539156525251999, -1.0925484305920792 * x * z,
        0.54627421529603959 * (xx - yy),
        0.59004358992664352 * y * (-3 * xx + yy), 2.8906114426405538 * x * y * z,
        0.45704579946446572 * y * (1 - 5 * zz), 0.3731763325901154 * z * (5 * zz - 3),
        0.45704579946446572 * x * (1 - 5 * zz), 1.4453057213202769 * z * (xx - yy),
        0.59004358992664352 * x * (-xx + 3 * yy),
    ], dim=-1)

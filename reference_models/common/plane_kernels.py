"""The CPU look-up of K-Planes' planes: one scale's bilinear look-ups and their product, fused.

``F.grid_sample`` (``align_corners=True``, ``padding_mode="border"``) is the reference and the
path for every other device: on the CPU its backward scatters each point's gradient across the
channels of a (1, F, H, W) plane, one strided write per channel, and the product of a scale's
planes then costs autograd a multiply and its backward per plane. Here the planes are read
*channel-last* (features contiguous per texel: a parameter of shape (1, F, H, W) kept in
``torch.channels_last`` memory format is an (H, W, F) array), so each of the 4 corners of a
look-up is one contiguous row of F features, and one compiled loop gathers every plane of a
scale and multiplies them; the backward scatters ``w * grad * (product of the other planes)``
into each plane's gradient, again one row per corner. The coordinates get no gradient (the
models' sample points depend on no parameter): ``plane_product`` raises for coordinates that
require one.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from dynaeval.core.runtime import compiled


@compiled
def _texel(u, size):  # noqa: ANN001, ANN202
    """grid_sample's source index with ``align_corners=True`` and border padding: ``u`` in
    [-1, 1] -> texel coordinate clipped to [0, size - 1] (NaN -> 0), as the lower corner, the
    upper corner (the same texel at the last one) and the float32 weight of the upper one."""
    last = np.float32(size - 1)
    c = (u + np.float32(1.0)) * np.float32(0.5) * last  # float32, in grid_sample's order
    if not c >= 0.0:  # also NaN
        c = np.float32(0.0)
    if c > last:
        c = last
    i0 = int(math.floor(c))
    i1 = min(i0 + 1, size - 1)
    return i0, i1, c - np.float32(i0)


@compiled
def _bilinear(u, v, h, w):  # noqa: ANN001, ANN202
    """The 4 corners and float32 weights of grid_sample's bilinear look-up at column ``u``, row
    ``v`` (in [-1, 1]) of an (h, w) plane: ``y0, x0, y1, x1, w00, w01, w10, w11`` for the
    texels (y0, x0), (y0, x1), (y1, x0), (y1, x1)."""
    x0, x1, wx = _texel(u, w)
    y0, y1, wy = _texel(v, h)
    one = np.float32(1.0)
    return (y0, x0, y1, x1, (one - wy) * (one - wx), (one - wy) * wx, wy * (one - wx), wy * wx)


@compiled
def _product_forward(x, planes, axes, out, feats):  # noqa: ANN001, ANN202
    """``out[n] = prod_p bilinear(planes[p], x[n, axes[p, 0]], x[n, axes[p, 1]])`` and every
    factor in ``feats[p, n]``. x (N, 4) float32; planes: tuple of (H_p, W_p, F) float32 (columns
    along axis ``axes[p, 0]``, rows along ``axes[p, 1]``); out (N, F), feats (P, N, F) float32.
    Each loop over the features touches one row per array (no two rows of one array), so it
    compiles to vector instructions."""
    n_pts, n_feat = out.shape
    out[:, :] = 1.0
    for p in range(len(planes)):
        pl = planes[p]
        h, w = pl.shape[0], pl.shape[1]
        a, b = axes[p, 0], axes[p, 1]
        fp = feats[p]
        for n in range(n_pts):
            y0, x0, y1, x1, w00, w01, w10, w11 = _bilinear(x[n, a], x[n, b], h, w)
            r00, r01, r10, r11 = pl[y0, x0], pl[y0, x1], pl[y1, x0], pl[y1, x1]
            v = fp[n]
            for f in range(n_feat):
                v[f] = w00 * r00[f] + w01 * r01[f] + w10 * r10[f] + w11 * r11[f]
            o = out[n]
            for f in range(n_feat):
                o[f] *= v[f]


@compiled
def _product_backward(x, axes, feats, grad, scaled, grads):  # noqa: ANN001, ANN202
    """Adds each plane's gradient into ``grads`` (a tuple of (H_p, W_p, F) float32, zeros on
    entry) from ``grad`` (N, F), the gradient of ``_product_forward``'s ``out``: the corners of
    plane p get ``w * grad * prod_{q != p} feats[q]``, that product first written to ``scaled``
    (P, N, F) float32 (prefix and suffix products, no division), then scattered plane by plane,
    one corner row at a time."""
    n_planes = len(grads)
    n_pts, n_feat = grad.shape
    suffix = np.empty((n_planes, n_feat), np.float32)
    prefix = np.empty(n_feat, np.float32)
    for n in range(n_pts):
        suffix[n_planes - 1, :] = 1.0
        for p in range(n_planes - 2, -1, -1):
            for f in range(n_feat):
                suffix[p, f] = suffix[p + 1, f] * feats[p + 1, n, f]
        for f in range(n_feat):
            prefix[f] = grad[n, f]
        for p in range(n_planes):
            for f in range(n_feat):
                scaled[p, n, f] = prefix[f] * suffix[p, f]
                prefix[f] *= feats[p, n, f]
    for p in range(n_planes):
        gp = grads[p]
        h, w = gp.shape[0], gp.shape[1]
        a, b = axes[p, 0], axes[p, 1]
        sp = scaled[p]
        for n in range(n_pts):
            y0, x0, y1, x1, w00, w01, w10, w11 = _bilinear(x[n, a], x[n, b], h, w)
            g = sp[n]
            r = gp[y0, x0]
            for f in range(n_feat):
                r[f] += w00 * g[f]
            r = gp[y0, x1]
            for f in range(n_feat):
                r[f] += w01 * g[f]
            r = gp[y1, x0]
            for f in range(n_feat):
                r[f] += w10 * g[f]
            r = gp[y1, x1]
            for f in range(n_feat):
                r[f] += w11 * g[f]


def _texel_rows(plane: torch.Tensor) -> torch.Tensor:
    """A (1, F, H, W) plane as the (H, W, F) channel-last array the loops read (a view of a
    ``channels_last`` plane; a copy of any other)."""
    return plane.detach()[0].permute(1, 2, 0).contiguous()


class _PlaneProduct(torch.autograd.Function):
    @staticmethod
    def forward(ctx, x, axes, *planes):  # noqa: ANN001
        rows = tuple(_texel_rows(p).numpy() for p in planes)
        out = torch.empty(x.shape[0], planes[0].shape[1])
        feats = torch.empty(len(planes), *out.shape)
        _product_forward(x.numpy(), rows, axes, out.numpy(), feats.numpy())
        ctx.save_for_backward(x, feats)
        ctx.axes, ctx.shapes = axes, [p.shape for p in planes]
        return out

    @staticmethod
    def backward(ctx, grad):  # noqa: ANN001
        x, feats = ctx.saved_tensors
        # the planes' own layout (channels_last), so autograd takes these as the gradients
        # instead of copying them into it
        grads = [torch.empty(shape, memory_format=torch.channels_last).zero_() for shape in ctx.shapes]
        _product_backward(x.numpy(), ctx.axes, feats.numpy(), grad.contiguous().numpy(),
                          np.empty(feats.shape, np.float32), tuple(_texel_rows(g).numpy() for g in grads))
        return (None, None, *grads)


def uses_fused_lookup(x: torch.Tensor, planes: list[torch.Tensor]) -> bool:
    """Whether ``plane_product`` runs the compiled loops: float32 CPU tensors, coordinates that
    need no gradient (otherwise the caller uses ``grid_sample``, e.g. on CUDA)."""
    return (x.device.type == "cpu" and x.dtype == torch.float32 and not x.requires_grad
            and all(p.device.type == "cpu" and p.dtype == torch.float32 for p in planes))


def plane_product(x: torch.Tensor, planes: list[torch.Tensor], pairs: list[tuple[int, int]]
                  ) -> torch.Tensor:
    """The product of bilinear look-ups of ``planes`` (each (1, F, H_p, W_p) float32, best in
    ``channels_last`` memory format) at (N, D) float32 CPU coordinates in [-1, 1] (no gradient):
    plane p is read at column ``x[:, a]`` (width axis), row ``x[:, b]`` (height axis) for
    ``(a, b) = pairs[p]``, exactly as ``F.grid_sample(plane, ..., align_corners=True,
    padding_mode="border")`` reads it. Returns (N, F) float32, differentiable in the planes.
    Raises ValueError for coordinates that require a gradient or tensors off the CPU."""
    if not uses_fused_lookup(x, planes):
        raise ValueError("plane_product takes float32 CPU tensors and coordinates without a "
                         "gradient; use grid_sample otherwise")
    axes = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    return _PlaneProduct.apply(x.contiguous(), axes, *planes)


@compiled
def _tv_sums(a, rows):  # noqa: ANN001, ANN202
    """Sums of the squared first differences of an (H, W, F) float32 array: along its rows
    (axis 0; 0.0 unless ``rows``) and along its columns (axis 1), float32 differences and
    squares (as torch forms them) summed in float64, one running sum per feature (independent
    sums: the loop over the features vectorises without reordering any sum)."""
    h, w, f = a.shape
    cols, rows_sum = np.zeros(f), np.zeros(f)
    for i in range(h):
        for j in range(w - 1):
            for k in range(f):
                d = a[i, j + 1, k] - a[i, j, k]
                cols[k] += d * d
    if rows:
        for i in range(h - 1):
            for j in range(w):
                for k in range(f):
                    d = a[i + 1, j, k] - a[i, j, k]
                    rows_sum[k] += d * d
    return rows_sum.sum(), cols.sum()


@compiled
def _tv_grad(a, c_rows, c_cols, out):  # noqa: ANN001, ANN202
    """``out`` (H, W, F) = the gradient of ``c_rows / 2 * sum(diff(a, axis 0)^2) + c_cols / 2 *
    sum(diff(a, axis 1)^2)``: at each texel ``c (d_before - d_after)`` along each axis, where a
    difference beyond the edge is 0 (a clamped neighbour index gives it). Writes every element
    (``out`` needs no zeroing); no branch in the loop over the features, which vectorises."""
    h, w, f = a.shape
    cr, cc = np.float32(c_rows), np.float32(c_cols)
    for i in range(h):
        im, ip = max(i - 1, 0), min(i + 1, h - 1)
        for j in range(w):
            jm, jp = max(j - 1, 0), min(j + 1, w - 1)
            for k in range(f):
                v = a[i, j, k]
                out[i, j, k] = (cc * ((v - a[i, jm, k]) - (a[i, jp, k] - v))
                                + cr * ((v - a[im, j, k]) - (a[ip, j, k] - v)))


class _PlaneTV(torch.autograd.Function):
    @staticmethod
    def forward(ctx, plane, rows):  # noqa: ANN001
        a = _texel_rows(plane)
        _, f, h, w = plane.shape
        n_rows, n_cols = (h - 1) * w * f, h * (w - 1) * f
        s_rows, s_cols = _tv_sums(a.numpy(), rows)
        ctx.save_for_backward(a)
        ctx.scale = (2.0 / n_rows if rows else 0.0, 2.0 / n_cols)
        value = s_cols / n_cols + (s_rows / n_rows if rows else 0.0)
        return torch.tensor(value, dtype=torch.float32)

    @staticmethod
    def backward(ctx, g):  # noqa: ANN001
        (a,) = ctx.saved_tensors
        grad = torch.empty(a.shape[2], *a.shape[:2]).unsqueeze(0).contiguous(
            memory_format=torch.channels_last)  # the plane's own layout: no copy into it
        scale = float(g)
        _tv_grad(a.numpy(), scale * ctx.scale[0], scale * ctx.scale[1],
                 _texel_rows(grad).numpy())
        return grad, None


def uses_fused_tv(plane: torch.Tensor) -> bool:
    """Whether ``plane_tv`` runs the compiled loops (a float32 CPU plane)."""
    return plane.device.type == "cpu" and plane.dtype == torch.float32


def plane_tv(plane: torch.Tensor, rows: bool) -> torch.Tensor:
    """K-Planes' total variation of one (1, F, H, W) float32 CPU plane (best ``channels_last``,
    as ``PlaneEncoding`` reads its planes): the mean of the squared first differences along its
    columns (the last axis), plus, with ``rows``, the mean of those along its rows. A float32
    scalar, differentiable in the plane: one compiled pass for the value, one for the gradient
    (the reference, ``encodings.squared_difference_mean``, takes six). Raises ValueError off
    the CPU or for another dtype."""
    if not uses_fused_tv(plane):
        raise ValueError("plane_tv takes a float32 CPU plane; use squared_difference_mean "
                         "otherwise")
    return _PlaneTV.apply(plane, bool(rows))

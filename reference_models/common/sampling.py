"""Samples along rays, volume rendering weights, and the proposal-sampling losses.

Samples are *bins*: ``edges`` (R, S + 1) in the spacing coordinate ``s`` in [0, 1] (see
``rays.spacing_to_distance``), sorted along each ray; a field is queried at the bin midpoints.
"""

from __future__ import annotations

import torch


def stratified_edges(n_rays: int, n_bins: int, jitter: bool, generator: torch.Generator | None = None,
                     device: torch.device | str = "cpu") -> torch.Tensor:
    """(R, n_bins + 1) float32 edges in [0, 1] on ``device``: uniform, shifted by one random
    offset per ray when ``jitter`` (training), so every distance gets sampled over time. The
    offsets are drawn by ``generator`` (default: torch's CPU one) and moved: the same numbers on
    every device."""
    base = torch.linspace(0.0, 1.0, n_bins + 1, device=device).expand(n_rays, n_bins + 1)
    if not jitter:
        return base.contiguous()
    off = (torch.rand(n_rays, 1, generator=generator).to(device) - 0.5) / n_bins
    return (base + off).clamp(0.0, 1.0)


def render_weights(density: torch.Tensor, deltas: torch.Tensor) -> torch.Tensor:
    """Volume rendering weights (R, S) from ``density`` (R, S) in 1/m and bin lengths ``deltas``
    (R, S) in metres: ``w_i = alpha_i prod_{j<i} (1 - alpha_j)``, ``alpha = 1 - exp(-density delta)``.
    ``1 - w.sum(-1)`` is the light that passes every bin (it shows the background)."""
    tau = density * deltas
    alpha = 1.0 - torch.exp(-tau)
    trans = torch.exp(-torch.cumsum(torch.cat([torch.zeros_like(tau[:, :1]), tau[:, :-1]], -1), -1))
    return alpha * trans


def resample_edges(edges: torch.Tensor, weights: torch.Tensor, n_bins: int, jitter: bool,
                   pad: float = 0.01, generator: torch.Generator | None = None) -> torch.Tensor:
    """Inverse-CDF sampling of ``n_bins + 1`` new edges from a piecewise-constant density.

    Args:
        edges: (R, S + 1) sorted edges in [0, 1].
        weights: (R, S) non-negative weights of the bins (detached by the caller).
        n_bins: bins in the output.
        jitter: one random offset per ray (training) instead of evenly spaced quantiles
            (drawn like ``stratified_edges``'), moved to ``edges``' device.
        pad: added to every normalised weight, so empty space still gets a few samples.

    Returns:
        (R, n_bins + 1) sorted edges in [0, 1].
    """
    w = weights + 1e-6
    w = w / w.sum(-1, keepdim=True) + pad
    w = w / w.sum(-1, keepdim=True)
    cdf = torch.cat([torch.zeros_like(w[:, :1]), torch.cumsum(w, -1).clamp(max=1.0)], -1)
    cdf[:, -1] = 1.0
    r = edges.shape[0]
    u = torch.linspace(0.0, 1.0, n_bins + 1, device=edges.device).expand(r, n_bins + 1)
    if jitter:
        u = (u + (torch.rand(r, 1, generator=generator).to(edges.device) - 0.5) / n_bins).clamp(0.0, 1.0)
    u = u.contiguous()
    idx = torch.searchsorted(cdf, u, right=True).clamp(1, cdf.shape[1] - 1)
    c0, c1 = cdf.gather(1, idx - 1), cdf.gather(1, idx)
    e0, e1 = edges.gather(1, idx - 1), edges.gather(1, idx)
    frac = ((u - c0) / (c1 - c0).clamp_min(1e-9)).clamp(0.0, 1.0)
    return (e0 + frac * (e1 - e0)).sort(-1).values


def interlevel_loss(edges: torch.Tensor, weights: torch.Tensor, prop_edges: torch.Tensor,
                    prop_weights: torch.Tensor) -> torch.Tensor:
    """mip-NeRF 360's proposal loss, a scalar: the proposal's weights must bound the final ones.

    For each final bin, the *outer* measure is the proposal weight of all proposal bins that
    overlap it; the loss is ``mean(max(0, w - outer)^2 / (w + eps))``. ``weights`` (R, S) of bins
    ``edges`` (R, S + 1) are detached here (only the proposal learns from this loss).
    """
    w = weights.detach()
    outer = outer_mass(edges, prop_edges, prop_weights)
    return (torch.clamp(w - outer, min=0.0) ** 2 / (w + 1e-7)).sum(-1).mean()


def outer_mass(edges: torch.Tensor, prop_edges: torch.Tensor, prop_weights: torch.Tensor
               ) -> torch.Tensor:
    """(R, S): for each bin of ``edges`` (R, S + 1), the summed ``prop_weights`` (R, P) of every
    bin of ``prop_edges`` (R, P + 1) that overlaps it (mip-NeRF 360's outer measure; an upper
    bound of the weight the proposal puts on that bin)."""
    cum = torch.cat([torch.zeros_like(prop_weights[:, :1]), torch.cumsum(prop_weights, -1)], -1)
    lo = torch.searchsorted(prop_edges.contiguous(), edges[:, :-1].contiguous(), right=True) - 1
    hi = torch.searchsorted(prop_edges.contiguous(), edges[:, 1:].contiguous(), right=False)
    last = prop_edges.shape[1] - 1
    return cum.gather(1, hi.clamp(0, last)) - cum.gather(1, lo.clamp(0, last))


def distortion_loss(edges: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    """mip-NeRF 360's distortion loss (a scalar) in the spacing coordinate: weights should
    gather in few short bins. ``sum_ij w_i w_j |m_i - m_j| + 1/3 sum_i w_i^2 (e_{i+1} - e_i)``,
    computed in O(S) with cumulative sums."""
    mid = 0.5 * (edges[:, 1:] + edges[:, :-1])
    width = edges[:, 1:] - edges[:, :-1]
    wm = weights * mid
    w_cum = torch.cumsum(weights, -1)
    wm_cum = torch.cumsum(wm, -1)
    cross = 2.0 * (wm[:, 1:] * w_cum[:, :-1] - weights[:, 1:] * wm_cum[:, :-1]).sum(-1)
    self_term = (weights ** 2 * width).sum(-1) / 3.0
    return (cross + self_term).mean()

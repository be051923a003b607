"""One dynamic radiance model around any space-time encoding: proposal sampling, a small
nerfacto-style decoder to density and view-dependent colour, a sky term, volume rendering.

K-Planes and NeRFPlayer differ only in the encoding (``PlaneEncoding`` vs a temporal hash grid);
everything else here — samples, proposals, decoder, background, losses — is shared, so a
comparison between them compares the encodings.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import nn

from reference_models.common.encodings import PlaneEncoding, spherical_harmonics
from reference_models.common.rays import contract, spacing_to_distance
from reference_models.common.sampling import (
    distortion_loss,
    interlevel_loss,
    outer_mass,
    render_weights,
    resample_edges,
    stratified_edges,
)


class _TruncExp(torch.autograd.Function):
    """``exp`` whose gradient is clamped at ``exp(15)`` (instant-NGP's density activation)."""

    @staticmethod
    def forward(ctx, x):  # noqa: ANN001
        ctx.save_for_backward(x)
        return torch.exp(x)

    @staticmethod
    def backward(ctx, g):  # noqa: ANN001
        (x,) = ctx.saved_tensors
        return g * torch.exp(x.clamp(max=15.0))


def trunc_exp(x: torch.Tensor) -> torch.Tensor:
    """Density activation: ``exp(x)`` with a bounded gradient."""
    return _TruncExp.apply(x)


def cpu_has_bfloat16() -> bool:
    """Whether this CPU multiplies bfloat16 matrices natively (oneDNN's check: AVX-512 BF16 or
    AMX); emulated bfloat16 would be slower than float32."""
    return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())


def cpu_bfloat16(enabled: bool) -> torch.autocast:
    """CPU autocast to bfloat16 (linear layers and matrix products in bfloat16, their inputs cast,
    float32 accumulation inside oneDNN), on only when ``enabled`` and ``cpu_has_bfloat16()``.
    The callers cast the results back to float32 (``.float()``) so nothing else changes."""
    return torch.autocast("cpu", dtype=torch.bfloat16, enabled=enabled and cpu_has_bfloat16())


@dataclass
class RenderConfig:
    """Ray sampling and the shared decoder (sizes for 2 CPU cores)."""

    proposal_samples: tuple[int, ...] = (64,)
    """Samples per ray of each proposal level (K-Planes DyNeRF: 256, 128)."""
    final_samples: int = 32
    """Samples per ray of the radiance field (K-Planes DyNeRF: 48)."""
    proposal_resolution: tuple[int, ...] = (64,)
    """Space resolution of each proposal's planes (K-Planes: 128, 256)."""
    proposal_features: int = 8
    """Features per proposal plane (K-Planes: 8)."""
    hidden: int = 64
    """Width of the decoder MLPs."""
    geo_features: int = 15
    """Features passed from the density MLP to the colour MLP."""
    near: float = 0.1
    """Nearest ray distance (m)."""
    far: float = 1000.0
    """Farthest ray distance (m); light reaching it shows the sky term."""
    prune_weight: float = 0.0
    """Skip the radiance field at final samples whose bin the last proposal gives at most this
    weight (``sampling.outer_mass``): they render with density 0 (no light stopped, no colour),
    in training and rendering alike; 0: every sample is looked up."""


def _mlp(n_in: int, hidden: int, n_out: int, layers: int) -> nn.Sequential:
    """Linear layers with ReLU between them; each ReLU writes over its Linear's output (nothing
    else reads it; autograd's ReLU backward needs only the result): equal values and gradients,
    one activation-sized buffer fewer per layer (render 1.01-1.07x: ``benchmarks/render_relu.py``)."""
    mods: list[nn.Module] = []
    for i in range(layers):
        mods += [nn.Linear(n_in if i == 0 else hidden, hidden), nn.ReLU(inplace=True)]
    mods.append(nn.Linear(hidden if layers else n_in, n_out))
    return nn.Sequential(*mods)


@dataclass
class RayBatch:
    """Rays to render."""

    origins: torch.Tensor
    """(R, 3) float32 world metres."""
    directions: torch.Tensor
    """(R, 3) float32 unit vectors."""
    times: torch.Tensor
    """(R,) float32 in [0, 1]."""


@dataclass
class RenderOutput:
    """What ``DynamicRadianceModel.render`` returns."""

    rgb: torch.Tensor
    """(R, 3) float32 colour in [0, 1] (sRGB-encoded, like the images)."""
    depth: torch.Tensor
    """(R,) float32 expected ray distance (m) of the volume part."""
    losses: dict[str, torch.Tensor] = field(default_factory=dict)
    """Unweighted per-batch losses besides the photometric one (training only)."""


def sample_mask(edges: torch.Tensor, prop_edges: torch.Tensor, prop_weights: torch.Tensor,
                threshold: float) -> torch.Tensor:
    """(R, S) bool: the final bins ``edges`` (R, S + 1) whose proposal weight (``outer_mass`` of
    the proposal's bins ``prop_edges`` and detached ``prop_weights``) exceeds ``threshold``: the
    samples ``RenderConfig.prune_weight`` looks up."""
    return outer_mass(edges, prop_edges, prop_weights.detach()) > threshold


class DynamicRadianceModel(nn.Module):
    """Proposal sampling + ``encoding`` + decoder + sky, rendered by alpha compositing.

    ``encoding``: a module mapping ``(N, 4)`` space-time grid coordinates in [-1, 1] to
    ``(N, encoding.out_dim)`` features, with ``regularizers() -> dict`` of unweighted scalars.
    ``box``: (2, 3) inner scene box (metres); ``n_frames``: time resolution of the proposals.
    """

    def __init__(self, encoding: nn.Module, box: torch.Tensor, n_frames: int,
                 config: RenderConfig | None = None) -> None:
        super().__init__()
        self.config = cfg = config or RenderConfig()
        if len(cfg.proposal_samples) != len(cfg.proposal_resolution):
            raise ValueError("one proposal resolution per proposal level is needed")
        self.register_buffer("box", torch.as_tensor(box, dtype=torch.float32))
        self.encoding = encoding
        self.proposals = nn.ModuleList(
            PlaneEncoding(r, n_frames, (1,), cfg.proposal_features) for r in cfg.proposal_resolution)
        self.proposal_heads = nn.ModuleList(
            nn.Linear(cfg.proposal_features, 1) for _ in cfg.proposal_resolution)
        self.density_net = _mlp(encoding.out_dim, cfg.hidden, 1 + cfg.geo_features, 1)
        self.color_net = _mlp(cfg.geo_features + 16, cfg.hidden, 3, 2)
        self.sky_net = _mlp(16, 32, 3, 1)
        half = 0.5 * (self.box[1] - self.box[0])
        self.t_lin = float(2.0 * half.max())
        self.unit = float(half.max())
        """Length (m) of one density unit: densities are per half box size, not per metre, so the
        initial density (about exp(-1)) is a light haze over the box, not a wall in front of the
        camera (an 18 m box at 0.37 / m is opaque after a few metres: nothing can be learnt)."""

    def _points(self, rays: RayBatch, edges: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Grid coordinates (R*S, 4) of the bin midpoints and bin lengths (R, S) in ``unit``s."""
        cfg = self.config
        dist = spacing_to_distance(edges, cfg.near, self.t_lin, cfg.far)
        mid = 0.5 * (dist[:, 1:] + dist[:, :-1])
        xyz = rays.origins[:, None, :] + rays.directions[:, None, :] * mid[..., None]
        t = (2.0 * rays.times - 1.0)[:, None, None].expand(-1, mid.shape[1], 1)
        coords = torch.cat([contract(xyz, self.box), t], dim=-1).reshape(-1, 4)
        return coords, (dist[:, 1:] - dist[:, :-1]) / self.unit

    def density_and_color(self, coords: torch.Tensor, dirs: torch.Tensor,
                          bfloat16_mlps: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """The radiance field at (N, 4) grid coordinates seen along (N, 3) unit directions:
        density (N,) per ``unit`` of length and colour (N, 3) in [0, 1], float32.
        ``bfloat16_mlps``: the decoder MLPs' layers run in bfloat16 (``cpu_bfloat16``; weights
        and every other operation stay float32)."""
        with cpu_bfloat16(bfloat16_mlps and coords.device.type == "cpu"):
            h = self.density_net(self.encoding(coords)).float()
            color = self.color_net(torch.cat([h[:, 1:], spherical_harmonics(dirs)], -1)).float()
        return trunc_exp(h[:, 0] - 1.0), torch.sigmoid(color)

    def render(self, rays: RayBatch, training: bool = False,
               generator: torch.Generator | None = None, proposal_rays: int | None = None,
               bfloat16_mlps: bool = False) -> RenderOutput:
        """Render ``rays``; with ``training`` the samples are jittered and the losses
        ``interlevel`` and ``distortion`` are returned in ``losses``. ``proposal_rays``: only the
        first that many rays train the proposals (their look-ups with autograd, the interlevel
        loss over them; None: all, 0: none and no ``interlevel``); the others' proposal
        look-ups run without autograd and still place their samples. ``bfloat16_mlps``: see
        ``density_and_color``."""
        cfg, r = self.config, rays.origins.shape[0]
        grad = training and torch.is_grad_enabled()
        n_grad = r if proposal_rays is None or not grad else min(max(int(proposal_rays), 0), r)
        edges = stratified_edges(r, cfg.proposal_samples[0], training, generator,
                                 rays.origins.device)
        history = []
        for level, (enc, head) in enumerate(zip(self.proposals, self.proposal_heads, strict=True)):
            coords, deltas = self._points(rays, edges)
            split = n_grad * (edges.shape[1] - 1)
            dens = []
            for part, with_grad in ((coords[:split], grad), (coords[split:], False)):
                if part.shape[0]:
                    with torch.set_grad_enabled(with_grad):
                        dens.append(trunc_exp(head(enc(part))[:, 0] - 1.0))
            dens = dens[0] if len(dens) == 1 else torch.cat(dens)
            w = render_weights(dens.view(r, -1), deltas)
            history.append((edges, w))
            n_next = (cfg.proposal_samples[level + 1] if level + 1 < len(cfg.proposal_samples)
                      else cfg.final_samples)
            edges = resample_edges(edges, w.detach(), n_next, training, generator=generator)
        coords, deltas = self._points(rays, edges)
        dirs = rays.directions[:, None, :].expand(-1, edges.shape[1] - 1, -1).reshape(-1, 3)
        if cfg.prune_weight > 0.0 and history:
            keep = sample_mask(edges, *history[-1], cfg.prune_weight).view(-1).nonzero()[:, 0]
            dens_k, color_k = self.density_and_color(coords.index_select(0, keep),
                                                     dirs.index_select(0, keep), bfloat16_mlps)
            density = dens_k.new_zeros(coords.shape[0]).index_copy(0, keep, dens_k)
            color = color_k.new_zeros(coords.shape[0], 3).index_copy(0, keep, color_k)
        else:
            density, color = self.density_and_color(coords, dirs, bfloat16_mlps)
        weights = render_weights(density.view(r, -1), deltas)
        sky = torch.sigmoid(self.sky_net(spherical_harmonics(rays.directions)))
        acc = weights.sum(-1, keepdim=True)
        rgb = (weights[..., None] * color.view(r, -1, 3)).sum(1) + (1.0 - acc) * sky
        dist = spacing_to_distance(edges, cfg.near, self.t_lin, cfg.far)
        depth = (weights * 0.5 * (dist[:, 1:] + dist[:, :-1])).sum(-1)
        losses = {}
        if training:
            if n_grad:
                losses["interlevel"] = sum(interlevel_loss(edges[:n_grad], weights[:n_grad],
                                                           e[:n_grad], w[:n_grad]) for e, w in history)
            losses["distortion"] = distortion_loss(edges, weights)
        return RenderOutput(rgb, depth, losses)

    def set_static_only(self, static: bool) -> None:
        """Look up only the static part of the field and the proposals (static warm-up; see
        ``PlaneEncoding.static_only``). Raises ValueError for an encoding without one."""
        if static and not hasattr(self.encoding, "static_only"):
            raise ValueError(f"{type(self.encoding).__name__} has no static part to warm up")
        for mod in [self.encoding, *self.proposals]:
            if hasattr(mod, "static_only"):
                mod.static_only = static

    def regularizers(self) -> dict[str, torch.Tensor]:
        """Unweighted regularisers of the field and the proposals, summed by name."""
        out: dict[str, torch.Tensor] = {}
        for mod in [self.encoding, *self.proposals]:
            for k, v in mod.regularizers().items():
                out[k] = out[k] + v if k in out else v
        return out

    @torch.no_grad()
    def render_image(self, c2w: torch.Tensor, intrinsics: torch.Tensor, time: float, height: int,
                     width: int, chunk: int = 1024, stride: int = 1) -> torch.Tensor:
        """Render one view: ``c2w`` (4, 4), ``intrinsics`` (4,) -> (H, W, 3) float32 in [0, 1];
        with ``stride`` only every stride-th row and column: (ceil(H / s), ceil(W / s), 3).
        Computed and returned on the model's device (``c2w`` and ``intrinsics`` are moved)."""
        from reference_models.common.rays import pixel_rays

        dev = self.box.device
        c2w, intrinsics = c2w.to(dev), intrinsics.to(dev)
        rows, cols = torch.meshgrid(torch.arange(0, height, stride, device=dev),
                                    torch.arange(0, width, stride, device=dev), indexing="ij")
        height, width = rows.shape
        rows, cols = rows.reshape(-1), cols.reshape(-1)
        out = []
        for i in range(0, rows.numel(), chunk):
            n = min(chunk, rows.numel() - i)
            o, d = pixel_rays(c2w.expand(n, 4, 4), intrinsics.expand(n, 4), rows[i:i + n], cols[i:i + n])
            out.append(self.render(RayBatch(o, d, torch.full((n,), float(time), device=dev))).rgb)
        return torch.cat(out).view(height, width, 3).clamp(0.0, 1.0)

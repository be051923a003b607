"""NeRFPlayer's streamable temporal hash grid (Song et al., TVCG 2023) in plain PyTorch.

A multiresolution hash encoding (instant-NGP) whose table rows are long along time: each row of a
level holds ``features + knots - 1`` channels. At time ``t`` in [0, 1] a window of ``features``
consecutive channels is read, starting at ``s = t * (knots - 1)``; between the two nearest window
positions ``k = floor(s)`` and ``k + 1`` the output is the linear blend::

    out_j(t) = (1 - a) row[k + j] + a row[k + j + 1],    a = s - k,   j < features

so features are piecewise linear in ``t`` with knots on the frames when ``knots = frames``.
Adjacent windows share ``features - 1`` channels (the "sliding window"). Only the
``features + 1`` channels a lookup needs are gathered. The temporal regulariser is the L1
difference between the two blended channels of every lookup (``window_l1``).

Without NeRFPlayer's static / deforming / new decomposition (the seed study dropped it for
multi-view setups), and without an appearance embedding.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from reference_models.common.seed import seed_preset
from reference_models.common.train import ModelSpec, standard_presets

_PRIMES = (1, 2654435761, 805459861)


@dataclass
class NeRFPlayerConfig:
    """Temporal hash grid sizes (published nerfacto-based: 16 levels x 2 features, table 2^19,
    temporal_dim 64 — ~400M parameters; these are the CPU-sized defaults)."""

    levels: int = 8
    """Resolution levels of the hash grid."""
    features: int = 2
    """Features per level read at one time (the window width)."""
    log2_table: int = 15
    """log2 of the rows per level (coarse levels that fit are indexed densely, not hashed)."""
    base_resolution: int = 16
    """Cells per axis of the coarsest level (over the contracted world)."""
    max_resolution: int = 256
    """Cells per axis of the finest level."""
    knots: int | None = None
    """Window positions along time; None: the number of frames (knots on frames)."""


class TemporalHashEncoding(nn.Module):
    """``(N, 4)`` grid coordinates in [-1, 1] -> ``(N, levels * features)`` (see module doc)."""

    def __init__(self, cfg: NeRFPlayerConfig, n_frames: int) -> None:
        super().__init__()
        self.cfg = cfg
        self.knots = max(int(cfg.knots or n_frames), 2)
        self.channels = cfg.features + self.knots - 1
        self.out_dim = cfg.levels * cfg.features
        growth = math.exp((math.log(cfg.max_resolution) - math.log(cfg.base_resolution))
                          / max(cfg.levels - 1, 1))
        res = [int(math.floor(cfg.base_resolution * growth ** level)) for level in range(cfg.levels)]
        rows = [min((r + 1) ** 3, 2 ** cfg.log2_table) for r in res]
        self.register_buffer("resolution", torch.tensor(res, dtype=torch.int64), persistent=False)
        self.register_buffer("rows", torch.tensor(rows, dtype=torch.int64), persistent=False)
        self.register_buffer("offsets", torch.tensor([0, *rows[:-1]]).cumsum(0), persistent=False)
        self.register_buffer("dense", torch.tensor([(r + 1) ** 3 <= 2 ** cfg.log2_table for r in res]),
                             persistent=False)
        self.table = nn.Parameter(torch.empty(sum(rows), self.channels).uniform_(-1e-4, 1e-4))
        n_dense = sum((r + 1) ** 3 <= 2 ** cfg.log2_table for r in res)  # coarse levels: a prefix
        self._level_groups = [g for g in (slice(0, n_dense), slice(n_dense, cfg.levels))
                              if g.stop > g.start]
        self._window_l1 = torch.zeros(())

    def _corner_rows(self, base: torch.Tensor, levels: slice) -> torch.Tensor:
        """(l, 3, N) integer cell corners of the levels ``levels`` -> (l, 8, N) rows of the flat
        table of each cell's 8 corners (corner ``4 cx + 2 cy + cz``).

        Built per axis and combined by broadcasting, with the points on the innermost axis so
        every elementwise pass is a contiguous, vectorised one; dense levels by place value,
        hashed ones by instant-NGP's XOR of primes."""
        c = torch.stack([base, base + 1], 2)  # (l, 3, 2, N): each axis' two corner coordinates
        cx, cy, cz = c[:, 0, :, None, None], c[:, 1, None, :, None], c[:, 2, None, None, :]
        if bool(self.dense[levels][0]):
            side = (self.resolution[levels] + 1)[:, None, None, None, None]
            idx = cx + side * cy + side * side * cz
        else:
            idx = (cx * _PRIMES[0]) ^ (cy * _PRIMES[1]) ^ (cz * _PRIMES[2])
            idx = idx % self.rows[levels][:, None, None, None, None]
        return idx.reshape(base.shape[0], 8, -1) + self.offsets[levels][:, None, None]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(N, 4) coordinates in [-1, 1] -> (N, levels * features) features.

        When every point has the same time and no gradient is recorded (rendering a view), the
        two time windows are blended once for the whole table and each lookup reads ``features``
        channels instead of ``features + 1``; the window regulariser (a training term) is then
        not computed. Gathers are ``index_select`` on flat indices (its backward is a plain
        ``index_add``, several times faster on the CPU than advanced indexing's)."""
        n, feats = x.shape[0], self.cfg.features
        p = ((x[:, :3].t() + 1.0) * 0.5).clamp(0.0, 1.0)  # (3, N)
        pos = p[None] * self.resolution[:, None, None].to(p.dtype)  # (L, 3, N)
        base = pos.floor().to(torch.int64).clamp(max=self.resolution[:, None, None] - 1)
        frac = pos - base.to(pos.dtype)
        wa = torch.stack([1.0 - frac, frac], 2)  # (L, 3, 2, N): each axis' two corner weights
        w = (wa[:, 0, :, None, None] * wa[:, 1, None, :, None]
             * wa[:, 2, None, None, :]).reshape(-1, 8, n, 1)
        s = ((x[:, 3] + 1.0) * 0.5).clamp(0.0, 1.0) * (self.knots - 1)
        k = s.floor().to(torch.int64).clamp(max=self.knots - 2)
        a = s - k.to(s.dtype)
        one_time = n > 0 and not torch.is_grad_enabled() and bool((s == s[0]).all())
        if one_time:
            k0 = int(k[0])
            table = torch.lerp(self.table[:, k0:k0 + feats], self.table[:, k0 + 1:k0 + 1 + feats],
                               float(a[0]))
        else:
            cols = k[:, None] + torch.arange(feats + 1, device=x.device)  # (N, F + 1)
            a = a[:, None]
        out, l1 = [], []
        for lv in self._level_groups:
            rows = self._corner_rows(base[lv], lv)  # (l, 8, N)
            if one_time:
                blended = table.index_select(0, rows.reshape(-1)).view(*rows.shape, feats)
            else:
                flat = (rows[..., None] * self.channels + cols).reshape(-1)
                vals = self.table.view(-1).index_select(0, flat).view(*rows.shape, feats + 1)
                lo, hi = vals[..., :feats], vals[..., 1:]
                l1.append((hi - lo).abs().sum())
                blended = (1.0 - a) * lo + a * hi
            out.append((w[lv] * blended).sum(1))  # (l, N, F)
        if l1:
            self._window_l1 = sum(l1) / (n * self.cfg.levels * 8 * feats)
        return torch.cat(out, 0).permute(1, 0, 2).reshape(n, -1)

    def regularizers(self) -> dict[str, torch.Tensor]:
        """``window_l1``: mean L1 between the two blended channels of the last forward's lookups."""
        return {"window_l1": self._window_l1}


def build_encoding(cfg: NeRFPlayerConfig, scene: dict) -> TemporalHashEncoding:
    """The temporal hash grid for a scene (``scene["n_frames"]`` sets the default knots)."""
    return TemporalHashEncoding(cfg, int(scene["n_frames"]))


PRESETS = standard_presets(
    tiny=NeRFPlayerConfig(levels=4, log2_table=12, base_resolution=8, max_resolution=64),
    small=NeRFPlayerConfig())
"""``tiny``: tests (seconds); ``small``: the documented runs (see ``standard_presets``)."""

SEED = NeRFPlayerConfig(levels=16, features=2, log2_table=20, base_resolution=16,
                        max_resolution=2048, knots=63)
"""The seed study's NeRFPlayer (for a GPU): nerfacto's hash grid (16 levels of 2 features from 16
to 2,048 cells), the table raised to 2^20 rows per level and "a temporal dimension of 64" (the
seed paper): 64 channels per row, i.e. ``features + knots - 1 = 64``, 63 window positions.
726M field parameters (2.9 GB of float32; ~11.6 GB with the gradients and Adam's two moments,
within a 24 GB RTX 3090)."""
PRESETS["seed"] = seed_preset(SEED)

SPEC = ModelSpec("nerfplayer", NeRFPlayerConfig, PRESETS, build_encoding)
"""What the shared CLI and training loop need to run NeRFPlayer."""

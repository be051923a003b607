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

from reference_models.common.train import ModelSpec, standard_presets

_PRIMES = (1, 2654435761, 805459861)
_CORNERS = torch.tensor([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=torch.int64)


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
        self._window_l1 = torch.zeros(())

    def _row_index(self, corner: torch.Tensor) -> torch.Tensor:
        """(N, L, 8, 3) integer corners -> (N, L, 8) rows of the flat table."""
        side = (self.resolution + 1)[:, None]
        dense = corner[..., 0] + side * (corner[..., 1] + side * corner[..., 2])
        hashed = corner[..., 0] * _PRIMES[0]
        hashed = hashed ^ (corner[..., 1] * _PRIMES[1]) ^ (corner[..., 2] * _PRIMES[2])
        idx = torch.where(self.dense[:, None], dense, hashed % self.rows[:, None])
        return idx + self.offsets[:, None]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(N, 4) coordinates in [-1, 1] -> (N, levels * features) features."""
        n, feats = x.shape[0], self.cfg.features
        p = ((x[:, :3] + 1.0) * 0.5).clamp(0.0, 1.0)
        pos = p[:, None, :] * self.resolution[None, :, None].to(p.dtype)  # (N, L, 3)
        base = pos.floor().to(torch.int64).clamp(max=self.resolution[None, :, None] - 1)
        frac = pos - base.to(pos.dtype)
        corner = base[:, :, None, :] + _CORNERS  # (N, L, 8, 3)
        w = torch.where(_CORNERS.bool(), frac[:, :, None, :], 1.0 - frac[:, :, None, :]).prod(-1)
        rows = self._row_index(corner)
        s = ((x[:, 3] + 1.0) * 0.5).clamp(0.0, 1.0) * (self.knots - 1)
        k = s.floor().to(torch.int64).clamp(max=self.knots - 2)
        a = (s - k.to(s.dtype))[:, None, None, None]
        cols = k[:, None, None, None] + torch.arange(feats + 1)  # (N, 1, 1, F + 1)
        flat = rows[..., None] * self.channels + cols
        vals = self.table.view(-1)[flat]  # (N, L, 8, F + 1)
        lo, hi = vals[..., :feats], vals[..., 1:]
        self._window_l1 = (hi - lo).abs().mean()
        blended = (1.0 - a) * lo + a * hi
        return (w[..., None] * blended).sum(2).reshape(n, -1)

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

SPEC = ModelSpec("nerfplayer", NeRFPlayerConfig, PRESETS, build_encoding)
"""What the shared CLI and training loop need to run NeRFPlayer."""

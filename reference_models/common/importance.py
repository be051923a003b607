"""Which training pixels each step sees: uniform, or DyNeRF's ray importance sampling.

``isg`` / ``ist`` weights come from ``dynaeval.regions.motion.importance_weights`` — the same
implementation that makes dynaeval's motion masks — computed per static training camera over its
frames. A fraction of every batch (``importance_fraction``, 20–30 % in the seed study) is drawn
with probability proportional to the weights, the rest uniformly, so the static stadium keeps
being learnt. ``ist`` follows the published schedule: ISG weights first, IST weights from
``ist_from`` of the run on (K-Planes' DyNeRF config switches at step 50k of 90k).

Weights are kept as one per-view CDF (V, H*W) float32 and searched with a vectorised binary
search, so a batch costs a few gathers however many pixels the dataset has.
"""

from __future__ import annotations

import numpy as np
import torch

from dynaeval.errors import InputError
from reference_models.common.data import Views

SAMPLING = ("uniform", "isg", "ist")


def view_weights(views: Views, kind: str) -> np.ndarray:
    """(V, H, W) float32 importance weights of every view, from its camera's video.

    Raises InputError when a camera has a single frame (a moving camera: no static video to
    find motion in).
    """
    out = np.zeros(views.images.shape[:3], dtype=np.float32)
    from dynaeval.regions.motion import importance_weights

    for cam, idx in views.camera_sequences().items():
        if len(idx) < 2:
            raise InputError(f"importance sampling ({kind}) needs static cameras that film "
                             f"several frames; camera {cam!r} has {len(idx)}. Use --sampling uniform")
        out[idx] = importance_weights(views.images[idx], kind)
    return out


def moving_box(views: Views, box: np.ndarray, cells: int = 48, agree: float = 0.9
               ) -> np.ndarray | None:
    """The world box ``(2, 3)`` float32 (metres) that holds everything the motion masks say moves.

    Each training camera's motion masks (``dynaeval.regions.motion.motion_mask``, ISG defaults)
    are OR-ed over its frames; a cell of a ``cells``^3 grid over the inner ``box`` moves when at
    least two cameras see it and ``agree`` of those see it on a moving pixel (a visual hull that
    forgives a few missed masks). The result is grown by one cell; None when no cell moves.
    """
    from dynaeval.regions.motion import motion_mask

    lo, hi = box[0].astype(np.float64), box[1].astype(np.float64)
    axes = [lo[i] + (np.arange(cells) + 0.5) * (hi[i] - lo[i]) / cells for i in range(3)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    seen = np.zeros(len(pts), np.int32)
    moving = np.zeros(len(pts), np.int32)
    for idx in views.camera_sequences().values():
        if len(idx) < 2:
            continue
        ever = motion_mask(views.images[idx]).any(axis=0)
        c2w, (fx, fy, cx, cy) = views.c2w[idx[0]].astype(np.float64), views.intrinsics[idx[0]]
        pc = (pts - c2w[:3, 3]) @ c2w[:3, :3]
        depth = -pc[:, 2]
        ok = depth > 1e-3
        u = np.floor(fx * pc[:, 0] / np.where(ok, depth, 1.0) + cx).astype(np.int64)
        v = np.floor(-fy * pc[:, 1] / np.where(ok, depth, 1.0) + cy).astype(np.int64)
        ok &= (u >= 0) & (u < views.width) & (v >= 0) & (v < views.height)
        seen += ok
        moving[ok] += ever[v[ok], u[ok]]
    hit = (seen >= 2) & (moving >= agree * seen)
    if not hit.any():
        return None
    cell = (hi - lo) / cells
    out = np.stack([pts[hit].min(0) - cell, pts[hit].max(0) + cell])
    return np.clip(out, lo, hi).astype(np.float32)


def _search(cdf: torch.Tensor, row: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
    """For each ``row`` (K,) of ``cdf`` (V, M) (non-decreasing, last entry 1), the first column
    whose value exceeds ``u`` (K,) in [0, 1): a binary search with one gather per halving."""
    m = cdf.shape[1]
    lo = torch.zeros_like(row)
    hi = torch.full_like(row, m - 1)
    flat = cdf.reshape(-1)
    while bool((lo < hi).any()):
        mid = (lo + hi) // 2
        go_right = flat[row * m + mid] <= u
        lo = torch.where(go_right, mid + 1, lo)
        hi = torch.where(go_right, hi, mid)
    return lo


class RaySampler:
    """Draws (view, row, col) batches from training views; state: its generator and the CDFs."""

    def __init__(self, views: Views, mode: str = "uniform", importance_fraction: float = 0.25,
                 ist_from: float = 5 / 9, seed: int = 0) -> None:
        if mode not in SAMPLING:
            raise InputError(f"sampling must be one of {', '.join(SAMPLING)}, got {mode!r}")
        if not 0.0 <= importance_fraction <= 1.0:
            raise InputError(f"importance_fraction must be in [0, 1], got {importance_fraction}")
        self.views, self.mode = views, mode
        self.fraction, self.ist_from = importance_fraction, ist_from
        self.generator = torch.Generator().manual_seed(seed)
        self._kind: str | None = None
        self._cdf = self._totals = None

    def kind_at(self, progress: float) -> str | None:
        """Weights in use at ``progress`` (step / total steps): None, ``"isg"`` or ``"ist"``."""
        if self.mode == "uniform":
            return None
        return "ist" if self.mode == "ist" and progress >= self.ist_from else "isg"

    def _prepare(self, kind: str) -> None:
        w = torch.from_numpy(view_weights(self.views, kind)).reshape(len(self.views), -1)
        w = w.to(torch.float64)
        totals = w.sum(-1)
        cdf = torch.cumsum(w, -1) / totals.clamp_min(1e-12)[:, None]
        cdf[:, -1] = 1.0
        self._cdf, self._totals, self._kind = cdf.to(torch.float32), totals, kind

    def sample(self, n: int, progress: float = 0.0, importance: bool = True
               ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``n`` pixels: view (n,), row (n,), col (n,) int64 tensors; ``importance=False`` draws
        them all uniformly whatever the mode (a static warm-up)."""
        v_count, h, w = len(self.views), self.views.height, self.views.width
        g = self.generator
        kind = self.kind_at(progress) if importance else None
        n_imp = 0 if kind is None else int(round(self.fraction * n))
        view = torch.randint(0, v_count, (n - n_imp,), generator=g)
        pix = torch.randint(0, h * w, (n - n_imp,), generator=g)
        if n_imp:
            if kind != self._kind:
                self._prepare(kind)
            if float(self._totals.sum()) > 0:
                iv = torch.multinomial(self._totals, n_imp, replacement=True, generator=g)
                u = torch.rand(n_imp, generator=g) * 0.999999
                ip = _search(self._cdf, iv, u)
            else:  # nothing moves: fall back to uniform
                iv = torch.randint(0, v_count, (n_imp,), generator=g)
                ip = torch.randint(0, h * w, (n_imp,), generator=g)
            view, pix = torch.cat([view, iv]), torch.cat([pix, ip])
        return view, pix // w, pix % w

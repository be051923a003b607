"""Training of ``CenterNetSmall`` on rendered views: targets, loss, the loop, checkpoints.

Each view is letterboxed exactly as the runtime does (``dynaeval.regions.yolo.letterbox`` to a
square of ``INPUT_SIZE`` px, times a random scale in ``scale_range``), then a ``crop`` x ``crop``
window is cut (centred near a random object with probability ``object_crop_p``), flipped and
colour-jittered. Ground-truth boxes that are mostly occluded (``visible < min_visible``), smaller
than ``min_side`` px at the model's input scale, or cut by the crop to less than half their area
are *ignored*: their box region contributes no loss for their class.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from dynaeval.regions.yolo import letterbox
from reference_models.detector.model import CLASS_NAMES, INPUT_SIZE, STRIDE

MIN_VISIBLE = 0.3
"""Ground-truth boxes less visible than this (generator's ``visible``) are ignored."""
MIN_SIDE = 2.0
"""Ground-truth boxes whose shorter side is below this many input px are ignored."""


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation and augmentation settings of one training run."""

    steps: int = 3500
    """Optimiser steps."""
    batch: int = 8
    """Crops per step."""
    crop: int = 256
    """Side of the square training crop in input px (a multiple of 32)."""
    lr: float = 2e-3
    """Peak AdamW learning rate (linear warm-up over 100 steps, then cosine to 2 % of it)."""
    weight_decay: float = 1e-4
    """AdamW weight decay."""
    scale_range: tuple[float, float] = (0.6, 1.3)
    """Random letterbox side factor around ``INPUT_SIZE`` (robustness to ``input_size``)."""
    object_crop_p: float = 0.8
    """Probability that a crop is centred near a random object (else anywhere)."""
    size_weight: float = 1.0
    """Weight of the L1 loss on ``log(w / 4), log(h / 4)``."""
    offset_weight: float = 1.0
    """Weight of the L1 loss on the sub-cell centre offset."""
    seed: int = 0
    """Seed of the weights' initialisation and of every augmentation draw."""
    threads: int = 1
    """``torch.set_num_threads`` during training (1: on a shared 2-core machine a second thread
    made steps several times slower, waiting on the other)."""


TINY_CONFIG = TrainConfig(steps=30, batch=4, crop=128, lr=3e-3)
"""Settings of the ``--size tiny`` run (seconds; for tests)."""


def _class_id(name: str) -> int:
    return CLASS_NAMES.index("ball" if name in ("ball", "sports ball") else name)


def prepare(sample: dict, side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Letterbox one sample to ``side`` x ``side`` as the runtime does.

    Returns ``(canvas (side, side, 3) float32 in [0, 1], boxes (N, 4) float64 xyxy in canvas px,
    class ids (N,) int64, ignore (N,) bool)``.
    """
    img = sample["image"].astype(np.float32) / 255.0
    canvas, (sx, sy), (ox, oy) = letterbox(img, (side, side))
    recs = sample["boxes"]
    boxes = np.array([r["box"] for r in recs], dtype=np.float64).reshape(-1, 4)
    boxes[:, [0, 2]] = boxes[:, [0, 2]] * sx + ox
    boxes[:, [1, 3]] = boxes[:, [1, 3]] * sy + oy
    cls = np.array([_class_id(r["class"]) for r in recs], dtype=np.int64)
    vis = np.array([r.get("visible", 1.0) for r in recs], dtype=np.float64)
    short = np.minimum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    ignore = (vis < MIN_VISIBLE) | (short < MIN_SIDE)
    return canvas, boxes, cls, ignore


def augment(sample: dict, cfg: TrainConfig, rng: np.random.Generator):
    """One training crop: ``(image (3, crop, crop) float32, boxes (N, 4), cls (N,), ignore (N,))``."""
    import cv2

    side = int(round(INPUT_SIZE * rng.uniform(*cfg.scale_range)))
    canvas, boxes, cls, ignore = prepare(sample, side)
    c = cfg.crop
    pad = max(0, c - side)
    if pad:
        canvas = cv2.copyMakeBorder(canvas, 0, pad, 0, pad, cv2.BORDER_CONSTANT, value=(114 / 255,) * 3)
    hh, ww = canvas.shape[:2]
    keep = np.flatnonzero(~ignore)
    if keep.size and rng.random() < cfg.object_crop_p:
        b = boxes[rng.choice(keep)]
        cx = 0.5 * (b[0] + b[2]) + rng.uniform(-0.4, 0.4) * c
        cy = 0.5 * (b[1] + b[3]) + rng.uniform(-0.4, 0.4) * c
        x0 = int(np.clip(round(cx - c / 2), 0, ww - c))
        y0 = int(np.clip(round(cy - c / 2), 0, hh - c))
    else:
        x0, y0 = int(rng.integers(0, ww - c + 1)), int(rng.integers(0, hh - c + 1))
    img = canvas[y0:y0 + c, x0:x0 + c].copy()
    full = np.maximum(boxes[:, 2] - boxes[:, 0], 0) * np.maximum(boxes[:, 3] - boxes[:, 1], 0)
    boxes = boxes - np.array([x0, y0, x0, y0], dtype=np.float64)
    boxes = np.clip(boxes, 0, c)
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    inside = area > 0
    ignore = ignore | (area < 0.5 * np.maximum(full, 1e-9))
    boxes, cls, ignore = boxes[inside], cls[inside], ignore[inside]
    if rng.random() < 0.5:
        img = img[:, ::-1]
        boxes = np.stack([c - boxes[:, 2], boxes[:, 1], c - boxes[:, 0], boxes[:, 3]], axis=1)
    gain = rng.uniform(0.8, 1.2, size=3).astype(np.float32)
    img = img * gain + np.float32(rng.uniform(-0.08, 0.08))
    if rng.random() < 0.2:
        img = cv2.GaussianBlur(img, (0, 0), float(rng.uniform(0.5, 1.2)))
    img = np.clip(img + rng.normal(0, 0.01, img.shape).astype(np.float32), 0, 1)
    return np.ascontiguousarray(img.transpose(2, 0, 1)), boxes, cls, ignore


def targets(boxes: np.ndarray, cls: np.ndarray, ignore: np.ndarray, size: int) -> dict[str, np.ndarray]:
    """CenterNet targets on the ``size / STRIDE`` grid.

    ``heat`` (2, g, g) in [0, 1]: an elliptical Gaussian per object (sigma = 0.1 x box side in
    cells, at least 0.5) with 1 at its centre cell; ``weight`` (2, g, g): 0 inside ignored boxes,
    else 1; ``size`` / ``offset`` (4, g, g) regression targets (channels ``2k, 2k + 1`` for class
    k) and ``reg_mask`` (2, g, g) at each class's centre cells.
    """
    g = size // STRIDE
    heat = np.zeros((len(CLASS_NAMES), g, g), dtype=np.float32)
    weight = np.ones_like(heat)
    size_t = np.zeros((2 * len(CLASS_NAMES), g, g), dtype=np.float32)
    off_t = np.zeros_like(size_t)
    reg = np.zeros((len(CLASS_NAMES), g, g), dtype=np.float32)
    ys, xs = np.mgrid[0:g, 0:g].astype(np.float32)
    for b, k, ig in zip(boxes, cls, ignore, strict=True):
        if ig:
            x0, y0 = int(np.floor(b[0] / STRIDE)), int(np.floor(b[1] / STRIDE))
            x1, y1 = int(np.ceil(b[2] / STRIDE)), int(np.ceil(b[3] / STRIDE))
            weight[k, y0:y1, x0:x1] = 0.0
            continue
        w, h = b[2] - b[0], b[3] - b[1]
        cx, cy = 0.5 * (b[0] + b[2]) / STRIDE, 0.5 * (b[1] + b[3]) / STRIDE
        ix, iy = min(int(cx), g - 1), min(int(cy), g - 1)
        sx, sy = max(0.5, 0.1 * w / STRIDE), max(0.5, 0.1 * h / STRIDE)
        gauss = np.exp(-0.5 * (((xs - ix) / sx) ** 2 + ((ys - iy) / sy) ** 2))
        heat[k] = np.maximum(heat[k], gauss)
        heat[k, iy, ix] = 1.0
        size_t[2 * k : 2 * k + 2, iy, ix] = np.log(np.maximum([w / STRIDE, h / STRIDE], 1e-3))
        off_t[2 * k : 2 * k + 2, iy, ix] = (cx - ix, cy - iy)
        reg[k, iy, ix] = 1.0
    return {"heat": heat, "weight": weight, "size": size_t, "offset": off_t, "reg_mask": reg}


def loss_fn(outputs, batch: dict, cfg: TrainConfig):
    """Penalty-reduced focal loss on the heat map (per positive) + L1 on size and offset.

    Returns ``(total, parts dict of floats)``.
    """
    import torch
    from torch.nn import functional as F

    heat_logit, size, offset = outputs
    t_heat, w = batch["heat"], batch["weight"]
    p = torch.sigmoid(heat_logit).clamp(1e-4, 1 - 1e-4)
    pos = (t_heat >= 1.0).float()
    log_p, log_1p = F.logsigmoid(heat_logit), F.logsigmoid(-heat_logit)
    pos_loss = -(pos * (1 - p) ** 2 * log_p).sum()
    neg_loss = -((1 - pos) * w * (1 - t_heat) ** 4 * p**2 * log_1p).sum()
    n_pos = pos.sum().clamp(min=1.0)
    focal = (pos_loss + neg_loss) / n_pos
    m = batch["reg_mask"].repeat_interleave(2, dim=1)  # (B, C, g, g) -> (B, 2C, g, g)
    n_reg = (m.sum() / 2).clamp(min=1.0)  # objects (each has an x and a y term)
    l_size = (torch.abs(size - batch["size"]) * m).sum() / n_reg
    l_off = (torch.abs(torch.sigmoid(offset) - batch["offset"]) * m).sum() / n_reg
    total = focal + cfg.size_weight * l_size + cfg.offset_weight * l_off
    return total, {"focal": float(focal.detach()), "size": float(l_size.detach()), "offset": float(l_off.detach())}


def make_batch(samples: list[dict], cfg: TrainConfig, rng: np.random.Generator) -> dict:
    """``cfg.batch`` augmented crops with their targets, as torch tensors."""
    import torch

    imgs, tgts = [], []
    for i in rng.integers(0, len(samples), size=cfg.batch):
        img, boxes, cls, ignore = augment(samples[int(i)], cfg, rng)
        imgs.append(img)
        tgts.append(targets(boxes, cls, ignore, cfg.crop))
    batch = {k: torch.from_numpy(np.stack([t[k] for t in tgts])) for k in tgts[0]}
    batch["image"] = torch.from_numpy(np.stack(imgs))
    return batch


def lr_at(step: int, cfg: TrainConfig) -> float:
    """Linear warm-up over 100 steps, then cosine decay to 2 % of ``cfg.lr``."""
    warm = min(100, max(1, cfg.steps // 10))
    if step < warm:
        return cfg.lr * (step + 1) / warm
    t = (step - warm) / max(1, cfg.steps - warm)
    return cfg.lr * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * t)))


def train(samples: list[dict], cfg: TrainConfig, out: Path, log=print, init: Path | None = None):
    """Train on ``samples`` from scratch, or from the weights in ``init`` (a ``model.pt``: a second
    stage with its own schedule); write ``out/model.pt`` and ``out/train.json``; return the net."""
    import torch

    from reference_models.detector.model import CenterNetSmall, count_parameters, widen_heads

    if not samples:
        raise ValueError("no training samples")
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    net = CenterNetSmall()
    if init is not None:
        net.load_state_dict(widen_heads(torch.load(init, map_location="cpu", weights_only=True)))
    opt = torch.optim.AdamW(net.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    history = []
    run = {}
    net.train()
    for step in range(cfg.steps):
        for group in opt.param_groups:
            group["lr"] = lr_at(step, cfg)
        batch = make_batch(samples, cfg, rng)
        loss, parts = loss_fn(net(batch["image"]), batch, cfg)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 10.0)
        opt.step()
        for k, v in parts.items():
            run[k] = 0.98 * run.get(k, v) + 0.02 * v
        if step % 50 == 0 or step == cfg.steps - 1:
            elapsed = time.perf_counter() - start
            history.append({"step": step, "seconds": round(elapsed, 1), **{k: round(v, 4) for k, v in run.items()}})
            log(f"step {step}/{cfg.steps} {elapsed:.0f} s " + " ".join(f"{k} {v:.3f}" for k, v in run.items()))
        if step % 500 == 499:
            torch.save(net.state_dict(), out / "model.pt")
    seconds = time.perf_counter() - start
    torch.save(net.state_dict(), out / "model.pt")
    info = {"config": asdict(cfg), "init": None if init is None else str(init), "train_seconds": round(seconds, 1), "views": len(samples),
            "parameters": count_parameters(net), "torch": torch.__version__, "history": history}
    (out / "train.json").write_text(json.dumps(info, indent=1) + "\n")
    return net

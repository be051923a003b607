"""The seed study's training budget and shared model sizes, for a machine with a GPU.

The seed paper (Dynamic NeRFs for Soccer Scenes, section "Implementation") trains K-Planes and
NeRFPlayer in nerfstudio with "typical Nerfstudio settings: 30,000 iterations using Adam with a
learning rate of 10^-2, about 1 to 2 hours on an NVIDIA RTX 3090 GPU for each scene", and
"shared settings between the models are identical, such as proposal sampling and scene
contraction"; its model-specific hyperparameters "follow the original implementations, except
for the model size". What the paper does not state is taken from K-Planes' DyNeRF config (the
values the ``RenderConfig`` / ``TrainConfig`` docstrings cite) and nerfstudio's defaults, as said
at each value. Each model package adds its own ``seed`` field sizes with ``seed_preset``.
"""

from __future__ import annotations

from typing import Any

from reference_models.common.model import RenderConfig
from reference_models.common.train import TrainConfig

SEED_RENDER = RenderConfig(proposal_samples=(256, 128), final_samples=48,
                           proposal_resolution=(128, 256), proposal_features=8, hidden=64,
                           geo_features=15)
"""Shared by both models, as in the seed: K-Planes' DyNeRF proposal sampling (two proposal
levels of 256 and 128 samples per ray on planes of 128 and 256 cells, 8 features each; 48
samples of the field) and its decoder (64 hidden units, 15 geometry features). Near and far
stay the stadium's (the seed's scenes are the same kind)."""

SEED_TRAIN = TrainConfig(iters=30_000, batch_rays=4096, lr=1e-2, warmup=512, log_every=100,
                         eval_every=1000, eval_views=4, eval_stride=1, checkpoint_every=1000)
"""30,000 steps at a learning rate of 1e-2 (the seed paper); 4,096 rays per step (nerfstudio's
default batch, the seed's "typical Nerfstudio settings"; K-Planes' too); 512 warm-up steps
(K-Planes' cosine schedule); the loss weights are ``TrainConfig``'s K-Planes values. Eval PSNR
every 1,000 steps on 4 whole views, a checkpoint every 1,000 steps (our choices: cheap on a
GPU, at most ~1/30 of a run lost to an interruption)."""


def seed_preset(model_cfg: Any) -> tuple[Any, RenderConfig, TrainConfig]:
    """A model's ``seed`` preset: its seed-sized field with the shared render and train configs."""
    return model_cfg, SEED_RENDER, SEED_TRAIN

"""K-Planes' field for the shared model: configuration, presets, and the encoding builder."""

from __future__ import annotations

from dataclasses import dataclass

from reference_models.common.encodings import PlaneEncoding
from reference_models.common.train import ModelSpec, standard_presets


@dataclass
class KPlanesConfig:
    """K-Planes encoding sizes (K-Planes DyNeRF hybrid: 64 base, scales 1/2/4/8, F=16, T=150)."""

    resolution: int = 64
    """Space resolution of the coarsest scale (cells per axis over the contracted world)."""
    scales: tuple[int, ...] = (1, 2, 4)
    """Multipliers of ``resolution``, one plane set per scale (capped at ``max_resolution``)."""
    features: int = 16
    """Features per plane and scale (F)."""
    max_resolution: int = 256
    """Cap on any space resolution (planes above 256^2 cost much more on CPU)."""
    time_resolution: int | None = None
    """Cells along time; None: the number of frames (knots on frames, as the ball needs)."""


def build_encoding(cfg: KPlanesConfig, scene: dict) -> PlaneEncoding:
    """The six-plane encoding for a scene (``scene["n_frames"]`` sets the default time cells)."""
    t_res = cfg.time_resolution or int(scene["n_frames"])
    return PlaneEncoding(cfg.resolution, max(t_res, 2), tuple(cfg.scales), cfg.features,
                         cfg.max_resolution)


PRESETS = standard_presets(
    tiny=KPlanesConfig(resolution=16, scales=(1, 2), features=8),
    small=KPlanesConfig())
"""``tiny``: tests (seconds); ``small``: the documented runs (see ``standard_presets``)."""

SPEC = ModelSpec("kplanes", KPlanesConfig, PRESETS, build_encoding)
"""What the shared CLI and training loop need to run K-Planes."""

"""Compact reference K-Planes (Fridovich-Keil et al., CVPR 2023) in plain PyTorch for 2 CPU cores.

The field is ``PlaneEncoding`` (six planes xy, xz, yz, xt, yt, zt at several spatial scales,
features multiplied across planes and concatenated across scales, time planes initialised to 1)
decoded by the shared ``DynamicRadianceModel`` (proposal sampling, density + view-dependent colour
MLPs, a sky term). ``dynamic_box=True`` is the "model only what a scene needs" variant: a static
three-plane field everywhere plus space-time planes only inside the box the motion masks say moves
(see ``field.py``).

    python -m reference_models.kplanes train DATA --out RUN [--size tiny|small] [--iters N]
        [--sampling uniform|isg|ist]
    python -m reference_models.kplanes render RUN      # RUN/pred/<camera>/<frame>.png
"""

from reference_models.kplanes.field import SPEC, KPlanesConfig

__all__ = ["SPEC", "KPlanesConfig"]

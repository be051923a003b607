"""Evaluation protocols: reproduce the whole-frame numbers other evaluators publish.

``--protocol NAME`` (``ScoreConfig.protocol``, names in ``PROTOCOL_NAMES``) changes how the
whole-frame PSNR and SSIM are computed and how images are prepared, so that dynaeval's figures can
sit next to tables produced by those tools. Each protocol is one class, a subclass of
``dynaeval.metrics.protocol_base.Protocol`` (the interface) in its own module, and this module is
their registry (``PROTOCOLS``, ``get_protocol``), as ``dynaeval.metrics.registry`` is the
metrics'. docs/protocols.md lists every difference and where it comes from; in short:

* ``dynaeval``: images as read (no 8-bit step), PSNR from a float64 squared error, SSIM of
  scikit-image's Gaussian variant (11 taps, sigma 1.5, valid windows only, float64 reductions),
  LPIPS AlexNet.
* ``nerfbaselines``: both images go through 8 bit by truncation (``clip(x * 255).astype(uint8)``)
  before the metrics, values are clipped to [0, 1]; PSNR from a float32 mean squared error; SSIM of
  the dm_pix variant (Gaussian 11 taps, sigma 1.5, valid windows, float64 statistics of the float32
  images, variances clamped to at least ``eps_float32 ** 2`` and the covariance to
  ``+-sqrt(var_x var_y)``); LPIPS AlexNet.
* ``nerfstudio`` (nerfacto and the models that share its metrics: instant-ngp, mipnerf, tensorf,
  vanilla-nerf, semantic-nerfw): float images as rendered (no 8-bit step); PSNR as torchmetrics'
  ``PeakSignalNoiseRatio(data_range=1)`` (float32); SSIM as torchmetrics' (1.9)
  ``structural_similarity_index_measure`` called with *no* ``data_range``, i.e. the images' own
  range ``max(ptp(pred), ptp(gt))`` per image (Gaussian 11 taps, sigma 1.5, image reflect-padded
  by 5 px and *every* window averaged, border included; variances clamped at 0; float32); LPIPS
  AlexNet as torchmetrics' ``LearnedPerceptualImagePatchSimilarity(normalize=True)`` (inputs in
  [0, 1] mapped to [-1, 1]).
* ``kplanes``: K-Planes' trainers (``dynaeval.metrics.protocol_kplanes``): float renders, images
  clipped to [0, 1], PSNR from a float32 MSE, mip-NeRF's SSIM (valid windows, float64 statistics,
  variances clipped at 0, covariance at ``+-sqrt(var_x var_y)``), and MS-SSIM / D-SSIM
  (``dynaeval.metrics.multiscale``) added to the run's metrics; LPIPS AlexNet; RGBA over white.
* ``nerfstudio-splatfacto``: as ``nerfstudio`` but SSIM as ``pytorch_msssim.SSIM(data_range=1)``
  (valid windows, no clamp, float32) — ``dynaeval.metrics.protocol_nerfstudio``.
* ``3dgs`` (gaussian-splatting, 4DGaussians, Deformable-3DGS ``metrics.py``): PSNR
  ``20 log10(1 / sqrt(MSE))`` in float32, SSIM with zero padding (every pixel's window, float32),
  LPIPS VGG fed the [0, 1] images unscaled — ``dynaeval.metrics.protocol_3dgs``.
* ``4dgaussians``: ``3dgs`` plus what 4DGaussians' ``metrics.py`` adds: MS-SSIM and D-SSIM of
  ``pytorch_msssim.ms_ssim(data_range=1)`` (``Protocol.whole_msssim``), and its ``LPIPS-alex`` beside
  ``LPIPS-vgg`` (``--lpips-net alex``, again on unscaled [0, 1] input).
* ``dycheck``: 8-bit truncation, float32 squared error, DyCheck's SSIM (valid windows, variances
  clamped at 0), LPIPS AlexNet as the mean of its spatial map; with covisibility masks also
  ``mpsnr``/``mssim``/``mlpips`` as DyCheck defines them (``dynaeval.metrics.protocol_dycheck``).

Given masks (``ScoreConfig.masks``, a NeRFBaselines ``mask/`` folder, DyCheck's
``covisible/``) are used by every protocol as dynaeval's ``masked_*`` region; the protocol's
``apply_masks`` / ``mask_regions`` say what it does with them itself (recorded as
``Protocol.masks``): nothing more (``region``), ``multiply`` (NeRFBaselines: the whole-frame
metrics score ``pred * m`` against ``gt * m`` over the whole frame) or ``covisible`` (DyCheck: its
``m*`` metrics).

The ``focused_*``/``masked_*``/temporal metrics are dynaeval's own under every protocol (the other
tools have none); the protocol's 8-bit step applies to them too, since it changes the images.
All protocols report the mean of per-image values.
"""

from __future__ import annotations

from dynaeval.core.errors import InputError, did_you_mean
from dynaeval.metrics.pixel import psnr_float32
from dynaeval.metrics.protocol_3dgs import FourDGaussiansProtocol, GaussianSplattingProtocol
from dynaeval.metrics.protocol_base import Protocol
from dynaeval.metrics.protocol_dycheck import DyCheckProtocol
from dynaeval.metrics.protocol_kplanes import KPlanesProtocol
from dynaeval.metrics.protocol_nerfbaselines import NerfBaselinesProtocol
from dynaeval.metrics.protocol_nerfstudio import NerfstudioProtocol, SplatfactoProtocol
from dynaeval.metrics.windows import SSIM_BORDERS, SSIM_CLAMPS, ssim_variant

__all__ = ["PROTOCOLS", "PROTOCOL_NAMES", "SSIM_BORDERS", "SSIM_CLAMPS", "DynaevalProtocol",
           "Protocol", "get_protocol", "psnr_float32", "resolve_quantize", "run_metrics",
           "ssim_variant"]


class DynaevalProtocol(Protocol):
    """dynaeval's own numbers (the base class's behaviour), and the one protocol that lets the
    user choose the 8-bit step and the LPIPS backbone."""

    name = "dynaeval"
    reference = "docs/metrics.md"

    def resolve_quantize(self, asked: str | None) -> str:
        """``asked`` (any of ``pixel.QUANTIZE_MODES``), ``none`` when not asked."""
        return self.quantize if asked in (None, "none") else asked

    def check_lpips_net(self, net: str) -> None:
        """Any backbone: dynaeval reports the one asked for."""


PROTOCOLS: dict[str, Protocol] = {
    p.name: p
    for p in (DynaevalProtocol(), NerfBaselinesProtocol(), NerfstudioProtocol(), KPlanesProtocol(),
              SplatfactoProtocol(), GaussianSplattingProtocol(), FourDGaussiansProtocol(),
              DyCheckProtocol())
}
"""Every protocol by name, in the order the CLI lists them: adding one is its class (a subclass
of ``Protocol`` in its ``protocol_*.py`` module) and its entry here (docs/protocols.md)."""

PROTOCOL_NAMES = tuple(PROTOCOLS)
"""The ``--protocol`` choices."""


def get_protocol(name: str) -> Protocol:
    """The protocol called ``name``.

    Raises:
        InputError: unknown name.
    """
    if name not in PROTOCOLS:
        raise InputError(f"protocol must be one of {', '.join(PROTOCOL_NAMES)}, got {name!r}"
                         f"{did_you_mean(name, PROTOCOL_NAMES)}")
    return PROTOCOLS[name]


def resolve_quantize(protocol: Protocol, quantize: str | None) -> str:
    """``protocol.resolve_quantize(quantize)``: the 8-bit step to use."""
    return protocol.resolve_quantize(quantize)


def run_metrics(protocol: Protocol, names: tuple[str, ...]) -> tuple[str, ...]:
    """``protocol.run_metrics(names)``: those asked for, then the protocol's own."""
    return protocol.run_metrics(names)

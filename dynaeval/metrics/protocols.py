"""Evaluation protocols: reproduce the whole-frame numbers other evaluators publish.

``--protocol NAME`` (``ScoreConfig.protocol``, names in ``PROTOCOLS``) changes how the
whole-frame PSNR and SSIM are computed and how images are prepared, so that dynaeval's figures can
sit next to tables produced by those tools. docs/protocols.md lists every difference and where it
comes from; in short:

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
  ``pytorch_msssim.ms_ssim(data_range=1)`` (``Protocol.msssim``), and its ``LPIPS-alex`` beside
  ``LPIPS-vgg`` (``--lpips-net alex``, again on unscaled [0, 1] input).
* ``dycheck``: 8-bit truncation, float32 squared error, DyCheck's SSIM (valid windows, variances
  clamped at 0), LPIPS AlexNet as the mean of its spatial map; with covisibility masks also
  ``mpsnr``/``mssim``/``mlpips`` as DyCheck defines them (``dynaeval.metrics.protocol_dycheck``).

Given masks (``ScoreConfig.masks``, a NeRFBaselines ``mask/`` folder, DyCheck's
``covisible/``) are used by every protocol as dynaeval's ``masked_*`` region; ``Protocol.masks``
says what the protocol itself does with them: ``region`` (nothing more), ``multiply``
(NeRFBaselines: the whole-frame metrics score ``pred * m`` against ``gt * m`` over the whole
frame) or ``covisible`` (DyCheck: its ``m*`` metrics).

The ``focused_*``/``masked_*``/temporal metrics are dynaeval's own under every protocol (the other
tools have none); the protocol's 8-bit step applies to them too, since it changes the images.
All protocols report the mean of per-image values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dynaeval.errors import InputError
from dynaeval.metrics.pixel import psnr
from dynaeval.metrics.protocol_3dgs import psnr_3dgs
from dynaeval.metrics.protocol_dycheck import dycheck_lpips, dycheck_psnr, dycheck_ssim
from dynaeval.metrics.protocol_kplanes import KPLANES_CHOICES, KPLANES_REFERENCE, kplanes_ssim
from dynaeval.metrics.protocol_nerfbaselines import multiply_mask
from dynaeval.metrics.protocol_nerfstudio import image_data_range, msssim_window
from dynaeval.metrics.structural import K1, K2, _check_size, ssim
from dynaeval.metrics.windows import as_hwc, window_statistics
from dynaeval.validation import check_data_range, check_pair

PROTOCOL_NAMES = ("dynaeval", "nerfbaselines", "nerfstudio", "kplanes", "nerfstudio-splatfacto",
                  "3dgs", "4dgaussians", "dycheck")


def psnr_float32(pred: object, gt: object, *, data_range: float = 1.0, clip: bool = False) -> float:
    """PSNR in dB from a float32 mean squared error (as NeRFBaselines and torchmetrics compute it).

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range].
        data_range: peak value L.
        clip: clip both images to [0, 1] first (NeRFBaselines' input normalisation).

    Returns:
        ``10 log10(L^2 / MSE)`` as a Python float; ``math.inf`` for identical images.
    """
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    p32, g32 = p.astype(np.float32), g.astype(np.float32)
    if clip:
        p32, g32 = np.clip(p32, 0, 1), np.clip(g32, 0, 1)
    d = p32 - g32
    mse = float(np.mean(d * d, dtype=np.float32))
    if mse == 0.0:
        return math.inf
    return 10.0 * math.log10(data_range * data_range / mse)


SSIM_BORDERS = ("valid", "reflect", "zero")
SSIM_CLAMPS = ("none", "zero", "dm_pix")


def ssim_variant(
    pred: object,
    gt: object,
    *,
    data_range: float = 1.0,
    border: str = "valid",
    clamp: str = "none",
    clip: bool = False,
    precision: str = "float32",
    window: np.ndarray | None = None,
) -> float:
    """SSIM with a Gaussian window (11 taps, sigma 1.5) in the variants other evaluators use.

    Args:
        pred, gt: (H, W) or (H, W, C) arrays/tensors in [0, data_range], H, W >= 11.
        data_range: L in ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2``.
        border: ``"valid"``: only windows entirely inside the image (scikit-image, dm_pix,
            NeRFBaselines); ``"reflect"``: the image is padded by 5 px by reflection without
            repeating the edge (torch's ``reflect``) and all H x W windows are averaged
            (torchmetrics 1.9, which nerfstudio calls); ``"zero"``: padded by 5 px of zeros and
            all H x W windows averaged (3DGS ``utils/loss_utils.ssim``: ``conv2d(padding=5)``).
        clamp: ``"none"``; ``"zero"``: variances ``max(0, var)`` (torchmetrics); ``"dm_pix"``:
            variances ``max(eps_f32^2, var)`` and covariance ``sign(cov) min(sqrt(var_x var_y),
            |cov|)`` (dm_pix / NeRFBaselines).
        clip: clip both images to [0, 1] first (NeRFBaselines).
        precision: ``"float32"`` (torchmetrics: float32 tensors throughout) or ``"float64"``
            (NeRFBaselines' numpy port of dm_pix: float32 images convolved with a float64
            window, so the statistics are float64).
        window: the 1-D taps, (11,), as the evaluator computes them (float32 weights normalised
            in float32 sum to 1 only within rounding, which moves SSIM by ~1e-5 on flat regions);
            default ``structural.gaussian_window()`` (float64).

    Returns:
        Mean SSIM over the windows and channels, a Python float in [-1, 1].

    Raises:
        InputError: bad shapes, values, size below 11 px, or unknown border/clamp/precision.
    """
    for arg, value, allowed in (("border", border, SSIM_BORDERS), ("clamp", clamp, SSIM_CLAMPS),
                                ("precision", precision, ("float32", "float64"))):
        if value not in allowed:
            raise InputError(f"{arg} must be one of {', '.join(allowed)}, got {value!r}")
    data_range = check_data_range(data_range)
    p, g = check_pair(pred, gt)
    dtype = np.dtype(precision)
    p, g = as_hwc(p).astype(np.float32), as_hwc(g).astype(np.float32)
    if clip:
        p, g = np.clip(p, 0, 1), np.clip(g, 0, 1)
    p, g = p.astype(dtype), g.astype(dtype)
    _check_size(*p.shape[:2])
    c1 = dtype.type((K1 * data_range) ** 2)
    c2 = dtype.type((K2 * data_range) ** 2)
    maps = []
    for mx, my, sxx, syy, sxy in window_statistics(p, g, border=border, clamp=clamp, window=window):
        num = (2 * mx * my + c1) * (2 * sxy + c2)
        den = (mx * mx + my * my + c1) * (sxx + syy + c2)
        maps.append(num / den)
    return float(np.mean(np.stack(maps), dtype=np.float64))


@dataclass(frozen=True)
class Protocol:
    """How one evaluator prepares images and computes whole-frame PSNR/SSIM."""

    name: str
    """A key of ``PROTOCOLS``."""
    quantize: str
    """8-bit step applied to both images before every metric: ``none`` or ``truncate``."""
    psnr: str
    """``float64`` (dynaeval), ``float32`` (mean squared error in float32) or ``3dgs``
    (``20 log10(1 / sqrt(MSE))``, all in float32)."""
    ssim: str
    """``skimage-gaussian`` (dynaeval), ``dm_pix`` (valid windows, clamped), ``torchmetrics``
    (reflect-padded, every window, float32), ``mipnerf`` (K-Planes: valid windows, float64
    statistics, variances clipped at 0), ``pytorch_msssim`` (valid windows, float32) or ``3dgs``
    (zero-padded, every window, float32)."""
    clip: bool
    """Clip images to [0, 1] before PSNR/SSIM."""
    lpips_net: str
    """The LPIPS backbone the evaluator reports as ``lpips``."""
    reference: str
    """Where the definitions come from."""
    metrics: tuple[str, ...] = ()
    """Per-frame metrics the evaluator reports beyond PSNR/SSIM/LPIPS (registry names): a run
    under this protocol computes them too (``run_metrics``)."""
    background: str | None = None
    """The background RGBA ground truth is blended over (``white``/``black``), None: any."""
    choices: tuple[tuple[str, str], ...] = ()
    """Every further choice of the evaluator, ``(what, how and where from)``, for the results."""
    ssim_data_range: str = "fixed"
    """L of SSIM's constants: ``fixed`` (the run's ``data_range``) or ``image`` (each pair's own
    range, ``max(ptp(pred), ptp(gt))``: torchmetrics called without ``data_range``)."""
    lpips_input: str = "signed"
    """How [0, 1] images reach the LPIPS network: ``signed`` (mapped to [-1, 1], the package's
    convention) or ``unit`` (given as they are, as 3DGS' ``metrics.py`` does)."""
    family: str = ""
    """The models whose evaluation code this protocol follows (empty: a tool, not a model)."""

    decode: str = "dynaeval"
    """16-bit PNG decoding (``dynaeval.io.images.DECODES``): ``dynaeval`` (v / 65535) or
    ``pil`` (the high byte, as Pillow and so NeRFBaselines read them)."""
    masks: str = "region"
    """What the protocol does with given masks beyond dynaeval's ``masked_*``: ``region``,
    ``multiply`` (whole-frame metrics of the mask-multiplied images) or ``covisible`` (the
    ``m*`` metrics of DyCheck)."""
    lpips_reduce: str = "network"
    """Whole-frame LPIPS: ``network`` (the package's own spatial average per layer) or
    ``spatial-mean`` (mean of the ``spatial=True`` map, upsampled per layer: DyCheck)."""
    msssim: str = "torchmetrics"
    """Which MS-SSIM ``msssim``/``dssim`` compute: ``torchmetrics`` (1.9, K-Planes' call:
    ``dynaeval.metrics.multiscale``) or ``pytorch_msssim`` (1.0 ``ms_ssim``, 4DGaussians':
    ``dynaeval.metrics.protocol_3dgs.msssim_4dgaussians``)."""
    lpips_nets: tuple[str, ...] = ()
    """Other LPIPS backbones the evaluator also reports (``--lpips-net`` may choose them);
    ``lpips_net`` is the default."""

    def describe(self) -> dict[str, Any]:
        """Settings for the results JSON: every choice the protocol implies. The fields after
        ``reference`` are written when they differ from their defaults, so the results of the
        older protocols stay as they were."""
        out = {"name": self.name, "quantize": self.quantize, "psnr": self.psnr,
               "ssim": self.ssim, "clip": self.clip, "lpips_net": self.lpips_net,
               "reference": self.reference}
        if self.metrics:
            out["metrics"] = list(self.metrics)
        if self.background is not None:
            out["background"] = self.background
        if self.choices:
            out["choices"] = dict(self.choices)
        for key, default in (("ssim_data_range", "fixed"), ("lpips_input", "signed"),
                             ("family", ""), ("decode", "dynaeval"), ("masks", "region"),
                             ("lpips_reduce", "network"), ("msssim", "torchmetrics")):
            if getattr(self, key) != default:
                out[key] = getattr(self, key)
        if self.lpips_nets:
            out["lpips_nets"] = list(self.lpips_nets)
        return out

    def _weighted(self, pred: object, gt: object, weights: object) -> tuple[object, object]:
        """``pred * m, gt * m`` for ``masks="multiply"``; the images otherwise. InputError when
        the protocol has no use for weights."""
        if weights is None or self.masks == "covisible":
            return pred, gt
        if self.masks != "multiply":
            raise InputError(f"protocol {self.name} does not score the whole frame with a mask")

        return multiply_mask(pred, gt, weights)

    def _check_range(self, data_range: float) -> None:
        if self.clip and data_range != 1.0:
            raise InputError(
                f"protocol {self.name} clips images to [0, 1], so it needs data_range=1, got "
                f"{data_range}; scale the images to [0, 1] or use --protocol dynaeval"
            )

    def whole_psnr(self, pred: object, gt: object, *, data_range: float = 1.0,
                   weights: object = None) -> float:
        """Whole-frame PSNR in dB under this protocol; ``weights``: (H, W) mask in [0, 1], used
        as ``Protocol.masks`` says."""
        self._check_range(data_range)
        pred, gt = self._weighted(pred, gt, weights)
        if self.psnr == "dycheck":
            return dycheck_psnr(pred, gt, weights=weights, data_range=data_range)
        if self.psnr == "float32":
            return psnr_float32(pred, gt, data_range=data_range, clip=self.clip)
        if self.psnr == "3dgs":
            return psnr_3dgs(pred, gt, data_range=data_range)

        return psnr(pred, gt, data_range=data_range)

    def whole_ssim(self, pred: object, gt: object, *, data_range: float = 1.0,
                   weights: object = None) -> float:
        """Whole-frame SSIM under this protocol; ``weights`` as in ``whole_psnr``."""
        self._check_range(data_range)
        pred, gt = self._weighted(pred, gt, weights)
        if self.ssim == "dycheck":
            return dycheck_ssim(pred, gt, weights=weights, data_range=data_range)
        if self.ssim == "skimage-gaussian":
            return ssim(pred, gt, data_range=data_range)
        if self.ssim == "mipnerf":
            return kplanes_ssim(pred, gt, data_range=data_range, clip=self.clip)
        if self.ssim == "dm_pix":
            return ssim_variant(pred, gt, data_range=data_range, border="valid", clamp="dm_pix",
                                clip=self.clip, precision="float64")
        if self.ssim == "3dgs":
            return ssim_variant(pred, gt, data_range=data_range, border="zero", clamp="none",
                                clip=self.clip, precision="float32")
        if self.ssim == "pytorch_msssim":
            return ssim_variant(pred, gt, data_range=data_range, border="valid", clamp="none",
                                clip=self.clip, precision="float32", window=msssim_window())
        if self.ssim_data_range == "image":
            data_range = image_data_range(pred, gt)
        return ssim_variant(pred, gt, data_range=data_range, border="reflect", clamp="zero",
                            clip=self.clip, precision="float32")

    def whole_lpips(self, score: Any, score_map: Any, pred: object, gt: object, *,
                    weights: object = None) -> float:
        """Whole-frame LPIPS under this protocol.

        Args:
            score: ``(pred, gt) -> float``, the package's LPIPS; score_map: ``(pred, gt) ->
                (H, W)`` its spatial map.
            weights: as in ``whole_psnr``.
        """
        if self.clip:
            pred, gt = np.clip(np.asarray(pred), 0, 1), np.clip(np.asarray(gt), 0, 1)
        pred, gt = self._weighted(pred, gt, weights)
        if self.lpips_reduce == "spatial-mean":
            return dycheck_lpips(score_map, pred, gt, weights=weights)
        return score(pred, gt)


PROTOCOLS: dict[str, Protocol] = {
    "dynaeval": Protocol("dynaeval", "none", "float64", "skimage-gaussian", False, "alex",
                         "docs/metrics.md"),
    "nerfbaselines": Protocol(
        "nerfbaselines", "truncate", "float32", "dm_pix", True, "alex",
        "NeRFBaselines evaluation.py (DefaultEvaluationProtocol, compute_metrics) and metrics.py",
        decode="pil", masks="multiply",
    ),
    "nerfstudio": Protocol(
        "nerfstudio", "none", "float32", "torchmetrics", False, "alex",
        "nerfstudio models' get_image_metrics_and_images (torchmetrics PSNR, SSIM, LPIPS "
        "normalize=True) averaged per image by ns-eval; torchmetrics 1.9 functional/image/ssim.py "
        "(data_range=None: the images' own range)",
        ssim_data_range="image",
        family="nerfacto, instant-ngp, mipnerf, tensorf, vanilla-nerf, semantic-nerfw",
    ),
    "nerfstudio-splatfacto": Protocol(
        "nerfstudio-splatfacto", "none", "float32", "pytorch_msssim", False, "alex",
        "nerfstudio models/splatfacto.py get_image_metrics_and_images (torchmetrics PSNR, "
        "pytorch_msssim.SSIM(data_range=1.0, size_average=True), LPIPS normalize=True)",
        family="splatfacto",
    ),
    "3dgs": Protocol(
        "3dgs", "none", "3dgs", "3dgs", False, "vgg",
        "gaussian-splatting / 4DGaussians / Deformable-3DGS metrics.py (utils/image_utils.psnr, "
        "utils/loss_utils.ssim, lpipsPyTorch or lpips.LPIPS(net='vgg') on [0, 1] images)",
        lpips_input="unit",
        family="gaussian-splatting, 4DGaussians, Deformable-3DGS",
    ),
    "4dgaussians": Protocol(
        "4dgaussians", "none", "3dgs", "3dgs", False, "vgg",
        "4DGaussians metrics.py (utils/image_utils.psnr, utils/loss_utils.ssim, "
        "pytorch_msssim.ms_ssim(data_range=1, size_average=True), D-SSIM = (1 - MS-SSIM) / 2, "
        "lpipsPyTorch.lpips(net_type='vgg' and 'alex') on [0, 1] images)",
        metrics=("msssim", "dssim"), lpips_input="unit", family="4DGaussians",
        msssim="pytorch_msssim", lpips_nets=("alex",),
    ),
    "kplanes": Protocol("kplanes", "none", "float32", "mipnerf", True, "alex", KPLANES_REFERENCE,
                        metrics=("msssim", "dssim"), background="white", choices=KPLANES_CHOICES),
    "dycheck": Protocol(
        "dycheck", "truncate", "dycheck", "dycheck", True, "alex",
        "DyCheck dycheck/core/tasks/novel_view.py (to_quantized_float32, mpsnr/mssim/mlpips), "
        "dycheck/core/metrics/image.py, dycheck/nn/functional/common.py (masked_mean)",
        masks="covisible", lpips_reduce="spatial-mean",
    ),
}


def get_protocol(name: str) -> Protocol:
    """The protocol called ``name``.

    Raises:
        InputError: unknown name.
    """
    if name not in PROTOCOLS:
        raise InputError(f"protocol must be one of {', '.join(PROTOCOL_NAMES)}, got {name!r}")
    return PROTOCOLS[name]


def resolve_quantize(protocol: Protocol, quantize: str | None) -> str:
    """The 8-bit step to use: the protocol's, unless the user asked for a compatible one.

    Args:
        quantize: what the user asked for; None or ``"none"`` means "not asked".

    Raises:
        InputError: the user asked for a step the protocol does not use.
    """
    if quantize in (None, "none"):
        return protocol.quantize
    if protocol.name != "dynaeval" and quantize != protocol.quantize:
        raise InputError(
            f"protocol {protocol.name} uses quantize={protocol.quantize}, not {quantize}: drop "
            "--quantize, or use --protocol dynaeval to choose the 8-bit step yourself"
        )
    return quantize


def check_lpips_net(protocol: Protocol, net: str) -> None:
    """Raise InputError when ``net`` is not an LPIPS backbone the protocol reports."""
    if protocol.name != "dynaeval" and net not in (protocol.lpips_net, *protocol.lpips_nets):
        raise InputError(
            f"protocol {protocol.name} reports LPIPS with the {protocol.lpips_net} backbone, not "
            f"{net}; drop --lpips-net or use --protocol dynaeval"
        )


def check_background(protocol: Protocol, background: str) -> None:
    """Raise InputError when the protocol blends RGBA ground truth over another background."""
    if protocol.background is not None and background != protocol.background:
        raise InputError(
            f"protocol {protocol.name} blends RGBA ground truth over {protocol.background}, not "
            f"{background}; drop --background or use --protocol dynaeval"
        )


def run_metrics(protocol: Protocol, names: tuple[str, ...]) -> tuple[str, ...]:
    """The per-frame metrics of a run: those asked for, then the protocol's own (``metrics``)."""
    return (*names, *(m for m in protocol.metrics if m not in names))

"""The protocol interface: what one evaluator changes in dynaeval's numbers, as one class.

A protocol (``--protocol NAME``, ``dynaeval.metrics.protocols``) is a subclass of ``Protocol``
with one instance in the registry ``dynaeval.metrics.protocols.PROTOCOLS``. Its class attributes
(``SETTINGS``) are what it records in the results (``describe()``); its methods are everything the
rest of dynaeval asks of it: the 8-bit step and the checks of a run's options (``config``,
``plan``, ``ImageMetrics``), the whole-frame PSNR / SSIM / LPIPS / MS-SSIM (the registry's
``build_*``), and what it does with given masks (``apply_masks``, ``mask_regions``). No module
outside the protocol modules reads a setting attribute (``tests/dynaeval/test_architecture.py``):
it calls a method, so a protocol that differs is one class that overrides what differs.

The base class is dynaeval's own behaviour (``--protocol dynaeval``): images as read, PSNR from a
float64 squared error, scikit-image's Gaussian SSIM, the package's LPIPS, torchmetrics' MS-SSIM
(``dynaeval.metrics.multiscale``), masks used for ``masked_*`` only.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.metrics import multiscale, pixel, structural

Pair = tuple[Any, Any]
"""``(pred, gt)``: two images of one shape, (H, W) or (H, W, C)."""
Score = Callable[[Any, Any], float]
"""``(pred, gt) -> value`` of one image pair."""

SETTINGS = ("quantize", "psnr", "ssim", "clip", "lpips_net", "reference", "metrics", "background",
            "choices", "ssim_data_range", "lpips_input", "family", "decode", "masks",
            "lpips_reduce", "msssim", "lpips_nets")
"""The class attributes a protocol records (``describe``); read by its own methods only."""
_OPTIONAL = (("ssim_data_range", "fixed"), ("lpips_input", "signed"), ("family", ""),
             ("decode", "dynaeval"), ("masks", "region"), ("lpips_reduce", "network"),
             ("msssim", "torchmetrics"))
"""Settings written only when they differ from these defaults (the older results unchanged)."""


class Protocol:
    """How one evaluator prepares images and computes the whole-frame metrics (base: dynaeval's).

    Subclasses set ``name`` and ``reference``, the settings that differ, and override the
    methods whose behaviour differs; instances hold no state (one per protocol, registered).
    """

    name: ClassVar[str] = ""
    """A key of ``dynaeval.metrics.protocols.PROTOCOLS``."""
    quantize: ClassVar[str] = "none"
    """8-bit step applied to both images before every metric: ``none`` or ``truncate``."""
    psnr: ClassVar[str] = "float64"
    """Label of ``psnr_of``: ``float64`` (dynaeval), ``float32`` (mean squared error in float32),
    ``3dgs`` (``20 log10(1 / sqrt(MSE))``, all in float32) or ``dycheck``."""
    ssim: ClassVar[str] = "skimage-gaussian"
    """Label of ``ssim_of``: ``skimage-gaussian`` (dynaeval), ``dm_pix`` (valid windows, clamped),
    ``torchmetrics`` (reflect-padded, every window, float32), ``mipnerf`` (K-Planes: valid windows,
    float64 statistics, variances clipped at 0), ``pytorch_msssim`` (valid windows, float32),
    ``3dgs`` (zero-padded, every window, float32) or ``dycheck``."""
    clip: ClassVar[bool] = False
    """Clip images to [0, 1] before PSNR/SSIM (and before LPIPS with a mask, and MS-SSIM)."""
    lpips_net: ClassVar[str] = "alex"
    """The LPIPS backbone the evaluator reports as ``lpips`` (the run's default)."""
    reference: ClassVar[str] = ""
    """Where the definitions come from."""
    metrics: ClassVar[tuple[str, ...]] = ()
    """Per-frame metrics the evaluator reports beyond PSNR/SSIM/LPIPS (registry names): a run
    under this protocol computes them too (``run_metrics``)."""
    background: ClassVar[str | None] = None
    """The background RGBA ground truth is blended over (``white``/``black``), None: any."""
    choices: ClassVar[tuple[tuple[str, str], ...]] = ()
    """Every further choice of the evaluator, ``(what, how and where from)``, for the results."""
    ssim_data_range: ClassVar[str] = "fixed"
    """L of SSIM's constants: ``fixed`` (the run's ``data_range``) or ``image`` (each pair's own
    range, ``max(ptp(pred), ptp(gt))``: torchmetrics called without ``data_range``)."""
    lpips_input: ClassVar[str] = "signed"
    """How [0, 1] images reach the LPIPS network: ``signed`` (mapped to [-1, 1], the package's
    convention) or ``unit`` (given as they are, as 3DGS' ``metrics.py`` does)."""
    family: ClassVar[str] = ""
    """The models whose evaluation code this protocol follows (empty: a tool, not a model)."""
    decode: ClassVar[str] = "dynaeval"
    """16-bit PNG decoding (``dynaeval.io.images.DECODES``): ``dynaeval`` (v / 65535) or
    ``pil`` (the high byte, as Pillow and so NeRFBaselines read them)."""
    masks: ClassVar[str] = "region"
    """What the protocol does with given masks beyond dynaeval's ``masked_*``: ``region``,
    ``multiply`` (whole-frame metrics of the mask-multiplied images) or ``covisible`` (the
    ``m*`` metrics of DyCheck)."""
    lpips_reduce: ClassVar[str] = "network"
    """Whole-frame LPIPS: ``network`` (the package's own spatial average per layer) or
    ``spatial-mean`` (mean of the ``spatial=True`` map, upsampled per layer: DyCheck)."""
    msssim: ClassVar[str] = "torchmetrics"
    """Which MS-SSIM ``msssim``/``dssim`` compute: ``torchmetrics`` (1.9, K-Planes' call:
    ``dynaeval.metrics.multiscale``) or ``pytorch_msssim`` (1.0 ``ms_ssim``, 4DGaussians':
    ``dynaeval.metrics.protocol_3dgs.msssim_4dgaussians``)."""
    lpips_nets: ClassVar[tuple[str, ...]] = ()
    """Other LPIPS backbones the evaluator also reports (``--lpips-net`` may choose them);
    ``lpips_net`` is the default."""

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError(f"protocol {self.name} is constant: subclass it to change {key}")

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self)

    def __hash__(self) -> int:
        return hash(type(self))

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    # -- what the results record -------------------------------------------------------------

    def describe(self) -> dict[str, Any]:
        """Settings for the results JSON: every choice the protocol implies. The settings after
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
        for key, default in _OPTIONAL:
            if getattr(self, key) != default:
                out[key] = getattr(self, key)
        if self.lpips_nets:
            out["lpips_nets"] = list(self.lpips_nets)
        return out

    # -- a run's options, checked and resolved ----------------------------------------------

    def resolve_quantize(self, asked: str | None) -> str:
        """The 8-bit step to use: the protocol's, unless the user asked for a compatible one.

        Args:
            asked: what the user asked for; None or ``"none"`` means "not asked".

        Raises:
            InputError: the user asked for a step the protocol does not use.
        """
        if asked in (None, "none"):
            return self.quantize
        if asked != self.quantize:
            raise InputError(
                f"protocol {self.name} uses quantize={self.quantize}, not {asked}: drop "
                "--quantize, or use --protocol dynaeval to choose the 8-bit step yourself"
            )
        return asked

    def resolve_lpips_net(self, asked: str | None) -> str:
        """The LPIPS backbone of a run: the one asked for, else the protocol's."""
        return asked or self.lpips_net

    def check_lpips_net(self, net: str) -> None:
        """Raise InputError when ``net`` is not an LPIPS backbone the protocol reports."""
        if net not in (self.lpips_net, *self.lpips_nets):
            raise InputError(
                f"protocol {self.name} reports LPIPS with the {self.lpips_net} backbone, not "
                f"{net}; drop --lpips-net or use --protocol dynaeval"
            )

    def check_background(self, background: str) -> None:
        """Raise InputError when the protocol blends RGBA ground truth over another background."""
        if self.background is not None and background != self.background:
            raise InputError(
                f"protocol {self.name} blends RGBA ground truth over {self.background}, not "
                f"{background}; drop --background or use --protocol dynaeval"
            )

    def run_metrics(self, names: tuple[str, ...]) -> tuple[str, ...]:
        """The per-frame metrics of a run: those asked for, then the protocol's own."""
        return (*names, *(m for m in self.metrics if m not in names))

    def decode_rule(self) -> str:
        """How 16-bit PNGs are read under this protocol (``dynaeval.io.images.DECODES``)."""
        return self.decode

    # -- images -------------------------------------------------------------------------------

    def clips_images(self) -> bool:
        """True when the protocol clips both images to [0, 1] before its metrics (itself or by
        its 8-bit step), so float inputs that overshoot the range are accepted
        (``validation.CLIPPED_LIMIT``)."""
        return self.clip or self.quantize != "none"

    def prepare_images(self, pred: Any, gt: Any) -> Pair:
        """Both images after the protocol's 8-bit step (``pixel.quantize``); as given without
        one. (H, W, C) float in [0, 1]."""
        if self.quantize == "none":
            return pred, gt
        return pixel.quantize(pred, self.quantize), pixel.quantize(gt, self.quantize)

    # -- given masks --------------------------------------------------------------------------

    def weighs_whole_frame(self) -> bool:
        """True when the whole-frame metrics use a given mask's weights (``apply_masks``), so
        the registry passes them (``registry.region_argument``)."""
        return False

    def mask_regions(self) -> tuple[str, ...]:
        """The protocol's own region variants over given masks (DyCheck: ``("covisible",)``)."""
        return ()

    def uses_masks(self) -> bool:
        """True when given masks change the protocol's own numbers (beyond ``masked_*``)."""
        return self.weighs_whole_frame() or bool(self.mask_regions())

    def apply_masks(self, pred: Any, gt: Any, weights: Any) -> Pair:
        """The images a whole-frame metric scores given a mask's ``weights`` ((H, W) in [0, 1];
        None: no mask): the images themselves here.

        Raises:
            InputError: weights given to a protocol that does not score with a mask.
        """
        if weights is not None:
            raise InputError(f"protocol {self.name} does not score the whole frame with a mask")
        return pred, gt

    # -- whole-frame metrics ------------------------------------------------------------------

    def check_range(self, data_range: float) -> None:
        """Raise InputError when the protocol clips to [0, 1] and ``data_range`` is another."""
        if self.clip and data_range != 1.0:
            raise InputError(
                f"protocol {self.name} clips images to [0, 1], so it needs data_range=1, got "
                f"{data_range}; scale the images to [0, 1] or use --protocol dynaeval"
            )

    def psnr_of(self, pred: Any, gt: Any, data_range: float) -> float:
        """The protocol's PSNR in dB of one pair (H, W[, C]) in [0, data_range]: dynaeval's
        float64 ``pixel.psnr`` here; ``math.inf`` for identical images."""
        return pixel.psnr(pred, gt, data_range=data_range)

    def ssim_of(self, pred: Any, gt: Any, data_range: float) -> float:
        """The protocol's SSIM of one pair (H, W[, C]) in [0, data_range], in [-1, 1]:
        dynaeval's ``structural.ssim`` here."""
        return structural.ssim(pred, gt, data_range=data_range)

    def whole_psnr(self, pred: Any, gt: Any, *, data_range: float = 1.0,
                   weights: Any = None) -> float:
        """Whole-frame PSNR in dB under this protocol; ``weights``: (H, W) mask in [0, 1], used
        as ``apply_masks`` says."""
        self.check_range(data_range)
        pred, gt = self.apply_masks(pred, gt, weights)
        return self.psnr_of(pred, gt, data_range)

    def whole_ssim(self, pred: Any, gt: Any, *, data_range: float = 1.0,
                   weights: Any = None) -> float:
        """Whole-frame SSIM under this protocol; ``weights`` as in ``whole_psnr``."""
        self.check_range(data_range)
        pred, gt = self.apply_masks(pred, gt, weights)
        return self.ssim_of(pred, gt, data_range)

    def whole_lpips(self, pred: Any, gt: Any, *, score: Score, score_map: Callable[[Any, Any], Any],
                    score_unit: Score, weights: Any = None) -> float:
        """Whole-frame LPIPS under this protocol (>= 0).

        Args:
            pred, gt: (H, W, 3) images in [0, 1].
            score: ``(pred, gt) -> float``, the package's LPIPS (inputs mapped to [-1, 1]);
                score_map: ``(pred, gt) -> (H, W)`` its spatial map; score_unit: the network
                fed the [0, 1] images as they are (``perceptual.lpips_unit_input``).
            weights: as in ``whole_psnr`` (clipped images, then ``apply_masks``).
        """
        if weights is None:
            return score(pred, gt)
        if self.clip:
            pred, gt = np.clip(np.asarray(pred), 0, 1), np.clip(np.asarray(gt), 0, 1)
        return score(*self.apply_masks(pred, gt, weights))

    def whole_msssim(self, pred: Any, gt: Any, *, data_range: float = 1.0) -> float:
        """Whole-frame MS-SSIM in [0, 1]: torchmetrics' (``multiscale.ms_ssim``), clipped when
        the protocol clips. (H, W[, C]) images, at least ``multiscale.MIN_SIZE`` px a side."""
        return multiscale.ms_ssim(pred, gt, data_range=data_range, clip=self.clip)

    def whole_dssim(self, pred: Any, gt: Any, *, data_range: float = 1.0) -> float:
        """Whole-frame D-SSIM ``(1 - MS-SSIM) / 2`` of ``whole_msssim``'s variant, in [0, 0.5]."""
        return multiscale.d_ssim(pred, gt, data_range=data_range, clip=self.clip)

    def msssim_settings(self) -> dict[str, Any]:
        """What the results record of ``whole_msssim``'s variant."""
        return multiscale.torchmetrics_settings(bool(self.clip))


class Float32PsnrProtocol(Protocol):
    """The base of the protocols whose PSNR is ``10 log10(L^2 / MSE)`` of a float32 mean squared
    error (``pixel.psnr_float32``: NeRFBaselines, torchmetrics / nerfstudio, K-Planes), clipped
    first when the protocol clips."""

    psnr = "float32"

    def psnr_of(self, pred: Any, gt: Any, data_range: float) -> float:
        return pixel.psnr_float32(pred, gt, data_range=data_range, clip=self.clip)

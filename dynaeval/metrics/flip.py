"""FLIP (LDR-FLIP, Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"):
whole frame, over the union of boxes, over a mask. Lower is better, in [0, 1], unitless.

The per-pixel map is NVIDIA's own implementation, the ``flip-evaluator`` package (BSD, compiled
C++; ``pip install 'dynaeval[video]'``): ``flip_evaluator.evaluate(reference, test, "LDR",
inputsRGB=True, applyMagma=False, computeMeanError=False, parameters={"ppd": ...})``, called with
the ground truth as the reference and the prediction as the test image, both (H, W, 3) float32
C-contiguous sRGB in [0, 1]. The package's map is an (H, W, 1) float32 array; the value of a
region is the float64 mean of the map over the region's pixels (the package's own mean is a
float32 running sum over the whole frame, off by up to 6e-6 on 512x512 photographs).

What the package computes (read from ``src/cpp/FLIP.h`` of NVlabs/flip v1.7; a float64 numpy
re-implementation from the paper's definition in ``tests/dynaeval/metrics/test_flip.py`` holds
it): sRGB -> linear RGB -> YCxCz opponent space; colour pipeline: contrast-sensitivity filters per
channel (Gaussians in visual degrees, radius ``ceil(3 sqrt(0.04 / (2 pi^2)) ppd)`` px, replicated
border), back to linear RGB clamped to [0, 1], CIE L*a*b* with the Hunt adjustment, HyAB distance
to the power 0.7 redistributed to [0, 1]; feature pipeline: edge and point detectors (first and
second derivatives of a Gaussian of sigma ``0.5 * 0.082 * ppd`` px) on the luminance; the value
is ``colour_error ** (1 - feature_error)``. So a pixel's value depends on the pixels within
``context_radius(ppd)`` px of it (10 px at the default): a region is scored on its bounding box
grown by that radius, which gives the full-frame map's values there bit for bit (tested).

Pixels per degree: FLIP's default, a 0.7 m wide 3840-px display seen from 0.7 m,
``0.7 * 3840 / 0.7 * pi / 180 = 67.02`` (``PIXELS_PER_DEGREE``; the package rounds it to float32,
67.020645), recorded in the results' settings.

Inputs: the unit of a pixel is stated by its dtype, never guessed (``dynaeval.core.validation``,
``to_unit=True``): uint8 / 255, uint16 / 65535, floats as they are and checked in [0, 1] (LDR-FLIP
is defined on display-referred sRGB; values outside are refused, never clipped). Grayscale
``(H, W)`` or ``(H, W, 1)`` is replicated to three equal channels (a grey level v is the sRGB
colour (v, v, v)); other channel counts are refused (composite RGBA over a background first).

Importing this module does not import the package: it is imported on the first map.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from dynaeval.core.deps import MissingDependency, load, missing
from dynaeval.core.errors import InputError
from dynaeval.core.validation import as_image, grey_to_rgb
from dynaeval.metrics._common import region_mask

PIXELS_PER_DEGREE = 0.7 * (3840 / 0.7) * math.pi / 180
"""FLIP's default observer: 0.7 m from a 0.7 m wide display of 3840 px (67.0206 px/degree)."""

VIEWING_CONDITIONS = "0.7 m from a 0.7 m wide 3840-px display (FLIP's default)"

PACKAGE = "flip-evaluator"
"""The PyPI distribution that computes the map (module ``flip_evaluator``)."""

_HINT = "pip install 'dynaeval[video]'"

# Largest CSF scale parameter (the blue-yellow channel's b1 = 0.04 deg^2) and the feature
# detector's peak-to-trough width (0.082 deg): they fix how far a pixel's value reaches.
_CSF_MAX_SCALE = 0.04
_FEATURE_WIDTH = 0.082


def check_pixels_per_degree(pixels_per_degree: object) -> float:
    """``pixels_per_degree`` as a positive finite float; InputError otherwise (the package
    would end the process on a value <= 0)."""
    ok = isinstance(pixels_per_degree, numbers.Real) and not isinstance(pixels_per_degree, bool)
    value = float(pixels_per_degree) if ok else math.nan  # type: ignore[arg-type]
    if not math.isfinite(value) or value <= 0:
        raise InputError(
            f"pixels_per_degree must be a positive number (FLIP's default {PIXELS_PER_DEGREE:.2f}: "
            f"{VIEWING_CONDITIONS}), got {pixels_per_degree!r}"
        )
    return value


def context_radius(pixels_per_degree: float = PIXELS_PER_DEGREE) -> int:
    """Pixels on each side that a FLIP value depends on: the larger of the colour filters'
    radius ``ceil(3 sqrt(0.04 / (2 pi^2)) ppd)`` and the feature filters' ``ceil(3 * 0.5 *
    0.082 * ppd)`` (10 and 9 px at the default; the package computes them in float32, one more
    pixel is kept for that)."""
    ppd = check_pixels_per_degree(pixels_per_degree)
    colour = math.ceil(3.0 * math.sqrt(_CSF_MAX_SCALE / (2.0 * math.pi**2)) * ppd)
    feature = math.ceil(3.0 * 0.5 * _FEATURE_WIDTH * ppd)
    return max(colour, feature) + 1


_ABSENT = f"FLIP needs NVIDIA's {PACKAGE} package, which is not installed: {_HINT}"


def _package() -> Any:
    """The ``flip_evaluator`` module; ImportError saying what to install when it is absent."""
    try:
        return load("flip_evaluator")
    except MissingDependency as err:
        if err.installed:
            raise
        raise err.saying(_ABSENT) from err


def missing_package(ctx: Any = None) -> str | None:
    """Why FLIP cannot run on this machine (with the install line), or None when its package is
    there; found without importing it (the registry's ``requires``)."""
    return _ABSENT if missing("flip_evaluator") else None


def _rgb(x: object, name: str) -> np.ndarray:
    """One image as (H, W, 3) float32 sRGB in [0, 1] (grayscale replicated)."""
    arr = as_image(x, name, to_unit=True, check_range=True)
    return grey_to_rgb(arr, name, "FLIP")


def _pair(pred: object, gt: object) -> tuple[np.ndarray, np.ndarray]:
    p, g = _rgb(pred, "pred"), _rgb(gt, "gt")
    if p.shape != g.shape:
        raise InputError(
            f"pred and gt must have the same shape, got pred {p.shape} and gt {g.shape}; "
            "render the prediction at the ground truth's resolution"
        )
    return p, g


def _map(p: np.ndarray, g: np.ndarray, ppd: float) -> np.ndarray:
    """The package's map of checked (H, W, 3) float32 images: (H, W) float32.

    Its binding takes only writeable C-contiguous float32 arrays (it refuses read-only ones,
    such as the frame cache's, with a TypeError; it never writes to them): others are copied.
    """
    reference, test = (np.require(x, np.float32, ("C", "W")) for x in (g, p))
    emap, _, _ = _package().evaluate(
        reference, test, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=False,
        parameters={"ppd": ppd},
    )
    return np.asarray(emap)[..., 0]


def flip_map(
    pred: object, gt: object, *, pixels_per_degree: float = PIXELS_PER_DEGREE
) -> np.ndarray:
    """Per-pixel LDR-FLIP error map of ``pred`` against ``gt`` (the reference).

    Args:
        pred, gt: (H, W, 3) sRGB or (H, W) / (H, W, 1) grayscale numpy arrays or torch tensors of
            equal shape: float in [0, 1] (checked) or uint8 / uint16 (divided by 255 / 65535).
        pixels_per_degree: the observer, pixels per degree of visual angle (default: FLIP's,
            ``PIXELS_PER_DEGREE`` = 67.02).

    Returns:
        (H, W) float32 map in [0, 1], unitless, 0 where the images agree; lower is better.

    Raises:
        InputError: shapes differ, channels other than 1 or 3, float values outside [0, 1],
            NaN/Inf pixels, a non-positive ``pixels_per_degree``.
        ImportError: the ``flip-evaluator`` package is not installed.
    """
    ppd = check_pixels_per_degree(pixels_per_degree)
    p, g = _pair(pred, gt)
    return _map(p, g, ppd)


def flip(
    pred: object,
    gt: object,
    *,
    mask: object = None,
    boxes: object = None,
    pixels_per_degree: float = PIXELS_PER_DEGREE,
) -> float:
    """Mean LDR-FLIP error over the whole image, the union of boxes, or a mask; lower is better.

    Args:
        pred, gt: as ``flip_map``: (H, W, 3) sRGB or grayscale, float in [0, 1] or uint8/uint16.
        mask: optional bool (H, W): mean of the map over the masked pixels (divided by their
            count, never by the frame's).
        boxes: optional (N, 4) int ``[x_min, y_min, x_max, y_max]``, max exclusive, clipped to
            the image: mean of the map over the union of the boxes, each pixel once. Not together
            with ``mask``.
        pixels_per_degree: see ``flip_map``.

    The map of a region is the whole frame's map there: the filters see the real pixels around
    the region (only the region's bounding box grown by ``context_radius`` is computed).

    Returns:
        Mean FLIP error as a Python float in [0, 1] (0 for identical images), float64 mean.

    Raises:
        InputError: as ``flip_map``, and a bad mask/boxes or both given.
        EmptyRegionError: the mask or boxes hold no pixel.
        ImportError: the ``flip-evaluator`` package is not installed.
    """
    ppd = check_pixels_per_degree(pixels_per_degree)
    p, g = _pair(pred, gt)
    h, w = p.shape[:2]
    m = region_mask(mask, boxes, h, w)
    if m is None:
        return float(_map(p, g, ppd).mean(dtype=np.float64))
    rows = np.flatnonzero(m.any(axis=1))
    cols = np.flatnonzero(m.any(axis=0))
    r = context_radius(ppd)
    y0, y1 = max(int(rows[0]) - r, 0), min(int(rows[-1]) + 1 + r, h)
    x0, x1 = max(int(cols[0]) - r, 0), min(int(cols[-1]) + 1 + r, w)
    window = _map(p[y0:y1, x0:x1], g[y0:y1, x0:x1], ppd)
    return float(window[m[y0:y1, x0:x1]].mean(dtype=np.float64))


def build_flip(ctx: Any) -> Any:
    """The registry's FLIP for a run (``dynaeval.metrics.registry.FrameContext``): checks the
    package is importable now (``ImportError`` with the install line: the registry reports FLIP
    unavailable; a run that asked for it was refused before by ``missing_package``);
    images in [0, data_range] are scaled to [0, 1]; the region as ``flip``."""
    _package()
    scale = 1.0 / ctx.data_range
    ppd = _pixels_per_degree(ctx)

    def fn(pred: np.ndarray, gt: np.ndarray, region: dict[str, Any]) -> float:
        if scale != 1.0:
            pred, gt = np.asarray(pred) * scale, np.asarray(gt) * scale
        return flip(pred, gt, pixels_per_degree=ppd, **region)

    return fn


def _pixels_per_degree(ctx: Any) -> float:
    """The run's pixels per degree (``metric_options={"flip": {"pixels_per_degree": ...}}``)."""
    return check_pixels_per_degree(ctx.option("flip", "pixels_per_degree", PIXELS_PER_DEGREE))


def flip_settings(ctx: Any, enabled: bool, unavailable: str | None) -> dict[str, Any] | None:
    """What the results record of FLIP (None when it was not asked for): the variant, the
    observer, the package and how regions are reduced."""
    if not enabled and unavailable is None:
        return None
    out: dict[str, Any] = {
        "enabled": enabled,
        "variant": "LDR-FLIP (sRGB input, ground truth as the reference)",
        "pixels_per_degree": _pixels_per_degree(ctx),
        "viewing_conditions": (VIEWING_CONDITIONS if _pixels_per_degree(ctx) == PIXELS_PER_DEGREE
                               else "set by the user (pixels_per_degree)"),
        "regions": "mean of the whole frame's FLIP map over the union of the boxes (focused) "
                   "or the mask's pixels (masked)",
        "every": ctx.option("flip", "every", 1),
        "frames": ("every frame" if ctx.option("flip", "every", 1) == 1 else
                   f"frames whose index is a multiple of {ctx.option('flip', 'every', 1)} "
                   "(the others have no value; summaries are means over the scored frames)"),
    }
    if unavailable is not None:
        out["unavailable"] = unavailable
    if enabled:
        from importlib.metadata import version

        out["package"] = f"{PACKAGE} {version(PACKAGE)}"
    return out

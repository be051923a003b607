"""JOD of a camera's video: ColorVideoVDP (Mantiuk et al. 2024), or FovVideoVDP (Mantiuk et al.
2021) as the DyNeRF-era tables report it. Higher is better, in JOD (just-objectionable
differences), 10 = identical, unbounded below.

One value per camera: the prediction's frame sequence against the ground truth's, played at the
camera's frame rate on a display model (default ``standard_fhd``: a 24-inch 1920x1080 monitor of
200 cd/m^2 in a 250 lux office, seen from 0.6 m). The number is the package's own:

* ``cvvdp`` (default): the ``cvvdp`` package (MIT, ships its calibrated parameters),
  ``pycvvdp.cvvdp(display_name=display, device=...)``, ``.predict_video_source(...)``;
* ``fvvdp``: the ``pyfvvdp`` package (CC BY-NC 4.0: non-commercial use only),
  ``pyfvvdp.fvvdp(display_name=display, device=...)`` — what K-Planes' evaluation runs
  (``fvvdp --display standard_fhd`` on an mp4 of the frames at 30 fps; here the decoded frames are
  passed directly, without the mp4 step, which is lossy).

Frames reach the package one at a time through a video source (``_sources``) that reads them on
demand, so a camera's clip is never held whole in memory; each frame is the package's input
``(1, 3, 1, H, W)`` float32, display-encoded sRGB in [0, 1], exactly what ``.predict(test, ref,
dim_order="FHWC", frames_per_second=fps)`` gives the same model for the stacked frames (a test
holds the two equal). SDR input: the display model maps the sRGB values through its EOTF to
cd/m^2, so values are display-encoded in [0, 1] (uint8 / 255, uint16 / 65535, floats checked in
[0, 1], never clipped here; ``dynaeval.core.validation``'s rule); grayscale is replicated to RGB.

Focused JOD: video metrics need one frame size for the clip, so the focused variant scores a fixed
window per camera (``focus_window``): the bounding box of the union of every frame's focus boxes
(already expanded, clipped and merged by the run's focus rule, the same pixels ``focused_psnr``
scores), grown to at least ``MIN_WINDOW`` pixels per side around its centre and kept inside the
frame (``dynaeval.core.boxes.grow_box``). No masked variant: see docs/metrics.md ("JOD", why not).

Importing this module imports neither torch nor the packages: they are imported when a model is
built.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from dynaeval.core.boxes import as_boxes, clip_boxes, grow_box
from dynaeval.core.deps import MissingDependency, load, missing
from dynaeval.core.errors import EmptyRegionError, InputError
from dynaeval.core.validation import as_image, grey_to_rgb

MODELS = {"cvvdp": ("cvvdp", "pycvvdp"), "fvvdp": ("pyfvvdp", "pyfvvdp")}
"""JOD model -> (PyPI distribution, module)."""

MODEL_NAMES = {"cvvdp": "ColorVideoVDP", "fvvdp": "FovVideoVDP"}

DEFAULT_MODEL = "cvvdp"
DEFAULT_DISPLAY = "standard_fhd"
DEFAULT_FPS = 30.0
"""Frame rate of a camera given as image files (a video file's own rate is used)."""

MIN_WINDOW = 64
"""Smallest side of the focused window, px (a box of a few pixels is grown to this)."""

HINTS = {"cvvdp": "pip install 'dynaeval[video]'", "fvvdp": "pip install 'dynaeval[fvvdp]'"}
"""What to install per model (pyfvvdp is non-commercial, so it has an extra of its own)."""


def check_model(model: object) -> str:
    if model not in MODELS:
        raise InputError(f"jod model must be one of {', '.join(MODELS)}, got {model!r}")
    return str(model)


def check_fps(fps: object) -> float:
    """``fps`` as a positive finite float; InputError otherwise."""
    ok = isinstance(fps, numbers.Real) and not isinstance(fps, bool)
    value = float(fps) if ok else math.nan  # type: ignore[arg-type]
    if not math.isfinite(value) or value <= 0:
        raise InputError(f"fps: frames per second must be a positive number, got {fps!r}")
    return value


def _absent(model: str, missing: str | None = None) -> str:
    """The message for ``model``'s package (or its dependency ``missing``) being absent, with
    the install line of that model (``HINTS``)."""
    dist, name = MODELS[model]
    what = ("is not installed" if missing in (None, name) else
            f"cannot be imported (its dependency {missing} is missing)")
    return f"JOD ({MODEL_NAMES[model]}) needs the {dist} package, which {what}: {HINTS[model]}"


def _module(model: str) -> Any:
    """The package of ``model``; ImportError saying what to install when it is absent."""
    name = MODELS[check_model(model)][1]
    try:
        return load(name)
    except MissingDependency as err:
        raise err.saying(_absent(model, err.name)) from err


def missing_package(ctx: Any) -> str | None:
    """Why the run's JOD model (option ``jod.model``) cannot run on this machine, with its
    install line (``dynaeval[fvvdp]`` for FovVideoVDP), or None when its package and torch are
    there; found without importing them (the registry's ``requires``)."""
    model = check_model(ctx.option("jod", "model", DEFAULT_MODEL))
    absent = missing(MODELS[model][1], "torch")
    return _absent(model, absent[0]) if absent else None


def load_model(model: str = DEFAULT_MODEL, display: str = DEFAULT_DISPLAY,
               device: str = "cpu") -> Any:
    """The package's metric object for ``display`` on ``device`` (a torch device name).

    Raises:
        ImportError: the package (or torch) is not installed.
        InputError: an unknown model or display name.
    """
    torch = load("torch")

    mod = _module(model)
    known = _display_names(mod, model)
    if display not in known:
        raise InputError(f"unknown display model {display!r} for {MODEL_NAMES[model]}; known: "
                         f"{', '.join(sorted(known))}")
    cls = mod.cvvdp if model == "cvvdp" else mod.fvvdp
    return cls(display_name=display, device=torch.device(device), quiet=True)


def _display_names(mod: Any, model: str) -> set[str]:
    """Display models the package ships (its ``display_models.json``)."""
    import json
    from pathlib import Path

    folder = "vvdp_data" if model == "cvvdp" else "fvvdp_data"
    path = Path(mod.__file__).parent / folder / "display_models.json"
    return set(json.loads(path.read_text()))


def _frame(frames: Sequence[Any], i: int, name: str) -> np.ndarray:
    """Frame ``i`` of ``frames`` as (H, W, 3) float32 sRGB in [0, 1] (checked)."""
    arr = as_image(frames[i], f"{name} frame {i}", to_unit=True, check_range=True)
    return grey_to_rgb(arr, f"{name} frame {i}", "JOD").astype(np.float32, copy=False)


def _sources(metric: Any, model: str, read: Callable[[str, int], np.ndarray],
             size: tuple[int, int, int], fps: float) -> Any:
    """A video source of the package that asks ``read("test"|"reference", i)`` for frame i."""
    torch = load("torch")

    def tensor(kind: str, i: int, device: Any) -> Any:
        t = torch.tensor(read(kind, i)).permute(2, 0, 1)[None, :, None]  # (1, 3, 1, H, W), a copy
        return t.to(device)

    class Clip:
        def get_video_size(self):  # noqa: ANN202
            return size

        def get_frames_per_second(self):  # noqa: ANN202
            return fps

    if model == "cvvdp":
        video_source_dm = load("pycvvdp.video_source").video_source_dm

        class Source(Clip, video_source_dm):  # type: ignore[misc, valid-type]
            def get_test_frame(self, i, device, colorspace):  # noqa: ANN001, ANN202
                return self.apply_dm_and_color_transform(tensor("test", i, device), colorspace)

            def get_reference_frame(self, i, device, colorspace):  # noqa: ANN001, ANN202
                return self.apply_dm_and_color_transform(tensor("reference", i, device), colorspace)
    else:
        fvvdp_video_source_dm = load("pyfvvdp.video_source").fvvdp_video_source_dm

        class Source(Clip, fvvdp_video_source_dm):  # type: ignore[misc, valid-type, no-redef]
            def _lum(self, t):  # noqa: ANN001, ANN202
                lin, w = self.dm_photometry.forward(t), self.color_to_luminance
                return lin[:, 0:1] * w[0] + lin[:, 1:2] * w[1] + lin[:, 2:3] * w[2]

            def get_test_frame(self, i, device=None):  # noqa: ANN001, ANN202
                return self._lum(tensor("test", i, device))

            def get_reference_frame(self, i, device=None):  # noqa: ANN001, ANN202
                return self._lum(tensor("reference", i, device))

    return Source(display_photometry=metric.display_photometry)


def jod(
    pred: Sequence[Any],
    gt: Sequence[Any],
    *,
    fps: float = DEFAULT_FPS,
    model: str = DEFAULT_MODEL,
    display: str = DEFAULT_DISPLAY,
    window: object = None,
    metric: Any = None,
    device: str = "cpu",
) -> float:
    """JOD of the video ``pred`` against the reference video ``gt``; higher is better.

    Args:
        pred, gt: sequences of F frames (lists, or (F, H, W[, C]) arrays; any object with
            ``len`` and ``[i]``; frames are read when the package asks for them, in order):
            (H, W, 3) sRGB or grayscale,
            float in [0, 1] (checked) or uint8 / uint16; every frame of both the same size.
        fps: frames per second the clip is played at (> 0).
        model: ``cvvdp`` (ColorVideoVDP) or ``fvvdp`` (FovVideoVDP).
        display: the package's display model (``standard_fhd``, ``standard_4k``, ...).
        window: optional ``[x_min, y_min, x_max, y_max]`` (max exclusive): score only that
            fixed window of every frame (``focus_window``).
        metric: a model from ``load_model`` to reuse (its model/display then win).
        device: torch device of a model built here.

    Returns:
        JOD as a Python float, 10.0 for identical clips, lower for visible differences.

    Raises:
        InputError: no frame, different counts or sizes, bad pixels, bad fps/model/display/window.
        ImportError: the model's package (or torch) is not installed.
    """
    torch = load("torch")

    fps = check_fps(fps)
    n = len(pred)
    if n == 0 or len(gt) != n:
        raise InputError(f"pred and gt must hold the same number (>= 1) of frames, got {n} and "
                         f"{len(gt)}")
    first = _frame(gt, 0, "gt")
    win = None if window is None else _check_window(window, *first.shape[:2])
    shape = first.shape if win is None else (win[3] - win[1], win[2] - win[0], 3)
    frames = {"test": pred, "reference": gt}

    def read(kind: str, i: int) -> np.ndarray:
        arr = _frame(frames[kind], i, "pred" if kind == "test" else "gt")
        if arr.shape != first.shape:
            raise InputError(f"{'pred' if kind == 'test' else 'gt'} frame {i} is "
                             f"{arr.shape[1]}x{arr.shape[0]} px, gt frame 0 is "
                             f"{first.shape[1]}x{first.shape[0]}: a video has one frame size")
        return arr if win is None else arr[win[1]:win[3], win[0]:win[2]]

    metric = metric if metric is not None else load_model(model, display, device)
    kind = "cvvdp" if type(metric).__module__.startswith("pycvvdp") else "fvvdp"
    src = _sources(metric, kind, read, (shape[0], shape[1], n), fps)
    with torch.no_grad():
        q, _ = metric.predict_video_source(src)
    return float(q)


def _check_window(window: object, height: int, width: int) -> tuple[int, int, int, int]:
    box = as_boxes(window)
    if box.shape != (1, 4):
        raise InputError(f"window must be one box [x_min, y_min, x_max, y_max], got {window!r}")
    clipped = clip_boxes(box, height, width)
    if len(clipped) == 0:
        raise EmptyRegionError(f"window {window!r} holds no pixel of a {width}x{height} frame")
    x0, y0, x1, y1 = (int(v) for v in clipped[0])
    return x0, y0, x1, y1


def focus_window(boxes: Sequence[object | None], height: int, width: int, *,
                 min_size: int = MIN_WINDOW) -> np.ndarray:
    """The fixed window of a clip's focused JOD: the bounding box of every frame's boxes
    (frames without boxes, None, add nothing), grown to at least ``min_size`` px per side
    around its centre and shifted to stay inside the ``height x width`` frame (the whole frame
    along a side shorter than ``min_size``).

    Args:
        boxes: per frame, (N, 4) ``[x_min, y_min, x_max, y_max]`` boxes (max exclusive) or None.
        height, width: the frame size (boxes are clipped to it).
        min_size: the smallest side of the window, px (>= 1).

    Returns:
        (4,) int64 ``[x_min, y_min, x_max, y_max]``.

    Raises:
        EmptyRegionError: no frame has a box inside the frame.
    """
    found = [clip_boxes(b, height, width) for b in boxes if b is not None]  # drops empty boxes
    allb = np.concatenate(found) if found else np.zeros((0, 4), np.int64)
    if len(allb) == 0:
        raise EmptyRegionError("no frame of the camera has a focus box: no focused window")
    union = np.array([allb[:, 0].min(), allb[:, 1].min(), allb[:, 2].max(), allb[:, 3].max()])
    return grow_box(union, min_size, min_size, height, width)


def build_jod(ctx: Any) -> Any:
    """The registry's JOD for a run (``dynaeval.metrics.registry.FrameContext``): builds the
    model now (``ImportError`` when the package is absent: the run reports JOD unavailable and
    goes on; ``InputError`` for an unknown model or display). Returns ``fn(pred_frames,
    gt_frames, fps, region)`` with region ``{}`` or ``{"boxes": [per-frame boxes or None]}``;
    frames in [0, data_range] are scaled to [0, 1]."""
    model = check_model(ctx.option("jod", "model", DEFAULT_MODEL))
    _module(model)
    metric = load_model(model, ctx.option("jod", "display", DEFAULT_DISPLAY), ctx.device)
    min_size = _min_window(ctx)
    scale = 1.0 / ctx.data_range

    def fn(pred: Sequence[Any], gt: Sequence[Any], fps: float, region: dict[str, Any]) -> float:
        if scale != 1.0:
            pred, gt = _Scaled(pred, scale), _Scaled(gt, scale)
        window = None
        if "boxes" in region:
            h, w = np.asarray(gt[0]).shape[:2]
            window = focus_window(region["boxes"], h, w, min_size=min_size)
        return jod(pred, gt, fps=fps, metric=metric, window=window)

    return fn


class _Scaled:
    """A frame sequence with every frame multiplied by ``scale`` (read on demand)."""

    def __init__(self, frames: Sequence[Any], scale: float) -> None:
        self.frames, self.scale = frames, scale

    def __len__(self) -> int:
        return len(self.frames)

    def __getitem__(self, i: int) -> np.ndarray:
        return np.asarray(self.frames[i], np.float32) * np.float32(self.scale)


def _min_window(ctx: Any) -> int:
    value = ctx.option("jod", "min_window", MIN_WINDOW)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(f"jod.min_window must be an integer >= 1, got {value!r}")
    return value


def jod_settings(ctx: Any, enabled: bool, unavailable: str | None) -> dict[str, Any] | None:
    """What the results record of JOD (None when it was not asked for)."""
    if not enabled and unavailable is None:
        return None
    model = ctx.option("jod", "model", DEFAULT_MODEL)
    out: dict[str, Any] = {
        "enabled": enabled,
        "model": model,
        "display": ctx.option("jod", "display", DEFAULT_DISPLAY),
        "fps": ctx.fps,
        "frames_per_second": f"a video file's own frame rate, else {ctx.fps:g} (fps)",
        "input": "display-encoded sRGB in [0, 1], the ground truth as the reference",
        "focused_window": "bounding box of the union of the camera's focus boxes over the clip, "
                          f"grown to at least {_min_window(ctx)} px per side, inside the frame",
        "min_window": _min_window(ctx),
        "masked": "not reported (see docs/metrics.md, JOD)",
    }
    if unavailable is not None:
        out["unavailable"] = unavailable
    if enabled:
        from importlib.metadata import version

        dist = MODELS[model][0]
        out["package"] = f"{dist} {version(dist)}"
    return out

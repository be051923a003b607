"""K-Planes' evaluation files: the stacked video (or PNG) its trainers write at each evaluation.

What K-Planes writes (sarafridov/K-Planes: ``plenoxels/runners/base_trainer.py``
``evaluate_metrics``, ``video_trainer.py`` ``validate``, ``ops/image/io.py``
``write_video_to_file``), read for the facts:

* per test image, ``torch.cat((pred, gt, err), dim=0)``: three parts stacked **vertically**, top
  to bottom the prediction (clamped to [0, 1]), the ground truth (RGBA blended over white) and a
  grey error map (``|pred - gt|`` averaged over the channels, ``(e - min) / max``). Depth is
  **not** in it: the video trainer writes it to its own ``step<N>-depth.mp4``. Without ground
  truth (``--render-only``) the frame is the prediction alone and cannot be scored;
* the stack is taken to 8 bit by truncation (``(x * 255).byte()``) and written to
  ``<log_dir>/step<N>.mp4`` with OpenCV's ``mp4v`` (MPEG-4 part 2, lossy, 30 fps); the static and
  phototourism trainers write one ``step<N>-<i>.png`` per test image instead;
* K-Planes re-scores such a video itself (``utils/eval_model_metrics.py``): rows
  ``[0, H // 3)`` are the prediction, ``[H // 3, 2 H // 3)`` the ground truth.

The metrics K-Planes logs (``test_metrics_step<N>.csv``) are computed on the float render, before
the 8-bit step and the encoding: numbers read back from the mp4 are not comparable to them (a
warning says so). OpenCV's ``mp4v`` encoder drops the last row (and column) of an odd-sized
frame, so a stack of odd height ``3h`` decodes as ``3h - 1`` rows: its prediction and ground
truth are intact and are read (rows ``[0, h)`` and ``[h, 2h)``), with a warning; K-Planes' own
``H // 3`` split is one row off on such a file.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import note
from dynaeval.io.frames import FramePair, FrameRef, Pairing
from dynaeval.io.images import IMAGE_EXTENSIONS, read_image, to_float
from dynaeval.io.video import VIDEO_EXTENSIONS, read_video_frame, scan_video

STACK_PARTS = ("prediction", "ground truth", "error map")
"""The parts of a K-Planes evaluation frame, top to bottom."""
STACK_NAME = re.compile(r"^step(\d+)(-\d+)?$")
"""File stem of an evaluation stack: ``step30000`` (video) or ``step30000-7`` (PNG)."""
DEPTH_NAME = re.compile(r"^step\d+(-\d+)?-depth$")


def is_stack_file(path: str | Path) -> bool:
    """True for a file named as K-Planes names its evaluation stacks (``step<N>.mp4``,
    ``step<N>-<i>.png``, or the depth files next to them)."""
    p = Path(path)
    ext = p.suffix.lower()
    return (p.is_file() and ext in (VIDEO_EXTENSIONS | IMAGE_EXTENSIONS)
            and bool(STACK_NAME.match(p.stem) or DEPTH_NAME.match(p.stem)))


@dataclass(frozen=True)
class StackedFrameRef(FrameRef):
    """One part of a vertically stacked frame (a video frame, or an image file)."""

    part: int = 0
    """0: prediction, 1: ground truth (``STACK_PARTS``)."""
    rows: int = 0
    """Height of one part in pixels (the frame's first ``3 * rows`` rows are the stack)."""

    @property
    def image_file(self) -> None:
        """None: a part of a file, not a whole image (``FrameRef.image_file``)."""
        return None

    def read(self, background: str | float = "white", decode: str = "dynaeval") -> np.ndarray:
        """The part as (rows, W, C) float32 in [0, 1]; ``decode``: the 16-bit PNG rule of
        ``dynaeval.io.images.read_image``."""
        if self.index is None:
            full = read_image(self.path, background=background, decode=decode)
        else:
            full = read_video_frame(self.path, self.index)
        part = full[self.part * self.rows:(self.part + 1) * self.rows]
        return to_float(np.ascontiguousarray(part), path=self.path)

    def __str__(self) -> str:
        where = str(self.path) if self.index is None else f"{self.path}#{self.index}"
        return f"{where} ({STACK_PARTS[self.part]})"


def _frame_size(path: Path, is_video: bool) -> tuple[int, int]:
    """(height, width) of the file's frames, read before any scoring."""
    if not is_video:
        return tuple(read_image(path).shape[:2])  # type: ignore[return-value]
    import cv2

    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise InputError("cannot open video file", path=path)
        return int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    finally:
        cap.release()


def part_rows(height: int, path: Path, is_video: bool) -> tuple[int, str | None]:
    """Rows of one part of a stack of ``height`` rows, and a warning when the encoder cut a row.

    Raises:
        InputError: the height is not three parts (naming the file).
    """
    if height % 3 == 0 and height >= 3:
        return height // 3, None
    if is_video and height % 3 == 2:
        rows = (height + 1) // 3
        return rows, (f"{path}: {height} rows, one less than 3 x {rows}: the mp4v encoder drops "
                      "the last row of an odd-height frame, so the error map lost its last row; "
                      f"prediction (rows 0-{rows - 1}) and ground truth (rows {rows}-"
                      f"{2 * rows - 1}) are intact and scored")
    raise InputError(
        f"a K-Planes evaluation frame stacks {', '.join(STACK_PARTS)} vertically, so its height "
        f"is 3 x the image's; this file's frames are {height} rows high, not a multiple of 3 "
        "(not a K-Planes evaluation stack, or cropped after it was written)",
        path=path,
    )


def _lossy_warning(path: Path, is_video: bool) -> str:
    if is_video:
        return (f"{path.name} is K-Planes' evaluation video: 8-bit (truncated) and MPEG-4 "
                "compressed (lossy), so these numbers are not comparable to the psnr/ssim/ms-ssim "
                "K-Planes logged (test_metrics_step<N>.csv), which were computed on the float "
                "render before encoding; they are what its eval_video_metrics gives from the video")
    return (f"{path.name} is a K-Planes evaluation PNG: 8-bit by truncation ((x * 255).byte()), "
            "so these numbers differ slightly from the ones K-Planes logged on the float render")


GREY_TOLERANCE = 12 / 255
"""Largest mean channel spread (|R - G| + |G - B|, in [0, 1] units) of a grey error map after
lossy coding: measured 5/255 for a grey part through OpenCV's mp4v, against 19-107/255 for
scikit-image's colour photos and their 60 x 70 crops."""


def _grey_warning(path: Path, is_video: bool, rows: int) -> str | None:
    """A warning when the first frame's third part is not grey (then it is no K-Planes error map,
    and the file is likely not a K-Planes stack)."""
    frame = read_video_frame(path, 0) if is_video else read_image(path)
    third = np.asarray(frame[2 * rows:], np.float32)
    if third.ndim < 3 or third.shape[2] < 3:
        return None
    if np.issubdtype(frame.dtype, np.integer):
        third /= np.iinfo(frame.dtype).max
    spread = float(np.mean(np.abs(third[..., 0] - third[..., 1]) + np.abs(third[..., 1] - third[..., 2])))
    if spread <= GREY_TOLERANCE:
        return None
    return (f"{path}: the bottom third of the first frame is not grey (mean channel spread "
            f"{spread * 255:.1f}/255), but K-Planes' third part is a grey error map: check that "
            "this file stacks prediction, ground truth and error map (top to bottom)")


def check_stack(path: str | Path) -> tuple[int, list[str]]:
    """Check a K-Planes stack file before scoring: (rows of one part, warnings).

    Raises:
        InputError: a depth file, an unreadable file, or a height that is not three parts.
    """
    path = Path(path)
    if DEPTH_NAME.match(path.stem):
        raise InputError(
            "this is K-Planes' depth output (step<N>-depth), which holds no ground truth; "
            f"score the stack next to it, {path.name.replace('-depth', '')}",
            path=path,
        )
    is_video = path.suffix.lower() in VIDEO_EXTENSIONS
    height, _ = _frame_size(path, is_video)
    rows, cut = part_rows(height, path, is_video)
    notes = (cut, _grey_warning(path, is_video, rows), _lossy_warning(path, is_video))
    return rows, [w for w in notes if w]


def latest_stacks(folder: str | Path) -> list[Path]:
    """The stack files of a K-Planes log folder's latest evaluation: the ``step<N>.mp4`` of the
    highest N, else every ``step<N>-<i>.png`` of the highest N (in order of i); [] if none."""
    videos: dict[int, Path] = {}
    images: dict[int, list[tuple[int, Path]]] = {}
    for p in sorted(Path(folder).iterdir()):
        m = STACK_NAME.match(p.stem)
        if not m or not p.is_file() or p.name.startswith("."):
            continue
        ext = p.suffix.lower()
        if ext in VIDEO_EXTENSIONS and m.group(2) is None:
            videos[int(m.group(1))] = p
        elif ext in IMAGE_EXTENSIONS and m.group(2) is not None:
            images.setdefault(int(m.group(1)), []).append((int(m.group(2)[1:]), p))
    if videos:
        return [videos[max(videos)]]
    return [p for _, p in sorted(images[max(images)])] if images else []


def pair_stack(path: str | Path) -> Pairing:
    """The (prediction, ground truth) pairs of a K-Planes stack file, or of a log folder's latest
    stacks (``latest_stacks``): one camera, named after the video (``step30000``) or the step of
    the PNGs; one frame per video frame or PNG.

    Raises:
        InputError: as ``check_stack``, a damaged video with no decodable frame, or a folder
            with no stack.
    """
    path = Path(path)
    files = latest_stacks(path) if path.is_dir() else [path]
    if not files:
        raise InputError("no K-Planes evaluation stack (step<N>.mp4, step<N>-<i>.png) here", path=path)
    pairs: list[FramePair] = []
    warnings: list[dict] = []
    for n, file in enumerate(files):
        rows, notes = check_stack(file)
        if n == 0:  # the notes of a PNG set are the same for each file
            warnings += [note(w) for w in notes]
        if file.suffix.lower() in VIDEO_EXTENSIONS:
            camera, scan = file.stem, scan_video(file)
            if scan.problem():
                warnings.append(note(f"{file}: {scan.problem()}", camera=camera))
            frames: list[tuple[str, int | None]] = [(str(i), i) for i in range(scan.n_frames)]
        elif len(files) > 1:  # a folder's PNG set: camera step<N>, frames by test image i
            m = STACK_NAME.match(file.stem)
            camera, frames = f"step{m.group(1)}", [(m.group(2)[1:], None)]
        else:
            camera, frames = file.stem, [("0", None)]
        pairs += [FramePair(camera, name, len(pairs) + k, StackedFrameRef(file, i, part=0, rows=rows),
                            StackedFrameRef(file, i, part=1, rows=rows))
                  for k, (name, i) in enumerate(frames)]
    return Pairing(pairs=pairs, warnings=warnings)


def describe_stack(pairing: Pairing) -> dict:
    """How a stack file was read, for the results' ``inputs.layout.stack``."""
    ref = pairing.pairs[0].pred if pairing.pairs else None
    rows = getattr(ref, "rows", None)
    return {
        "files": sorted({str(p.pred.path) for p in pairing.pairs}),
        "parts": list(STACK_PARTS), "axis": "vertical (rows)", "part_rows": rows,
        "prediction_rows": [0, rows], "ground_truth_rows": [rows, 2 * rows] if rows else None,
        "source": "K-Planes base_trainer.evaluate_metrics (torch.cat((pred, gt, err), dim=0), "
                  "(x * 255).byte()) and ops/image/io.write_video_to_file (mp4v)",
    }

"""Finding frames in a folder and pairing predictions with ground truth.

Layout: a folder of images (one camera, named ``"."``) or one sub-folder per camera (any depth:
the camera is the folder's path relative to the root, e.g. ``"cam03"``), or video files (one
camera each, named by the file's path without extension). Non-image files are ignored.

Pairing rules (driven by the prediction folder, see ``pair_frames``):

* image cameras are matched by relative path with the extension ignored: pred ``cam03/0007.jpg``
  pairs with gt ``cam03/0007.png``;
* when either side of a camera is a video, frames are paired by position;
* a prediction with no ground truth is an error;
* a ground-truth camera with no prediction at all is not scored (renders often cover only the
  evaluation cameras) and is listed in ``Pairing.unscored_cameras``;
* a camera with some ground-truth frames missing from the prediction is an error listing them,
  unless ``allow_missing``: then the intersection is scored and the rest listed in ``skipped``.

Frames within a camera are ordered by natural sort (``2.png`` before ``10.png``); a frame's
``index`` is its position in the ground-truth camera's sequence, so consecutive indices are
consecutive frames for temporal metrics.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dynaeval.errors import InputError
from dynaeval.io.images import IMAGE_EXTENSIONS, frame_name_parts, read_image, to_float
from dynaeval.io.video import VIDEO_EXTENSIONS, read_video_frame, scan_video
from dynaeval.outcome import Status, note, warning

ROOT_CAMERA = "."


def natural_key(text: str) -> tuple:
    """Sort key that orders digit runs by value: ``frame2`` < ``frame10``."""
    return tuple(int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", text))


@dataclass(frozen=True)
class FrameRef:
    """Where one frame lives: an image file, or frame ``index`` of a video file."""

    path: Path
    """Image or video file."""
    index: int | None = None
    """0-based frame number inside a video file; None for an image file."""

    def read(self, background: str | float = "white", decode: str = "dynaeval",
             decoded: np.ndarray | None = None) -> np.ndarray:
        """The frame as (H, W, C) float32, C in {1, 3}, in [0, 1] (float files as stored);
        ``decode``: the 16-bit PNG rule of ``dynaeval.io.images.read_image``; ``decoded``: an
        image file's uint8 decoding made beforehand (``read_image``)."""
        if self.index is None:
            return read_image(self.path, background=background, decode=decode, decoded=decoded)

        return to_float(read_video_frame(self.path, self.index), path=self.path)

    def __str__(self) -> str:
        return str(self.path) if self.index is None else f"{self.path}#{self.index}"


@dataclass(frozen=True)
class FramePair:
    """A prediction and the ground-truth frame it is scored against."""

    camera: str
    """Camera name: folder relative to the root (``"."`` for a flat folder) or video stem."""
    frame: str
    """Frame name: the ground-truth file's stem (``"0007"``), or the 0-based number for video."""
    index: int
    """Position of the frame in the ground-truth camera's natural order (0-based)."""
    pred: FrameRef
    gt: FrameRef


@dataclass
class Pairing:
    """Result of pairing a prediction folder with a ground-truth folder."""

    pairs: list[FramePair]
    """Pairs to score, ordered by camera (natural order) then frame index."""
    unscored_cameras: list[str] = field(default_factory=list)
    """Ground-truth cameras with no prediction at all (not scored)."""
    skipped: list[dict] = field(default_factory=list)
    """With ``allow_missing``: ground-truth frames with no prediction, ``{camera, frame}``."""
    warnings: list[dict] = field(default_factory=list)
    """``{camera, reason}`` of the scored cameras' damaged video files (``Camera.warnings``),
    and run-level ``{reason}`` ones (a K-Planes stack read from a lossy video), for the results'
    warnings."""


@dataclass
class Camera:
    """The frames of one camera found in a folder, in natural order."""

    name: str
    frames: list[tuple[str, FrameRef]]
    """(frame name, reference) pairs."""
    is_video: bool = False
    warnings: list[dict] = field(default_factory=list)
    """``{camera, reason}``: a damaged video file (frames dropped, ``video.VideoScan``)."""


def find_frames(root: str | Path, *, role: str = "input") -> dict[str, Camera]:
    """Find every camera and frame below ``root``.

    Args:
        root: folder to scan (hidden files and folders are skipped).
        role: ``"prediction"`` or ``"ground truth"``, for error messages.

    Returns:
        Mapping camera name -> Camera, in natural order of camera names.

    Raises:
        InputError: ``root`` is not a folder, holds no frame, a folder below it cannot be
            listed (permissions: never skipped silently), or a camera has two files with the
            same stem (``0001.png`` and ``0001.jpg``).
    """
    root = Path(root)
    if not root.exists():
        raise InputError(f"{role} folder not found", path=root)
    if not root.is_dir():
        raise InputError(f"{role} must be a folder of frames (or of camera folders)", path=root)
    images: dict[str, dict[str, Path]] = {}
    videos: dict[str, Path] = {}

    def unreadable(err: OSError) -> None:  # os.walk would skip the folder silently
        raise InputError(
            f"cannot list this {role} folder ({err.strerror or err}): its frames would be left "
            "out; fix its permissions (e.g. chmod a+rx)",
            path=err.filename or root,
        )

    for dirpath, dirnames, filenames in os.walk(root, onerror=unreadable):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        rel = Path(dirpath).relative_to(root).as_posix()
        for name in sorted(filenames):
            if name.startswith("."):
                continue
            path = Path(dirpath) / name
            stem, ext = frame_name_parts(path)
            if ext in IMAGE_EXTENSIONS:
                cam = images.setdefault(rel, {})
                if stem in cam:
                    raise InputError(
                        f"two {role} files share the frame name {stem!r}: {cam[stem].name} and "
                        f"{name}; keep one of them",
                        path=Path(dirpath),
                    )
                cam[stem] = path
            elif ext in VIDEO_EXTENSIONS:
                cam_name = (Path(rel) / path.stem).as_posix() if rel != "." else path.stem
                videos[cam_name] = path
    cameras: dict[str, Camera] = {}
    for name, stems in images.items():
        ordered = sorted(stems, key=natural_key)
        cameras[name] = Camera(name, [(s, FrameRef(stems[s])) for s in ordered])
    for name, path in videos.items():
        if name in cameras:
            raise InputError(
                f"camera {name!r} is both a folder of images and a video file; keep one", path=path
            )
        scan = scan_video(path)
        problem = scan.problem()
        cameras[name] = Camera(name, [(str(i), FrameRef(path, i)) for i in range(scan.n_frames)],
                               True, [note(f"{path}: {problem}", camera=name)] if problem
                               else [])
    if not cameras:
        raise InputError(
            f"no {role} frames found (looked for {', '.join(sorted(IMAGE_EXTENSIONS | VIDEO_EXTENSIONS))})",
            path=root,
        )
    return {k: cameras[k] for k in sorted(cameras, key=natural_key)}


def _listing(items: Iterable[str], limit: int = 8) -> str:
    items = list(items)
    shown = ", ".join(items[:limit])
    return shown + (f", … ({len(items)} in all)" if len(items) > limit else "")


def pair_frames(
    pred_root: str | Path, gt_root: str | Path, *, allow_missing: bool = False
) -> Pairing:
    """Pair every prediction frame with its ground truth (rules in the module docstring).

    Raises:
        InputError: a prediction has no ground truth, a camera misses frames (without
            ``allow_missing``), or either folder is empty or malformed.
    """
    pred = find_frames(pred_root, role="prediction")
    gt = find_frames(gt_root, role="ground truth")
    extra_cams = [c for c in pred if c not in gt]
    if extra_cams:
        hint = ""
        if extra_cams == [ROOT_CAMERA]:
            hint = (
                f"; the prediction folder is flat but the ground truth has cameras "
                f"{_listing(gt)}: point GT at one camera's folder, or put predictions in camera folders"
            )
        elif ROOT_CAMERA in gt and len(gt) == 1:
            hint = "; the ground truth folder is flat: point PRED at one camera's folder"
        raise InputError(
            f"prediction cameras with no ground-truth camera: {_listing(extra_cams)}{hint}",
            path=pred_root,
        )
    pairs: list[FramePair] = []
    skipped: list[dict] = []
    warnings: list[dict] = []
    for cam_name, pcam in pred.items():
        gcam = gt[cam_name]
        if pcam.is_video or gcam.is_video:
            n = len(pcam.frames)
            if n > len(gcam.frames):
                raise InputError(
                    f"camera {cam_name!r}: the prediction has {n} frames, the ground truth only "
                    f"{len(gcam.frames)}",
                    path=pcam.frames[0][1].path,
                )
            matched = [(i, gcam.frames[i], pcam.frames[i][1]) for i in range(n)]
            missing = [name for name, _ in gcam.frames[n:]]
        else:
            gt_index = {name: i for i, (name, _) in enumerate(gcam.frames)}
            no_gt = [name for name, _ in pcam.frames if name not in gt_index]
            if no_gt:
                raise InputError(
                    f"camera {cam_name!r}: predictions with no ground-truth frame: "
                    f"{_listing(no_gt)}",
                    path=Path(pred_root) / cam_name,
                )
            pred_refs = dict(pcam.frames)
            matched = [
                (i, gcam.frames[i], pred_refs[name])
                for i, (name, _) in enumerate(gcam.frames)
                if name in pred_refs
            ]
            missing = [name for name, _ in gcam.frames if name not in pred_refs]
        if missing and not allow_missing:
            raise InputError(
                f"camera {cam_name!r}: ground-truth frames with no prediction: {_listing(missing)} "
                f"(pass --allow-missing to score the {len(matched)} frames present)",
                path=Path(pred_root) / cam_name,
            )
        skipped.extend({"camera": cam_name, "frame": name} for name in missing)
        warnings.extend([*pcam.warnings, *gcam.warnings])
        for index, (gt_name, gt_ref), pred_ref in matched:
            pairs.append(FramePair(cam_name, gt_name, index, pred_ref, gt_ref))
    unscored = [c for c in gt if c not in pred]
    return Pairing(pairs=pairs, unscored_cameras=unscored, skipped=skipped, warnings=warnings)


def pairs_by_camera(pairs: list[FramePair]) -> dict[str, list[FramePair]]:
    """``pairs`` grouped by camera, cameras and frames in the order met."""
    out: dict[str, list[FramePair]] = {}
    for pair in pairs:
        out.setdefault(pair.camera, []).append(pair)
    return out


def gap_positions(pairs: list[FramePair]) -> list[int]:
    """Positions ``k`` of the neighbours ``(pairs[k], pairs[k + 1])`` of a camera that are not
    consecutive frames (ground-truth frames left out between them: ``--allow-missing``)."""
    return [k for k in range(len(pairs) - 1) if pairs[k + 1].index != pairs[k].index + 1]


def consecutive_pairs(pairing: Pairing) -> dict[str, dict]:
    """Per camera with ground-truth frames left out (``Pairing.skipped``, ``allow_missing``):
    ``{"scored": pairs of consecutive frames present, "expected": pairs of its ground truth,
    "missing_frames": [frame names]}``, what its temporal terms can use; {} when none is missing.
    """
    missing: dict[str, list[str]] = {}
    for s in pairing.skipped:
        missing.setdefault(s["camera"], []).append(s["frame"])
    out = {}
    for cam, cam_pairs in pairs_by_camera(pairing.pairs).items():
        if cam in missing:
            n_gt = len(cam_pairs) + len(missing[cam])
            scored = len(cam_pairs) - 1 - len(gap_positions(cam_pairs))
            out[cam] = {"scored": scored, "expected": max(0, n_gt - 1),
                        "missing_frames": missing[cam]}
    return out


def missing_frames_warning(gaps: dict[str, dict], temporal: bool, most: int = 8) -> dict:
    """The one run-level warning (printed on the console; ``Status.MISSING_FRAMES``, which
    ``dynaeval merge`` makes again) of ``--allow-missing`` runs that left frames out: which, per camera (``gaps``: ``consecutive_pairs``' output), and how many pairs
    of consecutive frames the temporal terms scored (``temporal``: they ran)."""
    parts = []
    for cam, g in list(gaps.items())[:most]:
        names = g["missing_frames"]
        shown = ", ".join(names[:8]) + (f", ... ({len(names)} in all)" if len(names) > 8 else "")
        pairs = f"; temporal pairs {g['scored']} of {g['expected']}" if temporal else ""
        parts.append(f"camera {cam}: {shown}{pairs}")
    more = f"; {len(gaps) - most} more camera(s) in inputs.skipped_frames" if len(gaps) > most else ""
    n = sum(len(g["missing_frames"]) for g in gaps.values())
    return warning(Status.MISSING_FRAMES, (
        f"{n} ground-truth frame(s) have no prediction and are not scored "
        f"({'; '.join(parts)}{more})"
        + ("; temporal terms use the pairs of consecutive frames present" if temporal else "")))


def parse_shard(spec: str) -> tuple[int, int]:
    """``"I/N"`` (1 <= I <= N) -> (I, N); InputError otherwise."""
    try:
        i, n = (int(x) for x in spec.split("/"))
    except ValueError:
        raise InputError(f"--shard must be I/N with whole numbers, e.g. 1/4; got {spec!r}") from None
    if not 1 <= i <= n:
        raise InputError(f"--shard I/N needs 1 <= I <= N, got {spec!r}")
    return i, n


def select_shard(pairing: Pairing, index: int, count: int) -> Pairing:
    """The deterministic slice ``index`` of ``count`` (1-based) of a pairing, by whole cameras.

    Camera k (0-based, in natural order) goes to shard ``k % count + 1``. Whole cameras, because
    motion masks and temporal terms need a camera's full sequence: the per-frame and per-camera
    numbers of a shard are then exactly those of an unsharded run, and ``dynaeval merge`` puts
    the shards back together bit for bit. A shard may hold no camera (more shards than cameras).
    """
    cameras = sorted({p.camera for p in pairing.pairs}, key=natural_key)
    mine = {c for k, c in enumerate(cameras) if k % count + 1 == index}
    return Pairing(
        pairs=[p for p in pairing.pairs if p.camera in mine],
        unscored_cameras=list(pairing.unscored_cameras),
        skipped=[s for s in pairing.skipped if s["camera"] in mine],
        warnings=[w for w in pairing.warnings  # run-level ones (no camera) go to every shard
                  if "camera" not in w or w["camera"] in mine],
    )

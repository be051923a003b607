"""Finding frames in a folder and pairing predictions with ground truth.

Layout: a folder of images (one camera, named ``"."``) or one sub-folder per camera (any depth:
the camera is the folder's path relative to the root, e.g. ``"cam03"``), or video files (one
camera each, named by the file's path without extension). Non-image files are ignored.

Symbolic links are followed: a linked camera folder or frame file is read as its target, under
the link's name (so ``pred/cam1 -> /renders/cam1`` is camera ``cam1``, scored as the folder
itself would be). A link that cannot be read is an error naming it, before the work: a broken
link (its target is gone), a loop of links, or a link to a folder that holds it (``cam1/up ->
..``: walked forever). Inputs that make the choice ambiguous are errors naming both, with the
fix (remove one, or move it out of the folder): two files of one frame name (``0001.png`` and
``0001.jpg``), two videos of one camera (``cam0.mp4`` and ``cam0.avi``), a folder of images and
a video of one camera (``cam0/`` beside ``cam0.mp4``). A TIFF whose pixel type is not read
(``dynaeval.io.images``: int32, complex, ...) is refused when listed, before the work.

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

import errno
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import Status, note, warning
from dynaeval.io.images import (
    IMAGE_EXTENSIONS,
    TYPED_HEADERS,
    check_pixel_type,
    frame_name_parts,
    read_image,
    to_float,
)
from dynaeval.io.video import VIDEO_EXTENSIONS, read_video_frame, scan_video

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

    @property
    def image_file(self) -> Path | None:
        """The image file that is this frame, read whole by ``read_image`` (which
        ``dynaeval.io.images.FrameCache`` calls itself), or None: a video frame, or (a subclass
        that reads part of a file) a part."""
        return self.path if self.index is None else None

    def read(self, background: str | float = "white", decode: str = "dynaeval") -> np.ndarray:
        """The frame as (H, W, C) float32, C in {1, 3}, in [0, 1] (float files as stored);
        ``decode``: the 16-bit PNG rule of ``dynaeval.io.images.read_image``."""
        if self.image_file is not None:
            return read_image(self.image_file, background=background, decode=decode)

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


KEEP_ONE = ("which one to score is ambiguous: remove one of them, or move it out of the folder")
"""The fix said for two inputs of one frame or camera (``find_frames``)."""


def _check_target(path: Path, role: str) -> None:
    """Refuse a symbolic link ``path`` whose target is missing or that loops (a link to a file
    or folder is otherwise read as its target)."""
    if not os.path.islink(path):
        return
    try:
        os.stat(path)
    except OSError as err:
        what = ("is a loop of symbolic links" if err.errno == errno.ELOOP else
                f"is a broken symbolic link: its target {os.readlink(path)} "
                + ("does not exist" if err.errno == errno.ENOENT else
                   f"cannot be read ({err.strerror or err})"))
        raise InputError(f"this {role} entry {what}, so it cannot be read; fix the link or "
                         "remove it", path=path) from None


def _enter(folder: Path, seen: frozenset[str], role: str) -> frozenset[str]:
    """The real paths of the folders from the root down to ``folder`` (``seen``: down to its
    parent), when walking into it is safe: a symbolic link to a folder above it, or to one
    already on the way down, would be walked forever (or would read the folder twice).

    Raises:
        InputError: such a link, naming it.
    """
    real = os.path.realpath(folder)
    parent = os.path.realpath(folder.parent)
    if real in seen or parent == real or parent.startswith(real.rstrip(os.sep) + os.sep):
        raise InputError(
            f"this {role} folder is a symbolic link to {real}, a folder that holds it (a loop): "
            "its frames would be read again and again; point the link at the camera's own "
            "folder or remove it", path=folder)
    return seen | {real}


def find_frames(root: str | Path, *, role: str = "input") -> dict[str, Camera]:
    """Find every camera and frame below ``root``.

    Args:
        root: folder to scan (hidden files and folders are skipped).
        role: ``"prediction"`` or ``"ground truth"``, for error messages.

    Returns:
        Mapping camera name -> Camera, in natural order of camera names.

    Raises:
        InputError: ``root`` is not a folder, holds no frame, a folder below it cannot be
            listed (permissions: never skipped silently), a camera has two files with the
            same stem (``0001.png`` and ``0001.jpg``) or two videos (``cam0.mp4`` and
            ``cam0.avi``, or a ``cam0/`` folder of images beside ``cam0.mp4``), a symbolic
            link below it is broken or loops, or an image file's header states a pixel type
            that has no range rule (``images.check_pixel_type``).
    """
    root = Path(root)
    if not root.exists():
        _check_target(root, role)  # a broken link, said as such
        raise InputError(f"{role} folder not found", path=root)
    if not root.is_dir():
        raise InputError(f"{role} must be a folder of frames (or of camera folders)", path=root)
    images, videos = _frame_files(root, role)
    cameras: dict[str, Camera] = {}
    for name, stems in images.items():
        ordered = sorted(stems, key=natural_key)
        cameras[name] = Camera(name, [(s, FrameRef(stems[s])) for s in ordered])
    for name, path in videos.items():
        if name in cameras:
            folder = root / name
            raise InputError(
                f"camera {name!r} is both a folder of images ({folder}/) and a video file "
                f"({path}); {KEEP_ONE}", path=path)
        cameras[name] = _video_camera(name, path)
    if not cameras:
        raise InputError(
            f"no {role} frames found (looked for {', '.join(sorted(IMAGE_EXTENSIONS | VIDEO_EXTENSIONS))})",
            path=root,
        )
    return {k: cameras[k] for k in sorted(cameras, key=natural_key)}


def _frame_files(root: Path, role: str) -> tuple[dict[str, dict[str, Path]], dict[str, Path]]:
    """The frame files below ``root``: ``images`` {camera: {frame name: file}} and ``videos``
    {camera: file}, hidden entries skipped, symbolic links followed (refused if broken or
    looping)."""
    images: dict[str, dict[str, Path]] = {}
    videos: dict[str, Path] = {}

    def unreadable(err: OSError) -> None:  # os.walk would skip the folder silently
        raise InputError(
            f"cannot list this {role} folder ({err.strerror or err}): its frames would be left "
            "out; fix its permissions (e.g. chmod a+rx)",
            path=err.filename or root,
        )

    above: dict[str, frozenset[str]] = {str(root): frozenset({os.path.realpath(root)})}
    for dirpath, dirnames, filenames in os.walk(root, onerror=unreadable, followlinks=True):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        for d in dirnames:  # a linked folder is read as its target, unless that loops
            above[os.path.join(dirpath, d)] = _enter(Path(dirpath) / d, above[dirpath], role)
        rel = Path(dirpath).relative_to(root).as_posix()
        for name in sorted(filenames):
            if not name.startswith("."):
                _add_frame_file(Path(dirpath) / name, rel, role, images, videos)
    return images, videos


def _add_frame_file(path: Path, rel: str, role: str, images: dict[str, dict[str, Path]],
                    videos: dict[str, Path]) -> None:
    """None; files ``path`` (in camera folder ``rel``) under its camera in ``images`` or
    ``videos``, refusing a second file of one frame or a second video of one camera."""
    _check_target(path, role)
    stem, ext = frame_name_parts(path)
    if ext in IMAGE_EXTENSIONS:
        cam = images.setdefault(rel, {})
        if stem in cam:
            raise InputError(
                f"two {role} files share the frame name {stem!r}: {cam[stem].name} and "
                f"{path.name}; {KEEP_ONE}",
                path=path.parent,
            )
        if ext in TYPED_HEADERS:
            check_pixel_type(path)
        cam[stem] = path
    elif ext in VIDEO_EXTENSIONS:
        cam_name = (Path(rel) / path.stem).as_posix() if rel != "." else path.stem
        if cam_name in videos:
            raise InputError(
                f"two {role} videos of camera {cam_name!r}: {videos[cam_name]} and "
                f"{path}; {KEEP_ONE}", path=path)
        videos[cam_name] = path


def _video_camera(name: str, path: Path) -> Camera:
    """Camera ``name``: one frame per frame of the video file ``path``, with a warning when the
    file is damaged."""
    scan = scan_video(path)
    problem = scan.problem()
    return Camera(name, [(str(i), FrameRef(path, i)) for i in range(scan.n_frames)],
                  True, [note(f"{path}: {problem}", camera=name)] if problem else [])


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
    _check_every_camera_has_ground_truth(pred, gt, pred_root)
    pairs: list[FramePair] = []
    skipped: list[dict] = []
    warnings: list[dict] = []
    for cam_name, pcam in pred.items():
        gcam = gt[cam_name]
        if pcam.is_video or gcam.is_video:
            matched, missing = _match_by_position(pcam, gcam)
        else:
            matched, missing = _match_by_name(pcam, gcam, pred_root)
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


_Matched = list[tuple[int, tuple[str, FrameRef], FrameRef]]
"""A camera's matched frames: (ground-truth index, (ground-truth name, its reference),
prediction reference)."""


def _check_every_camera_has_ground_truth(pred: dict[str, Camera], gt: dict[str, Camera],
                                         pred_root: str | Path) -> None:
    """None; raises InputError listing the prediction cameras with no ground-truth camera, with
    a hint when one side is a flat folder and the other is not."""
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


def _match_by_position(pcam: Camera, gcam: Camera) -> tuple[_Matched, list[str]]:
    """The matched frames of a camera where either side is a video (the n-th with the n-th), and
    the ground-truth frame names past the prediction's last."""
    n = len(pcam.frames)
    if n > len(gcam.frames):
        raise InputError(
            f"camera {pcam.name!r}: the prediction has {n} frames, the ground truth only "
            f"{len(gcam.frames)}",
            path=pcam.frames[0][1].path,
        )
    matched = [(i, gcam.frames[i], pcam.frames[i][1]) for i in range(n)]
    return matched, [name for name, _ in gcam.frames[n:]]


def _match_by_name(pcam: Camera, gcam: Camera,
                   pred_root: str | Path) -> tuple[_Matched, list[str]]:
    """The matched frames of a camera of images (by frame name, extension ignored), and the
    ground-truth frame names with no prediction."""
    gt_index = {name: i for i, (name, _) in enumerate(gcam.frames)}
    no_gt = [name for name, _ in pcam.frames if name not in gt_index]
    if no_gt:
        raise InputError(
            f"camera {pcam.name!r}: predictions with no ground-truth frame: "
            f"{_listing(no_gt)}",
            path=Path(pred_root) / pcam.name,
        )
    pred_refs = dict(pcam.frames)
    matched = [
        (i, gcam.frames[i], pred_refs[name])
        for i, (name, _) in enumerate(gcam.frames)
        if name in pred_refs
    ]
    return matched, [name for name, _ in gcam.frames if name not in pred_refs]


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
    ``dynaeval merge`` makes again) of ``--allow-missing`` runs that left frames out: which, per
    camera (``gaps``: ``consecutive_pairs``' output), and how many pairs of consecutive frames
    the temporal terms scored (``temporal``: they ran)."""
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

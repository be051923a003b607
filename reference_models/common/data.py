"""Load multi-view video datasets: the scene generator's ``transforms.json``, plain nerfstudio files
and D-NeRF style ``transforms_{train,test}.json``, into flat arrays of *views* (one image each).

A view is one (camera, frame) image with its pinhole intrinsics, camera-to-world matrix (nerfstudio
/ OpenGL convention: the camera looks down -Z, +Y up) and time in [0, 1]. Rays are made on the fly
from (view, row, col) by ``reference_models.common.rays``, so only the uint8 pixels are kept:
``30 cameras x 24 frames x 320 x 180`` is 124 MB.

Splits:

* generator files: ``train_cameras`` / ``eval_cameras`` name the cameras;
* nerfstudio files: ``train_filenames`` / ``val_filenames`` (or ``test_filenames``) when present,
  else every frame trains and nothing is held out;
* D-NeRF folders: ``transforms_train.json`` trains, ``transforms_test.json`` (else ``_val``) evaluates.

A view's ``camera`` is the frame's ``camera`` key, else the folder of its file (``images/cam03/
0007.png`` -> ``cam03``); its ``frame`` name is the file stem. Predictions are written to
``pred/<camera>/<frame>.png``, matching the ground truth's relative path for ``dynaeval score``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dynaeval.errors import InputError


@dataclass
class Views:
    """A set of views that share one image size."""

    images: np.ndarray
    """(V, H, W, 3) uint8 sRGB pixels (RGBA composited over white on load)."""
    c2w: np.ndarray
    """(V, 4, 4) float32 camera-to-world, world metres, OpenGL convention."""
    intrinsics: np.ndarray
    """(V, 4) float32 ``fx, fy, cx, cy`` in pixels (pixel centres at +0.5)."""
    times: np.ndarray
    """(V,) float32 time in [0, 1] (0 for static datasets)."""
    cameras: list[str]
    """Camera name of each view (several views share a static camera)."""
    frames: list[str]
    """Frame name of each view (the ground-truth file stem, e.g. ``"0007"``)."""

    def __len__(self) -> int:
        return len(self.cameras)

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return int(self.images.shape[1])

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return int(self.images.shape[2])

    def subset(self, index: np.ndarray | list[int]) -> Views:
        """The views at ``index`` (in that order)."""
        idx = np.asarray(index, dtype=np.int64)
        return Views(self.images[idx], self.c2w[idx], self.intrinsics[idx], self.times[idx],
                     [self.cameras[i] for i in idx], [self.frames[i] for i in idx])

    def camera_sequences(self) -> dict[str, np.ndarray]:
        """Camera name -> view indices of that camera sorted by time (its video)."""
        out: dict[str, list[int]] = {}
        for i, cam in enumerate(self.cameras):
            out.setdefault(cam, []).append(i)
        return {c: np.asarray(sorted(ix, key=lambda i: self.times[i]), dtype=np.int64)
                for c, ix in out.items()}


@dataclass
class Dataset:
    """Training and evaluation views of one scene, and the box the model concentrates on."""

    root: Path
    """Dataset folder."""
    train: Views
    """Views to train on."""
    eval: Views | None
    """Held-out views to render and score (None when the files name none)."""
    n_frames: int
    """Number of distinct times (frames of the video)."""
    box: np.ndarray
    """(2, 3) float32 ``[min, max]`` corners (world metres) of the inner scene box; space outside it
    is contracted (see ``rays.contract``)."""
    extent: np.ndarray | None = None
    """(2, 3) float64 ``[min, max]`` corners (world metres) of everything in the scene but the sky
    (the generator's ``metadata.json`` ``world.extent``); None when the files do not say."""


def _read(path: Path) -> np.ndarray:
    from dynaeval.io.images import read_image

    if not path.is_file():
        raise InputError("image listed in the transforms file does not exist", path=path)
    img = read_image(path, background="white")
    if img.shape[-1] == 1:
        img = np.repeat(img, 3, axis=-1)
    return np.round(np.clip(img[..., :3], 0.0, 1.0) * 255.0).astype(np.uint8)


def _resolve(root: Path, file_path: str) -> Path:
    p = root / file_path
    if p.suffix:
        return p
    for ext in (".png", ".jpg", ".jpeg"):  # D-NeRF lists paths without extension
        if p.with_suffix(ext).is_file():
            return p.with_suffix(ext)
    return p.with_suffix(".png")


def _intrinsics(entry: dict, top: dict, width: int, height: int, where: Path) -> tuple:
    def get(key: str) -> float | None:
        v = entry.get(key, top.get(key))
        return None if v is None else float(v)

    fx, fy = get("fl_x"), get("fl_y")
    if fx is None:
        angle = get("camera_angle_x")
        if angle is None:
            raise InputError("a frame has neither fl_x nor camera_angle_x; add the focal length "
                             "in pixels (fl_x, fl_y) or the horizontal field of view", path=where)
        fx = 0.5 * width / np.tan(0.5 * angle)
    fy = fx if fy is None else fy
    cx, cy = get("cx"), get("cy")
    return fx, fy, width / 2.0 if cx is None else cx, height / 2.0 if cy is None else cy


def _load_frames(root: Path, top: dict, entries: list[dict], where: Path) -> Views:
    if not entries:
        raise InputError("expected a non-empty 'frames' list", path=where)
    images, c2ws, intr, times, cams, names = [], [], [], [], [], []
    for entry in entries:
        if "file_path" not in entry or "transform_matrix" not in entry:
            raise InputError("every frame needs 'file_path' and 'transform_matrix'", path=where)
        path = _resolve(root, entry["file_path"])
        img = _read(path)
        if images and img.shape != images[0].shape:
            raise InputError(f"image size {img.shape[1]}x{img.shape[0]} differs from the first "
                             f"view's {images[0].shape[1]}x{images[0].shape[0]}; resize the dataset "
                             "to one size", path=path)
        c2w = np.asarray(entry["transform_matrix"], dtype=np.float64)
        if c2w.shape == (3, 4):
            c2w = np.vstack([c2w, [0.0, 0.0, 0.0, 1.0]])
        if c2w.shape != (4, 4) or not np.all(np.isfinite(c2w)):
            raise InputError(f"transform_matrix must be a finite 4x4 (or 3x4) matrix, got shape "
                             f"{c2w.shape}", path=where)
        t = float(entry.get("time", 0.0))
        if not 0.0 <= t <= 1.0:
            raise InputError(f"frame time must be in [0, 1], got {t} for {entry['file_path']}",
                             path=where)
        images.append(img)
        c2ws.append(c2w)
        intr.append(_intrinsics(entry, top, img.shape[1], img.shape[0], where))
        times.append(t)
        rel = Path(entry["file_path"])
        cams.append(str(entry.get("camera", rel.parent.name or ".")))
        names.append(rel.stem)
    return Views(np.stack(images), np.asarray(c2ws, np.float32), np.asarray(intr, np.float32),
                 np.asarray(times, np.float32), cams, names)


def _norm(name: str) -> str:
    return str(Path(name)).removeprefix("./")


def scene_box(centres: np.ndarray, ground_z: float | None = None, pad: float = 0.1) -> np.ndarray:
    """The inner box ``(2, 3)`` float32 (world metres) from the camera centres ``(N, 3)``.

    The box spans the camera centres (the cameras surround the action) grown by ``pad`` of its
    size on every side; with ``ground_z`` (the pitch plane) it reaches at least ``pad`` of its
    height below the ground. Axes where all cameras agree get the size of the largest axis.
    """
    lo, hi = centres.min(axis=0).astype(np.float64), centres.max(axis=0).astype(np.float64)
    if ground_z is not None:
        lo[2] = min(lo[2], ground_z)
    size = hi - lo
    flat = size < 1e-6 * max(size.max(), 1e-6)
    size[flat] = max(size.max(), 1.0)
    mid = 0.5 * (lo + hi)
    lo, hi = np.where(flat, mid - size / 2, lo), np.where(flat, mid + size / 2, hi)
    lo, hi = lo - pad * size, hi + pad * size
    return np.stack([lo, hi]).astype(np.float32)


def _rig(views: Views) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Camera name -> (c2w, intrinsics) of its first view."""
    return {cam: (views.c2w[idx[0]], views.intrinsics[idx[0]])
            for cam, idx in views.camera_sequences().items()}


def check_same_rig(clip: Views, stadium: Views, where: Path) -> None:
    """Raise InputError unless ``stadium`` was filmed by the cameras of ``clip``: the same names,
    poses and intrinsics (within 1e-5) and image size."""
    a, b = _rig(clip), _rig(stadium)
    if sorted(a) != sorted(b):
        raise InputError(f"the stadium's training cameras ({', '.join(sorted(b))}) are not the "
                         f"clip's ({', '.join(sorted(a))}); render the stadium with the clip's "
                         "preset, size and seed", path=where)
    if (clip.height, clip.width) != (stadium.height, stadium.width):
        raise InputError(f"the stadium's images are {stadium.width}x{stadium.height}, the clip's "
                         f"{clip.width}x{clip.height}; render both at one size", path=where)
    for cam, (c2w, intr) in a.items():
        if not (np.allclose(c2w, b[cam][0], atol=1e-5) and np.allclose(intr, b[cam][1], atol=1e-5)):
            raise InputError(f"camera {cam!r} of the stadium is not placed like the clip's; render "
                             "the stadium with the clip's preset, size and seed", path=where)


def load_dataset(path: str | Path) -> Dataset:
    """Load ``path``: a folder with ``transforms.json`` (generator / nerfstudio) or
    ``transforms_train.json`` (D-NeRF), or the ``transforms.json`` file itself.

    Raises InputError for a missing folder or file, malformed entries, missing images or images
    of different sizes.
    """
    p = Path(path)
    root = p.parent if p.is_file() else p
    if not root.is_dir():
        raise InputError("dataset folder does not exist", path=root)
    file = p if p.is_file() else root / "transforms.json"
    ground, extent = None, None
    meta = root / "metadata.json"
    if meta.is_file() and (info := json.loads(meta.read_text())).get("generator") == "reference_models.scenes":
        ground = 0.0  # the generator's pitch is the z = 0 plane
        if "extent" in info.get("world", {}):
            extent = np.asarray(info["world"]["extent"], dtype=np.float64)
    if file.is_file():
        top = _json(file)
        entries = top.get("frames")
        if not isinstance(entries, list) or not entries:
            raise InputError("expected a non-empty 'frames' list", path=file)
        if "train_cameras" in top:
            train_set, eval_set = set(top["train_cameras"]), set(top.get("eval_cameras", []))
            tr = [e for e in entries if e.get("camera") in train_set]
            ev = [e for e in entries if e.get("camera") in eval_set]
        elif "train_filenames" in top:
            train_set = {_norm(f) for f in top["train_filenames"]}
            eval_set = {_norm(f) for f in top.get("val_filenames", top.get("test_filenames", []))}
            tr = [e for e in entries if _norm(e.get("file_path", "")) in train_set]
            ev = [e for e in entries if _norm(e.get("file_path", "")) in eval_set]
        else:
            tr, ev = entries, []
        if not tr:
            raise InputError("the split names no training frame", path=file)
        train = _load_frames(root, top, tr, file)
        evals = _load_frames(root, top, ev, file) if ev else None
    elif (root / "transforms_train.json").is_file():
        ftr = root / "transforms_train.json"
        top = _json(ftr)
        train = _load_frames(root, top, top.get("frames", []), ftr)
        fev = next((f for f in (root / "transforms_test.json", root / "transforms_val.json")
                    if f.is_file()), None)
        evals = None
        if fev is not None:
            tev = _json(fev)
            evals = _load_frames(root, tev, tev.get("frames", []), fev)
    else:
        raise InputError("no transforms.json or transforms_train.json in the dataset folder; "
                         "render one with `python -m reference_models.scenes render ...`", path=root)
    n_frames = len(np.unique(train.times))
    box = scene_box(train.c2w[:, :3, 3], ground)
    return Dataset(root, train, evals, n_frames, box, extent)


def _json(path: Path) -> dict:
    try:
        obj = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise InputError(f"not valid JSON: {err}", path=path) from err
    if not isinstance(obj, dict):
        raise InputError("expected a JSON object at the top level", path=path)
    return obj

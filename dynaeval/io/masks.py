"""Given masks: a folder of per-frame masks beside the frames (NeRFBaselines ``mask/``, DyCheck
``covisible/<factor>x/<split>/``, or any folder named by ``--masks``).

Rules (docs/protocols.md repeats them):

* a frame's mask is ``FOLDER/<its ground truth's path relative to the GT folder>`` with the
  extension ``.png`` (NeRFBaselines' ``evaluate``: ``Path(mask_root).joinpath(relpath)
  .with_suffix(".png")``; DyCheck: ``covisible/<factor>x/<split>/<frame>.png`` beside
  ``rgb/<factor>x/<frame>.png``); other image extensions are accepted when no ``.png`` exists;
* found without ``--masks``: a NeRFBaselines render folder's ``mask/`` (beside ``color/`` and
  ``gt-color/``), and DyCheck's ``covisible/<factor>x/<split>/`` when the ground truth is a
  DyCheck ``rgb/<factor>x/`` folder and exactly one split holds a mask for every frame;
  ``--masks DATASET`` (a DyCheck dataset folder) picks the split the same way;
* a mask is one grey channel (or channels that are all equal), 8 or 16 bit, read as weights in
  [0, 1] (``v / 255``, ``v / 65535``); dynaeval's ``masked_*`` use the pixels with weight > 0.5;
* every frame must have its mask, of the frame's size: checked before any frame is scored
  (``InputError`` naming the file and the problem).
"""

from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.io.images import _PNG_MAGIC, IMAGE_EXTENSIONS, _read_bytes, check_complete, read_image

THRESHOLD = 0.5
"""Weights above this are the pixels of dynaeval's ``masked_*`` region."""
MASK_FOLDER_NAMES = ("mask", "masks", "covisible")
"""Folder names that look like masks: an unused one beside the frames is warned about."""
_FACTOR = re.compile(r"^(\d+)x$")


@dataclass(frozen=True)
class MaskSet:
    """Where the masks of a run are and how they were found."""

    folder: Path
    """The folder holding one mask per ground-truth frame."""
    gt_root: Path
    """The ground-truth folder the masks' relative paths follow."""
    origin: str
    """``given`` (``--masks``), ``nerfbaselines`` (a render folder's ``mask/``) or ``dycheck``
    (``covisible/<factor>x/<split>``)."""
    decode: str = "dynaeval"
    """``dynaeval`` or ``pil`` (NeRFBaselines: 8-bit grey masks only, see ``read_mask``)."""
    sha256: str | None = None
    """Hash of the scored frames' mask files (relative names and bytes, ``check_masks``), so
    runs on the same masks compare equal wherever the folder is."""

    def path_of(self, gt_path: Path) -> Path | None:
        """The mask file of a ground-truth frame, or None when there is none."""
        rel = Path(gt_path).relative_to(self.gt_root)
        first = self.folder / rel.with_suffix(".png")
        if first.is_file():
            return first
        for ext in sorted(IMAGE_EXTENSIONS - {".png"}):
            other = self.folder / rel.with_suffix(ext)
            if other.is_file():
                return other
        return None

    def describe(self) -> dict[str, Any]:
        """Settings for the results JSON."""
        return {"source": "given", "origin": self.origin, "folder": str(self.folder),
                "file": "<folder>/<ground-truth path relative to its folder>.png",
                "weights": "grey value / its maximum", "masked_threshold": THRESHOLD,
                "decode": self.decode, "sha256": self.sha256}


def image_size(path: Path) -> tuple[int, int]:
    """(H, W) of an image file (a PNG's header, else the decoded image)."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head.startswith(_PNG_MAGIC) and len(head) >= 24:
        w, h = struct.unpack(">II", head[16:24])
        return int(h), int(w)

    return read_image(path).shape[:2]


def read_mask(path: str | Path, decode: str = "dynaeval") -> np.ndarray:
    """One mask file as (H, W) float32 weights in [0, 1].

    Args:
        path: 8/16-bit grey PNG (or an image whose channels are all equal).
        decode: ``pil``: NeRFBaselines' reading, which multiplies the images by
            ``np.array(PIL.Image.open(f)) / 255``: only 8-bit single-channel masks give a mask
            there (a 16-bit one multiplies by the raw value, an RGB one fails to broadcast).

    Raises:
        InputError: unreadable or truncated file, colour mask, or a mask NeRFBaselines cannot
            use.
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise InputError("mask file not found", path=path)
    raw = _read_bytes(path)
    check_complete(raw, path)
    m = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_UNCHANGED) if raw else None
    if m is None or m.dtype not in (np.uint8, np.uint16, np.bool_):
        raise InputError("cannot decode mask (corrupt or not an 8/16-bit image)", path=path)
    if m.ndim == 3:
        if decode == "pil":
            raise InputError("NeRFBaselines needs single-channel masks (an RGB mask fails its "
                             "broadcast); save it as a grey PNG", path=path)
        colour = m[..., :3]
        if not all(np.array_equal(colour[..., 0], colour[..., c]) for c in range(1, colour.shape[2])):
            raise InputError("mask has different colour channels; save it as a grey image "
                             "(one channel, 0 = outside, 255 = inside)", path=path)
        m = colour[..., 0]
    if decode == "pil" and m.dtype == np.uint16:
        raise InputError("16-bit mask: NeRFBaselines multiplies the images by its raw value "
                         "(up to 65535); save it as an 8-bit grey PNG", path=path)
    return (m.astype(np.float32) / np.float32(np.iinfo(m.dtype).max)).astype(np.float32)


def check_masks(masks: MaskSet, gt_paths: list[tuple[Path, tuple[int, int] | None]]) -> MaskSet:
    """Every ground-truth frame has a readable mask of its size (before any frame is scored).

    Args:
        gt_paths: (ground-truth file, its (H, W) or None to read it) per frame.

    Returns:
        ``masks`` with ``sha256`` set: the hash of the masks' relative names and contents.

    Raises:
        InputError: naming the first missing mask or the first of another size.
    """
    import hashlib

    digest = hashlib.sha256()
    for gt, size in gt_paths:
        path = masks.path_of(gt)
        if path is None:
            raise InputError(f"no mask for ground-truth frame {gt} (expected "
                             f"{masks.folder / Path(gt).relative_to(masks.gt_root).with_suffix('.png')})",
                             path=masks.folder)
        h, w = read_mask(path, masks.decode).shape  # its format too, before the work
        size = image_size(gt) if size is None else size
        if (h, w) != tuple(size):
            raise InputError(f"mask is {w}x{h} px but its frame {gt} is {size[1]}x{size[0]} px",
                             path=path)
        digest.update(path.relative_to(masks.folder).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return replace(masks, sha256=digest.hexdigest())


def _dycheck_split(root: Path, factor: str, gt_root: Path, gt_files: list[Path]) -> Path | None:
    """The ``covisible/<factor>/<split>`` folder with a mask for every frame, if exactly one."""
    base = root / "covisible" / factor
    if not base.is_dir():
        return None
    fits = [s for s in sorted(base.iterdir()) if s.is_dir() and all(
        MaskSet(s, gt_root, "dycheck").path_of(g) is not None for g in gt_files)]
    return fits[0] if len(fits) == 1 else None


def find_masks(given: str | Path | None, gt_root: Path, gt_files: list[Path],
               render_root: Path | None, decode: str = "dynaeval") -> MaskSet | None:
    """The run's masks (module docstring), or None.

    Args:
        given: ``--masks``: a masks folder or a DyCheck dataset folder; None: look for them.
        gt_root: the ground-truth folder; gt_files: its frames' files.
        render_root: the render folder of a known layout (NeRFBaselines ``mask/``), or None.

    Raises:
        InputError: ``given`` is not a folder, or a DyCheck folder with no unique split.
    """
    factor = gt_root.name if _FACTOR.match(gt_root.name) and gt_root.parent.name == "rgb" else None
    if given is not None:
        folder = Path(given)
        if not folder.is_dir():
            raise InputError("masks folder not found (or not a folder)", path=folder)
        if (folder / "covisible").is_dir():
            split = _dycheck_split(folder, factor or "", gt_root, gt_files) if factor else None
            if split is None:
                raise InputError(
                    "a DyCheck dataset folder: no single covisible/<factor>x/<split>/ holds a "
                    f"mask for every frame of {gt_root} (the ground truth must be its "
                    "rgb/<factor>x/ folder); pass that covisible split folder instead",
                    path=folder)
            return MaskSet(split, gt_root, "dycheck", decode)
        return MaskSet(folder, gt_root, "given", decode)
    if render_root is not None and (render_root / "mask").is_dir():
        return MaskSet(render_root / "mask", gt_root, "nerfbaselines", decode)
    if factor is not None:
        split = _dycheck_split(gt_root.parent.parent, factor, gt_root, gt_files)
        if split is not None:
            return MaskSet(split, gt_root, "dycheck", decode)
    return None


def _instance_masks(parent: Path, name: str) -> bool:
    """True when ``parent/transforms.json`` names ``parent/name`` as its frames'
    ``instance_mask_path`` (the scene generator's per-object id maps, not weights to score)."""
    try:
        frames = json.loads((parent / "transforms.json").read_text()).get("frames", [])
        return any(str(f.get("instance_mask_path", "")).startswith(f"{name}/") for f in frames)
    except (OSError, ValueError, AttributeError, RecursionError):  # not the generator's file
        return False


def unused_mask_folders(used: MaskSet | None, folders: list[Path]) -> list[Path]:
    """Folders named like masks (``MASK_FOLDER_NAMES``) inside or beside ``folders`` that the
    run does not use (warned about: NeRFBaselines and DyCheck would have used them). A folder
    that ``transforms.json`` beside it declares as instance masks (``instance_mask_path``, the
    scene generator's layout) holds object ids, not weights, and is not listed."""
    seen: list[Path] = []
    for base in folders:
        dycheck = [base.parent.parent] if base.parent.name == "rgb" else []
        for parent in (base, base.parent, *dycheck):
            for name in MASK_FOLDER_NAMES:
                cand = (parent / name).resolve()
                if cand.is_dir() and cand not in seen and not _instance_masks(parent, name):
                    seen.append(cand)
    if used is None:
        return seen
    u = used.folder.resolve()
    return [c for c in seen if c != u and c not in u.parents]

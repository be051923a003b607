"""DyCheck's layouts: its dataset as ground truth, and its own render folder.

**Dataset** ``DATA/rgb/<factor>x/`` holds every frame (training and test views),
``DATA/splits/<split>.json`` lists each split's ``frame_names``. Predictions of one split
(``1_00000.png``, ...) are paired with that split's ground truth only: ``pair_dycheck`` pairs
them when the predicted frames all belong to exactly one split, so the training frames are
neither an error nor "skipped"; a frame of the split with no prediction is still an error
(unless ``allow_missing``). Covisibility masks: ``dynaeval.io.masks``. Every split file is
checked before any frame is paired (``read_split``, ``check_split_frames``): one that is not
JSON, not an object, without a list of frame-name strings in ``frame_names`` (``time_ids`` /
``camera_ids``, when there, one whole number per name), or that lists frames ``rgb/<factor>x/``
does not hold, is an error naming the file and its problem (it used to be skipped, and the
training frames then reported as frames with no prediction).

**Render folder** ``WORK/renders/novel_view/<split>/<frame>.png``, written by DyCheck's
``NovelView.finalize`` (``dycheck/core/tasks/novel_view.py``, read for the facts): each PNG is
``np.concatenate([gt, pred, masked_pred], axis=1)``, panels side by side of one width W, the
ground truth first, the prediction second, both quantised to 8 bit (``to_quantized_float32``)
and written as uint8 by truncation; the third panel exists only when the split has covisibility
masks: ``cov * pred + (1 - cov) * (1 + pred) / 2`` (the prediction, lightened to white outside
the covisible region), so a file is 3W wide, or 2W without masks. ``<split>/checkpoints/``
(training-time snapshots), ``metrics_dict.npz`` and ``mean_metrics_dict.json`` are not frames.
``find_renders`` finds the split folder (given at any level: ``WORK``, ``WORK/renders``,
``.../novel_view`` or the split), ``pair_renders`` pairs panel 2 (prediction) with panel 1
(ground truth). The third panel is not scored: the first file's is only used to tell three
panels from two; for DyCheck's masked numbers pass the dataset's masks (``--masks
DATA/covisible/<factor>x/<split> --protocol dycheck``): its frame names are the files'.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.io.frames import FramePair, FrameRef, Pairing, natural_key, pair_frames
from dynaeval.io.images import decode_file, read_image
from dynaeval.io.masks import image_size

_FACTOR = re.compile(r"^\d+x$")


SPLIT_IDS = ("time_ids", "camera_ids")
"""Optional keys of a DyCheck split file: one whole number per entry of ``frame_names``."""


def _split_error(path: Path, problem: str) -> InputError:
    return InputError(
        f"this DyCheck split file {problem}; it must be a JSON object whose \"frame_names\" is a "
        f"list of frame names (strings, as in rgb/<factor>x/), with {' and '.join(SPLIT_IDS)} "
        "lists of whole numbers of the same length when present (as DyCheck writes it): fix it, "
        "or restore it from the dataset", path=path)


def read_split(path: Path) -> list[str]:
    """The ``frame_names`` of one DyCheck ``splits/<split>.json`` file, checked.

    Raises:
        InputError: unreadable, not JSON, not an object, no ``frame_names``, entries of the wrong
            type, an empty or repeated frame name, or ``time_ids`` / ``camera_ids`` of another
            length or type, naming the file and the problem.
    """
    try:
        doc = json.loads(path.read_bytes())
    except OSError as err:
        raise InputError(f"cannot read this DyCheck split file ({err.strerror or err})",
                         path=path) from err
    except (ValueError, RecursionError) as err:
        raise _split_error(path, f"is not valid JSON ({err})") from None
    if not isinstance(doc, dict):
        raise _split_error(path, f"holds a JSON {type(doc).__name__}, not an object")
    if "frame_names" not in doc:
        raise _split_error(path, f"has no \"frame_names\" (keys: {', '.join(sorted(doc)) or 'none'})")
    names = doc["frame_names"]
    if not isinstance(names, list) or not names:
        raise _split_error(path, "has a \"frame_names\" that is "
                           + ("an empty list" if isinstance(names, list) else
                              f"a {type(names).__name__}, not a list"))
    wrong = next((n for n in names if not isinstance(n, str) or not n), None)
    if wrong is not None:
        raise _split_error(path, f"lists {json.dumps(wrong)} in \"frame_names\", not a frame name")
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1}, key=natural_key)
        raise _split_error(path, f"lists frame names twice in \"frame_names\": {', '.join(twice[:5])}")
    for key in SPLIT_IDS:
        ids = doc.get(key)
        if ids is not None and not (isinstance(ids, list) and len(ids) == len(names) and all(
                isinstance(i, int) and not isinstance(i, bool) for i in ids)):
            raise _split_error(path, f"has a \"{key}\" that is not {len(names)} whole numbers "
                               "(one per frame name)")
    return names


def dycheck_splits(gt_root: str | Path) -> dict[str, set[str]]:
    """Split name -> its frame names, for a ground truth that is DyCheck's ``rgb/<factor>x/``
    (empty when it is not one, or its dataset has no ``splits/``); every ``splits/*.json`` is
    checked (``read_split``), before any frame is paired.

    Raises:
        InputError: a split file that is broken (``read_split``).
    """
    gt_root = Path(gt_root)
    if not (_FACTOR.match(gt_root.name) and gt_root.parent.name == "rgb"):
        return {}
    return {f.stem: set(read_split(f))
            for f in sorted((gt_root.parent.parent / "splits").glob("*.json"))}


def check_split_frames(splits: dict[str, set[str]], frames: set[str], gt_root: Path) -> None:
    """Refuse a split that lists frames the ground truth ``gt_root`` (DyCheck's
    ``rgb/<factor>x/``, whose frame names are ``frames``) does not hold.

    Raises:
        InputError: naming the split file and the frames missing.
    """
    for name, listed in splits.items():
        absent = sorted(listed - frames, key=natural_key)
        if absent:
            shown = ", ".join(absent[:5]) + (f", ... ({len(absent)} in all)" if len(absent) > 5 else "")
            raise InputError(
                f"this DyCheck split lists {len(absent)} frame(s) that {gt_root} does not hold: "
                f"{shown}; the split file and the frames are not of one dataset (or frames were "
                "deleted): restore the frames, or the split file, from the dataset",
                path=gt_root.parent.parent / "splits" / f"{name}.json")


def pair_dycheck(pred_root: str | Path, gt_root: str | Path, *, allow_missing: bool = False) -> Pairing | None:
    """The pairing of one DyCheck split's predictions with its ground truth, or None when
    ``gt_root`` is no DyCheck ``rgb/<factor>x/`` or the predictions fit no single split (the
    ordinary ``pair_frames`` rules then apply).

    Raises:
        InputError: a broken split file (``dycheck_splits``), a split listing frames the ground
            truth does not hold (``check_split_frames``), or a frame of the split with no
            prediction (without ``allow_missing``).
    """
    splits = dycheck_splits(gt_root)
    if not splits:
        return None
    pairing = pair_frames(pred_root, gt_root, allow_missing=True)
    if pairing.unscored_cameras:  # the ground truth has camera folders: not DyCheck's rgb/
        return None
    check_split_frames(splits, {p.frame for p in pairing.pairs}
                       | {s["frame"] for s in pairing.skipped}, Path(gt_root))
    predicted = {p.frame for p in pairing.pairs}
    fits = [name for name, frames in splits.items() if predicted <= frames]
    if len(fits) != 1:
        return None
    split = splits[fits[0]]
    missing = sorted(split - predicted)
    if missing and not allow_missing:
        shown = ", ".join(missing[:5]) + (", ..." if len(missing) > 5 else "")
        raise InputError(f"DyCheck split {fits[0]!r}: {len(missing)} of its frames have no "
                         f"prediction: {shown} (pass --allow-missing to score the others)",
                         path=pred_root)
    skipped = [s for s in pairing.skipped if s["frame"] in split]
    return replace(pairing, skipped=skipped)


# --------------------------------------------------------------------------------------------
# DyCheck's render folder: renders/novel_view/<split>/<frame>.png = gt | pred [| masked pred]

RENDER_PANELS = ("ground truth", "prediction", "prediction masked by covisibility")
"""The panels of a DyCheck novel-view render, left to right (the third only with masks)."""
MASKED_PANEL_MATCH = 0.98
"""Share of the first file's third-panel values that must be the prediction's or the
prediction lightened to white, ``(255 + p) / 2``, within 1 (8-bit truncation), for it to be
read as three panels (else two)."""


@dataclass(frozen=True)
class PanelFrameRef(FrameRef):
    """One panel of a DyCheck render PNG, panels of ``width`` pixels side by side."""

    panel: int = 0
    """0: ground truth, 1: prediction (``RENDER_PANELS``)."""
    width: int = 0
    """Width of one panel in pixels."""
    panels: int = 3
    """Panels in the file (3 with covisibility masks, else 2): its width is ``panels * width``."""

    @property
    def image_file(self) -> None:
        """None: a part of a file, not a whole image (``FrameRef.image_file``)."""
        return None

    def read(self, background: str | float = "white", decode: str = "dynaeval") -> np.ndarray:
        """The panel as (H, width, C) float32 in [0, 1].

        Raises:
            InputError: the file is not ``panels * width`` wide (not like the first render).
        """
        full = read_image(self.path, background=background, decode=decode)
        if full.shape[1] != self.panels * self.width:
            raise InputError(
                f"a DyCheck render here is {self.panels} panels of {self.width} px side by side "
                f"({self.panels * self.width} px wide, as the first file), this one is "
                f"{full.shape[1]} px wide: render the split again", path=self.path)
        return np.ascontiguousarray(full[:, self.panel * self.width:(self.panel + 1) * self.width])

    def size(self) -> tuple[int, int]:
        """(H, W) of the panel, from the file's header (a mask of this frame has this size)."""
        return image_size(self.path)[0], self.width

    def __str__(self) -> str:
        return f"{self.path} ({RENDER_PANELS[self.panel]})"


def _split_dirs(folder: Path) -> list[Path]:
    return sorted((p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")
                   and any(p.glob("*.png"))), key=lambda p: natural_key(p.name))


def find_renders(folder: str | Path) -> Path | None:
    """The ``novel_view/<split>`` folder of a DyCheck render folder given at any level
    (``WORK``, ``WORK/renders``, ``WORK/renders/novel_view``, the split folder), or None when
    ``folder`` is none of these.

    Raises:
        InputError: several splits rendered (naming them), or a ``novel_view`` with none.
    """
    folder = Path(folder)
    if folder.parent.name == "novel_view" and any(folder.glob("*.png")):
        return folder
    for novel in (folder, folder / "novel_view", folder / "renders" / "novel_view"):
        if novel.name == "novel_view" and novel.is_dir():
            splits = _split_dirs(novel)
            if len(splits) == 1:
                return splits[0]
            if not splits:
                raise InputError("DyCheck render folder with no rendered split (novel_view/"
                                 "<split>/<frame>.png)", path=novel)
            raise InputError(f"DyCheck render folder with several splits: "
                             f"{', '.join(p.name for p in splits)}; point at one of them, "
                             f"e.g. {splits[0]}", path=novel)
    return None


def render_panels(path: Path) -> tuple[int, int]:
    """``(panels, panel width)`` of a DyCheck render PNG, from its content: three panels when
    its width is divisible by 3 and the third panel is the masked prediction, else two.

    Raises:
        InputError: a width that is not 2 or 3 panels of one width (naming the file).
    """
    image, _ = decode_file(path)
    w = image.shape[1]
    if w % 3 == 0 and w >= 3:
        scale = 255.0 / np.iinfo(image.dtype).max if image.dtype.kind == "u" else 255.0
        pred, third = (image[:, k * w // 3:(k + 1) * w // 3].astype(np.float64) * scale
                       for k in (1, 2))
        same = (np.abs(third - pred) <= 1) | (np.abs(third - (255 + pred) / 2) <= 1)
        if same.mean() >= MASKED_PANEL_MATCH:
            return 3, w // 3
    if w % 2 == 0 and w >= 2:
        return 2, w // 2
    raise InputError(
        f"a DyCheck novel-view render holds ground truth | prediction | masked prediction side "
        f"by side (3 panels of one width; 2 without covisibility masks); this file is {w} px "
        "wide, not a multiple of 3 (or 2): not a DyCheck render, or cropped after it was written",
        path=path)


def pair_renders(split_dir: str | Path) -> Pairing:
    """The (prediction, ground truth) pairs of a DyCheck ``novel_view/<split>`` folder: one
    camera (``"."``), one frame per ``<frame>.png`` (natural order), panel 2 against panel 1;
    the panel count is the first file's (``render_panels``), checked for each file as read.

    Raises:
        InputError: no PNG, or the first file is not 2 or 3 panels wide.
    """
    split_dir = Path(split_dir)
    files = sorted((p for p in split_dir.glob("*.png") if not p.name.startswith(".")),
                   key=lambda p: natural_key(p.stem))
    if not files:
        raise InputError("no DyCheck render (<frame>.png) in this folder", path=split_dir)
    panels, width = render_panels(files[0])
    pairs = [FramePair(".", f.stem, i, PanelFrameRef(f, panel=1, width=width, panels=panels),
                       PanelFrameRef(f, panel=0, width=width, panels=panels))
             for i, f in enumerate(files)]
    return Pairing(pairs=pairs)

"""DyCheck's dataset layout as ground truth: ``DATA/rgb/<factor>x/`` holds every frame (training
and test views), ``DATA/splits/<split>.json`` lists each split's ``frame_names``.

Predictions of one split (``1_00000.png``, ...) are paired with that split's ground truth only:
``pair_dycheck`` pairs them when the predicted frames all belong to exactly one split, so the
training frames are neither an error nor "skipped"; a frame of the split with no prediction is
still an error (unless ``allow_missing``). Covisibility masks: ``dynaeval.io.masks``.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

from dynaeval.errors import InputError
from dynaeval.io.frames import Pairing, pair_frames

_FACTOR = re.compile(r"^\d+x$")


def dycheck_splits(gt_root: str | Path) -> dict[str, set[str]]:
    """Split name -> its frame names, for a ground truth that is DyCheck's ``rgb/<factor>x/``
    (empty when it is not one, or its dataset has no readable ``splits/``)."""
    gt_root = Path(gt_root)
    if not (_FACTOR.match(gt_root.name) and gt_root.parent.name == "rgb"):
        return {}
    out = {}
    for f in sorted((gt_root.parent.parent / "splits").glob("*.json")):
        try:
            names = json.loads(f.read_text())["frame_names"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if isinstance(names, list) and all(isinstance(n, str) for n in names):
            out[f.stem] = set(names)
    return out


def pair_dycheck(pred_root: str | Path, gt_root: str | Path, *, allow_missing: bool = False) -> Pairing | None:
    """The pairing of one DyCheck split's predictions with its ground truth, or None when
    ``gt_root`` is no DyCheck ``rgb/<factor>x/`` or the predictions fit no single split (the
    ordinary ``pair_frames`` rules then apply).

    Raises:
        InputError: a frame of the split has no prediction (without ``allow_missing``).
    """
    splits = dycheck_splits(gt_root)
    if not splits:
        return None
    pairing = pair_frames(pred_root, gt_root, allow_missing=True)
    predicted = {p.frame for p in pairing.pairs}
    fits = [name for name, frames in splits.items() if predicted <= frames]
    if len(fits) != 1 or pairing.unscored_cameras:
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

"""A pre-trained empty stadium: the static field learnt once per scene and camera rig, the start of
every run on that scene.

The seed study's suggestion: the stadium does not move, so learn it once — from the same cameras
filming it without players and ball (``python -m reference_models.scenes render PRESET OUT
--hide person --hide ball --frames 1``) — and start every model and sampling run of the clip from
those weights, so their comparison stays fair and their clip minutes go to what moves. The
stadium run builds exactly the model a clip run builds (the clip's scene box, frames, moving box
and footprint planes: ``train(..., scene_data=CLIP)``) and trains only its static part
(``static_warmup=1``: planes with a time axis are not looked up and stay 1) on uniformly drawn
rays of the empty stadium. A clip run then starts from it with ``train(..., init=STADIUM)``, which
checks that model, size and scene match and records the stadium's checkpoint digest and its
training seconds in ``config.json``, so a report can say "30 clip minutes + P stadium minutes".

Only fields with a static part can be pre-trained this way (K-Planes; NeRFPlayer's temporal hash
grid has none).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dynaeval.errors import InputError
from reference_models.common.data import Views, load_dataset
from reference_models.common.train import ModelSpec, train


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


def train_stadium(spec: ModelSpec, clip_data: str | Path, stadium_data: str | Path,
                  out: str | Path, size: str = "small", iters: int | None = None,
                  progress: bool = True, overrides: dict | None = None,
                  resume: bool = False, device: str = "cpu") -> dict:
    """Pre-train the static part of ``spec``'s ``size`` model for the clip at ``clip_data`` on the
    empty stadium at ``stadium_data`` into the run folder ``out`` (``overrides``: TrainConfig
    fields, e.g. a ``minutes`` budget; the sampling is uniform and the whole run static;
    ``resume`` continues an interrupted pre-training from its checkpoint; ``device`` as
    ``train``'s).
    Returns the last log record. Raises InputError when the two datasets' cameras differ or the
    model has no static part."""
    clip, stadium = load_dataset(clip_data), load_dataset(stadium_data)
    check_same_rig(clip.train, stadium.train, Path(stadium_data))
    over = {**(overrides or {}), "static_warmup": 1.0}
    if resume:
        return train(spec, None, out, iters=iters, resume=True, progress=progress, overrides=over,
                     device=device)
    return train(spec, stadium_data, out, size=size, iters=iters, sampling="uniform",
                 progress=progress, overrides=over, scene_data=clip_data, device=device)

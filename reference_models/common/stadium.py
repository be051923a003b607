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

from reference_models.common.train import ModelSpec, train


def train_stadium(spec: ModelSpec, clip_data: str | Path, stadium_data: str | Path,
                  out: str | Path, size: str = "small", iters: int | None = None,
                  progress: bool = True, overrides: dict | None = None,
                  resume: bool = False, device: str = "cpu") -> dict:
    """Pre-train the static part of ``spec``'s ``size`` model for the clip at ``clip_data`` on the
    empty stadium at ``stadium_data`` into the run folder ``out`` (``overrides``: TrainConfig
    fields, e.g. a ``minutes`` budget; the sampling is uniform and the whole run static;
    ``resume`` continues an interrupted pre-training from its checkpoint; ``device`` as
    ``train``'s).
    Returns the last log record. Raises InputError when the two datasets' cameras differ
    (``data.check_same_rig``, checked by ``train``) or the model has no static part."""
    over = {**(overrides or {}), "static_warmup": 1.0}
    if resume:
        return train(spec, None, out, iters=iters, resume=True, progress=progress, overrides=over,
                     device=device)
    return train(spec, stadium_data, out, size=size, iters=iters, sampling="uniform",
                 progress=progress, overrides=over, scene_data=clip_data, device=device)

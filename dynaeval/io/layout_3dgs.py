"""The 3DGS family's render folders: gaussian-splatting, 4DGaussians, Deformable-3DGS and forks.

Their ``render.py`` (read, not copied) writes, for each split it renders and the iteration it
loaded::

    MODEL/test/ours_30000/renders/00000.png    predictions, torchvision.utils.save_image (8 bit)
    MODEL/test/ours_30000/gt/00000.png         ground truth, same names
    MODEL/train/ours_30000/...                 the training views (unless --skip_train)

and ``metrics.py`` scores every ``MODEL/test/ours_*`` into ``MODEL/results.json`` and
``MODEL/per_view.json``. ``find_3dgs`` accepts any of the three levels:

* ``MODEL``: the ``test`` split (or ``split``), its latest iteration (or ``iteration``);
* ``MODEL/test``: its latest iteration (or ``iteration``);
* ``MODEL/test/ours_14000`` (or any folder holding ``renders/`` + ``gt/``): that one.

Other iterations and splits are listed in the layout's notes (the run's warnings). Folders of an
iteration without ``gt/`` (4DGaussians' ``video`` split, Deformable-3DGS' ``interpolate_*``) are
not scoreable and are skipped.

Frames are a time sequence only for the dynamic methods: 4DGaussians on DyNeRF renders the
held-out ``cam00`` at every time step in order (one static camera over time); Deformable-3DGS and
4DGaussians on D-NeRF / HyperNeRF render the test views in time order, each from its own
camera pose. gaussian-splatting's test views are every 8th photograph of a static capture:
different cameras, no time. The method is recognised from what its ``render.py`` leaves
(``family_of``): ``video_rgb.mp4`` or ``deformation.pth`` (4DGaussians), ``depth/`` or
``deform/`` (Deformable-3DGS); otherwise static.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError

ITERATION_DIR = re.compile(r"ours_(\d+)")
"""Name of one iteration's folder: ``ours_<iteration>``."""
PRED_DIR, GT_DIR = "renders", "gt"
DEFAULT_SPLIT = "test"
DYNAMIC_FAMILIES = ("4DGaussians", "Deformable-3DGS")


def _scoreable(folder: Path) -> bool:
    return (folder / PRED_DIR).is_dir() and (folder / GT_DIR).is_dir()


def iterations_in(split_dir: Path) -> dict[int, Path]:
    """``{iteration: folder}`` of the scoreable ``ours_<N>`` folders of one split, ascending."""
    found = {}
    if split_dir.is_dir():
        for sub in split_dir.iterdir():
            m = ITERATION_DIR.fullmatch(sub.name)
            if m and _scoreable(sub):
                found[int(m.group(1))] = sub
    return dict(sorted(found.items()))


def family_of(iteration_dir: Path) -> str:
    """Which method wrote ``MODEL/<split>/ours_<N>``: ``4DGaussians``, ``Deformable-3DGS`` or
    ``gaussian-splatting`` (no dynamic method's traces)."""
    model = iteration_dir.parent.parent
    if (iteration_dir / "video_rgb.mp4").is_file() or any(
            model.glob("point_cloud/iteration_*/deformation.pth")):
        return "4DGaussians"
    if (iteration_dir / "depth").is_dir() or (model / "deform").is_dir():
        return "Deformable-3DGS"
    return "gaussian-splatting"


def family_protocol(family: str) -> str:
    """The ``--protocol`` of a family's own ``metrics.py``: ``4dgaussians`` for 4DGaussians'
    (3DGS' metrics plus MS-SSIM, D-SSIM and LPIPS-alex), else ``3dgs``. A run only names it in a
    warning and never switches to it: the family is guessed from what ``render.py`` leaves
    (``family_of``), and numbers must not change with files beside the renders."""
    return "4dgaussians" if family == "4DGaussians" else "3dgs"


def _pick_iteration(split_dir: Path, iteration: int | None) -> tuple[Path, list[str]]:
    found = iterations_in(split_dir)
    if iteration is None:
        chosen = max(found)
    elif iteration not in found:
        raise InputError(f"no iteration {iteration} rendered in this split (ours_<N> folders with "
                         f"renders/ and gt/: {', '.join(map(str, found))})", path=split_dir)
    else:
        chosen = iteration
    notes = []
    if len(found) > 1:
        others = ", ".join(f"ours_{n}" for n in found if n != chosen)
        why = "the latest iteration" if iteration is None else "as asked"
        notes.append(f"3DGS render folder: scored {split_dir.name}/ours_{chosen} ({why}); also "
                     f"rendered: {others} (choose with --iteration N / iteration=N)")
    return found[chosen], notes


def _pick_split(model: Path, split: str | None) -> tuple[Path, list[str]]:
    splits = sorted(p.name for p in model.iterdir() if p.is_dir() and iterations_in(p))
    name = split or DEFAULT_SPLIT
    if name not in splits:
        raise InputError(f"3DGS model folder has no scoreable {name!r} split (splits with "
                         f"ours_<N>/renders + gt: {', '.join(splits)}); choose one with --split",
                         path=model)
    others = [s for s in splits if s != name]
    notes = [f"3DGS model folder: scored the {name} split; also rendered: {', '.join(others)} "
             "(choose with --split NAME / split=NAME)"] if others else []
    return model / name, notes


def _refuse_renders_without_gt(folder: Path) -> None:
    """InputError when ``folder`` looks like a 3DGS render whose ``gt/`` is missing everywhere."""
    if not folder.is_dir():
        return
    levels = [folder, *(p for p in folder.iterdir() if p.is_dir())]
    candidates = [folder] if ITERATION_DIR.fullmatch(folder.name) else []
    for level in levels:
        candidates += [p for p in level.iterdir() if p.is_dir() and ITERATION_DIR.fullmatch(p.name)]
    half = [p for p in candidates if (p / PRED_DIR).is_dir() and not (p / GT_DIR).is_dir()]
    if half:
        raise InputError(f"3DGS render folder without ground truth: {half[0]} has {PRED_DIR}/ but "
                         f"no {GT_DIR}/ (was render.py interrupted, or is this a split without "
                         "ground truth, like 4DGaussians' video/?)", path=folder)


def find_3dgs(folder: Path, *, iteration: int | None = None,
              split: str | None = None) -> tuple[Path, dict[str, Any], list[str]] | None:
    """The iteration folder to score when ``folder`` is a 3DGS-family render (module docstring).

    Args:
        folder: ``MODEL``, ``MODEL/<split>`` or ``MODEL/<split>/ours_<N>``.
        iteration: the ``<N>`` to score (default: the latest rendered).
        split: the split to score from ``MODEL`` (default ``test``).

    Returns:
        ``(iteration folder, details, notes)`` — details for the results' ``inputs.layout``
        (family, split, iteration, model, sequence), notes for the run's warnings — or None
        when ``folder`` is not a 3DGS-family render.

    Raises:
        InputError: the asked iteration or split is not there, or does not match the folder.
    """
    notes: list[str] = []
    if _scoreable(folder):
        ours = folder
        m = ITERATION_DIR.fullmatch(folder.name)
        if iteration is not None and (m is None or int(m.group(1)) != iteration):
            raise InputError(f"--iteration {iteration} asked but this is the folder of one "
                             "iteration; point at MODEL or MODEL/<split> to choose", path=folder)
    elif iterations_in(folder):
        ours, notes = _pick_iteration(folder, iteration)
    elif folder.is_dir() and any(iterations_in(p) for p in folder.iterdir() if p.is_dir()):
        split_dir, notes = _pick_split(folder, split)
        ours, more = _pick_iteration(split_dir, iteration)
        notes += more
    else:
        _refuse_renders_without_gt(folder)
        return None
    if split is not None and ours.parent.name != split and ours.parent.parent != folder:
        raise InputError(f"--split {split} asked but this folder is of split {ours.parent.name!r}",
                         path=folder)
    family = family_of(ours)
    m = ITERATION_DIR.fullmatch(ours.name)
    details = {"family": family, "split": ours.parent.name,
               "iteration": int(m.group(1)) if m else None, "model": str(ours.parent.parent),
               "sequence": family in DYNAMIC_FAMILIES}
    if family in DYNAMIC_FAMILIES:
        notes.append(f"{family} render folder: its test views are scored as one time sequence "
                     "(true for DyNeRF's held-out camera; on D-NeRF / HyperNeRF each view has "
                     "its own camera pose: pass --no-temporal there)")
    return ours, details, notes

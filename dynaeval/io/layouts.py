"""Render-folder layouts of other tools, so ``dynaeval score`` reads them without renaming.

Rules (docs/integration.md repeats them with examples):

1. ``score RUN`` (one folder): RUN, or exactly one of its direct sub-folders, must hold a pair of
   sibling folders of a known layout:

   * NeRFBaselines (``nerfbaselines render`` / ``evaluate`` output): ``color/`` (predictions) and
     ``gt-color/`` (ground truth), same relative file names;
   * nerfstudio ``ns-render dataset --rendered-output-names rgb gt-rgb``: ``rgb/`` and ``gt-rgb/``
     (ns-render writes them under ``OUT/<split>/``, hence the one level of sub-folders);
   * the same with ``raw-rgb raw-gt-rgb`` (``nerfstudio-raw``): ``raw-rgb/`` and ``raw-gt-rgb/``
     of ``<frame>.npy.gz`` files, each the float render or ground-truth tensor ``np.save``'d into
     ``gzip.open`` (nerfstudio ``scripts/render.py`` ``DatasetRender``: ``(H, W, 3)`` float32 in
     [0, 1], read under the float-file range rule of ``dynaeval.io.images``); with ``rgb/`` +
     ``gt-rgb/`` beside them in the same folder, the float ones are scored (a note says so).

   Several matches (e.g. ``test/`` and ``train/`` splits) are an error listing them: point at one.
   The 3DGS family (gaussian-splatting, 4DGaussians, Deformable-3DGS: ``MODEL/<split>/ours_<N>/
   renders/`` + ``gt/``) is read at any of its levels, ``MODEL``, ``MODEL/test`` or
   ``MODEL/test/ours_<N>``, its latest iteration of the ``test`` split unless ``iteration`` /
   ``split`` say otherwise (``dynaeval.io.layout_3dgs``).
2. ``score PRED GT`` (two folders): used as given, so ``score RUN/color RUN/gt-color`` works too.
   If PRED is itself a render folder (holds ``color/`` + ``gt-color/`` or ``rgb/`` + ``gt-rgb/``)
   and GT is the same folder, rule 1 applies; the same ordinary folder twice is scored as given
   (the ground truth against itself: a sanity check that gives the ideal values).
3. K-Planes ``step<N>.mp4`` (or ``step<N>-<i>.png``), one file given alone, or a K-Planes log
   folder (no layout above), whose latest ``step<N>.mp4`` (else ``step<N>-*.png`` set) is read:
   each frame stacks prediction, ground truth and an error map vertically
   (``dynaeval.io.kplanes``); its pairs come from ``kplanes.pair_stack``.
4. DyCheck's own render folder ``WORK/renders/novel_view/<split>/<frame>.png`` (ground truth,
   prediction and masked prediction side by side), read at any of its levels: its pairs come
   from ``dycheck.pair_renders`` (``dynaeval.io.dycheck``).
5. nerfstudio ``ns-eval --render-output-path`` writes ``NNNNNN-img.jpg`` files that hold the ground
   truth and the prediction side by side in one 8-bit JPEG: they are refused with a message
   (JPEG loss and the shared file make them unfit for scoring); render with ``ns-render`` instead.

Frames in these folders are usually *different test views*, not a video: the layout says so
(``sequence=False``), and the CLI warns that temporal metrics then compare unrelated views.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

from dynaeval.core.errors import InputError
from dynaeval.io.dycheck import (
    RENDER_PANELS,
    PanelFrameRef,
    find_renders,
    pair_dycheck,
    pair_renders,
    render_panels,
)
from dynaeval.io.frames import Pairing, pair_frames
from dynaeval.io.kplanes import (
    STACK_PARTS,
    StackedFrameRef,
    check_stack,
    describe_stack,
    is_stack_file,
    latest_stacks,
    pair_stack,
)
from dynaeval.io.layout_3dgs import GT_DIR, PRED_DIR, family_protocol, find_3dgs

LAYOUTS: dict[str, tuple[str, str]] = {
    "nerfbaselines": ("color", "gt-color"),
    "nerfstudio": ("rgb", "gt-rgb"),
    "nerfstudio-raw": ("raw-rgb", "raw-gt-rgb"),
}
"""Layout name -> (prediction folder, ground-truth folder), siblings in one render folder."""


@dataclass(frozen=True)
class RenderLayout:
    """Where predictions and ground truth of one run are, and what wrote them."""

    name: str
    """``nerfbaselines``, ``nerfstudio``, ``nerfstudio-raw``, ``3dgs``, ``kplanes`` (a stack file
    or a K-Planes log folder: ``pred`` and ``gt`` are that path, ``kplanes.pair_stack`` pairs
    it), ``dycheck`` (a ``novel_view/<split>`` folder, ``pred`` and ``gt`` both, paired by
    ``dycheck.pair_renders``) or ``folders`` (PRED and GT as given)."""
    pred: Path
    """Folder of predictions."""
    gt: Path
    """Folder of ground truth."""
    root: Path | None = None
    """The render folder the pair was found in (None for ``folders``)."""
    sequence: bool = True
    """False when frames are independent test views (temporal metrics are then meaningless)."""
    details: dict[str, Any] = field(default_factory=dict)
    """What the layout found besides the folders (3DGS: family, split, iteration, model), for
    the results' ``inputs.layout``."""
    notes: tuple[str, ...] = ()
    """Messages for the run's warnings (other iterations or splits rendered, ...)."""

    @property
    def kind(self) -> LayoutKind:
        """What this kind of layout does differently (``LAYOUT_KINDS``; a ``LAYOUTS`` sibling
        pair: the default)."""
        return layout_kind(self.name)


class LayoutKind:
    """One kind of input layout: how its frames pair and what it tells the run. The default is a
    render folder of sibling prediction / ground-truth folders (``LAYOUTS``); a kind that differs
    overrides the method, and the run reads the kind, never the layout's name."""

    render_folder: ClassVar[bool] = True
    """A render folder of a known tool (False: PRED and GT given as ordinary folders): it names
    the run and is described in the results' ``inputs.layout``."""

    def pairing(self, layout: RenderLayout, allow_missing: bool) -> Pairing:
        """The frame pairs (a DyCheck ``rgb/<factor>x/`` ground truth paired by its rules)."""
        return (pair_dycheck(layout.pred, layout.gt, allow_missing=allow_missing)
                or pair_frames(layout.pred, layout.gt, allow_missing=allow_missing))

    def run_folder(self, layout: RenderLayout, pred_dir: Path) -> Path:
        """The folder whose name is the run's default method and scene name."""
        return Path(layout.details.get("model", pred_dir))

    def own_protocol(self, layout: RenderLayout) -> str | None:
        """The ``--protocol`` of the tool that wrote it, when the run should say so if another is
        used (None: no such protocol)."""
        return None

    def describe(self, layout: RenderLayout, pairing: Pairing) -> dict[str, Any]:
        """More fields of the results' ``inputs.layout``."""
        return {}

    def scored(self, inputs: dict[str, Any]) -> str:
        """What a run of this layout scored against what, from the results' ``inputs`` (its
        ``layout`` section present): the line ``dynaeval score`` prints."""
        return (f"{inputs['layout']['name']} render folder: scored {inputs['pred']} against "
                f"{inputs['gt']}")

    def gs_run_key(self, described: dict[str, Any]) -> str | None:
        """The top-level key of the 3DGS results files for a run of this layout (``described``:
        the results' ``inputs.layout``), or None: the method's name."""
        return None


class _Folders(LayoutKind):
    """PRED and GT as given."""

    render_folder = False


class _KPlanesStack(LayoutKind):
    """A K-Planes stack file or log folder: prediction and ground truth in one image."""

    def pairing(self, layout: RenderLayout, allow_missing: bool) -> Pairing:
        return pair_stack(layout.pred)

    def run_folder(self, layout: RenderLayout, pred_dir: Path) -> Path:
        return layout.root

    def describe(self, layout: RenderLayout, pairing: Pairing) -> dict[str, Any]:
        return {"stack": describe_stack(pairing)}

    def scored(self, inputs: dict[str, Any]) -> str:
        files = inputs["layout"]["stack"]["files"]
        shown = files[0] if len(files) == 1 else f"{len(files)} files ({files[0]}, ...)"
        return (f"K-Planes evaluation stack: scored the top third (prediction) of {shown} "
                "against its middle third (ground truth)")


class _DyCheckRenders(LayoutKind):
    """DyCheck's ``novel_view/<split>`` folder: the panels of one file."""

    def pairing(self, layout: RenderLayout, allow_missing: bool) -> Pairing:
        return pair_renders(layout.pred)

    def run_folder(self, layout: RenderLayout, pred_dir: Path) -> Path:
        """The experiment folder above ``renders/novel_view/<split>`` (its split was the run's
        name: "val against val"), else the folder given."""
        split = Path(layout.pred)
        if split.parent.name == "novel_view" and split.parent.parent.name == "renders":
            return split.parent.parent.parent
        return Path(pred_dir)


class _GaussianSplatting(LayoutKind):
    """A 3DGS-family model folder, whose own metrics are its family's protocol."""

    def own_protocol(self, layout: RenderLayout) -> str | None:
        return family_protocol(layout.details["family"])

    def gs_run_key(self, described: dict[str, Any]) -> str | None:
        """``ours_<N>``, the render's iteration, as the 3DGS family's own files name it."""
        it = described.get("iteration")
        return None if it is None else f"ours_{it}"


SIBLING_FOLDERS = LayoutKind()
"""The kind of every ``LAYOUTS`` entry (sibling prediction / ground-truth folders)."""
LAYOUT_KINDS: dict[str, LayoutKind] = {
    "folders": _Folders(), "kplanes": _KPlanesStack(), "dycheck": _DyCheckRenders(),
    "3dgs": _GaussianSplatting()}
"""The kinds that differ from ``SIBLING_FOLDERS``, by ``RenderLayout.name``."""


def layout_kind(name: str) -> LayoutKind:
    """The kind of the layout named ``name`` (a ``RenderLayout.name``, or the results'
    ``inputs.layout.name`` read back)."""
    return LAYOUT_KINDS.get(name, SIBLING_FOLDERS)


def _pairs_in(folder: Path) -> list[RenderLayout]:
    found = {}
    for name, (pred, gt) in LAYOUTS.items():
        if (folder / pred).is_dir() and (folder / gt).is_dir():
            found[name] = RenderLayout(name, folder / pred, folder / gt, folder, sequence=False)
    if "nerfstudio" in found and "nerfstudio-raw" in found:  # one ns-render: its float frames
        raw = found.pop("nerfstudio-raw")
        found["nerfstudio"] = replace(raw, notes=(
            f"ns-render wrote both 8-bit ({found['nerfstudio'].pred}/) and float (raw-rgb/) "
            "frames here: the float ones are scored (ns-eval's metrics are on the float render); "
            f"pass {found['nerfstudio'].pred} {found['nerfstudio'].gt} as PRED GT for the 8-bit "
            "files",))
    return list(found.values())


def _check_not_ns_eval(folder: Path) -> None:
    if folder.is_dir() and any(folder.glob("[0-9]*-img.jpg")):
        raise InputError(
            "this looks like an 'ns-eval --render-output-path' folder: its NNNNNN-img.jpg files "
            "hold ground truth and prediction side by side in one 8-bit JPEG, which dynaeval does "
            "not score; write separate frames with 'ns-render dataset --rendered-output-names rgb "
            "gt-rgb --image-format png' and score that folder",
            path=folder,
        )


def _stack_layout(path: Path) -> RenderLayout:
    """A K-Planes evaluation stack (``step<N>.mp4``, ``step<N>-<i>.png``) given alone."""
    if not is_stack_file(path):
        raise InputError(
            "one file was given: dynaeval reads a single file only as K-Planes' evaluation stack "
            "(prediction, ground truth and error map stacked vertically), named step<N>.mp4 or "
            "step<N>-<i>.png; pass PRED and GT folders (or videos in them) otherwise",
            path=path,
        )
    check_stack(path)  # the height is three parts, before any work
    return RenderLayout("kplanes", path, path, path.parent, sequence=True)


def _layout_3dgs(folder: Path, iteration: int | None, split: str | None) -> RenderLayout | None:
    found = find_3dgs(folder, iteration=iteration, split=split)
    if found is None:
        return None
    ours, details, notes = found
    return RenderLayout("3dgs", ours / PRED_DIR, ours / GT_DIR, ours,
                        sequence=details["sequence"], details=details, notes=tuple(notes))


def _check_no_selection(iteration: int | None, split: str | None, pred: Path) -> None:
    if iteration is not None or split is not None:
        asked = " and ".join(f"--{k} {v}" for k, v in (("iteration", iteration), ("split", split))
                             if v is not None)
        raise InputError(f"{asked} only selects within a 3DGS-family render folder "
                         "(MODEL/<split>/ours_<N>/renders + gt), which this is not", path=pred)


def detect_layout(pred: str | Path, gt: str | Path | None = None, *,
                  iteration: int | None = None, split: str | None = None) -> RenderLayout:
    """Find the prediction and ground-truth folders of a run (rules in the module docstring).

    Args:
        pred: a render folder (with ``gt`` None or equal to it), or the prediction folder.
        gt: the ground-truth folder, or None.
        iteration, split: which ``ours_<N>`` and split of a 3DGS-family render to score
            (default: the latest, ``test``); an error for any other layout.

    Returns:
        RenderLayout; ``name="folders"`` when PRED and GT are ordinary folders used as given.

    Raises:
        InputError: one folder given that holds no known pair (or several), a missing folder, or
            an ns-eval side-by-side folder.
    """
    pred = Path(pred)
    same = gt is not None and Path(gt).resolve() == pred.resolve()
    if gt is not None and not same:
        for folder in (pred, Path(gt)):
            _check_not_ns_eval(folder)
        _check_no_selection(iteration, split, pred)
        return RenderLayout("folders", pred, Path(gt))
    if (gt is None or same) and pred.is_file():
        return _stack_layout(pred)
    if not pred.is_dir():
        raise InputError("render folder not found (or not a folder)", path=pred)
    _check_not_ns_eval(pred)
    layout = _layout_3dgs(pred, iteration, split)
    if layout is not None:
        return layout
    _check_no_selection(iteration, split, pred)

    renders = find_renders(pred)
    if renders is not None:  # DyCheck's panels: pairs from dycheck.pair_renders
        return RenderLayout("dycheck", renders, renders, renders, sequence=False,
                            details={"split": renders.name})
    found = _pairs_in(pred)
    if not found:
        for sub in sorted(p for p in pred.iterdir() if p.is_dir() and not p.name.startswith(".")):
            found += _pairs_in(sub)
    if len(found) == 1:
        return found[0]
    if not found:
        stacks = latest_stacks(pred)
        if stacks:  # a K-Planes log folder: its latest evaluation
            video = len(stacks) == 1 and stacks[0].suffix.lower() != ".png"
            return RenderLayout("kplanes", pred, pred, pred, sequence=video)
    if same and not found:  # PRED and GT are one ordinary folder: a self-check, scored as given
        return RenderLayout("folders", pred, pred)
    raise _no_single_layout(pred, found)


def _no_single_layout(pred: Path, found: list[RenderLayout]) -> InputError:
    """The error of a folder that holds no known render layout (``found`` empty: the known ones
    listed) or several (``found``: each named)."""
    known = "; ".join([*(f"{n}: {p}/ + {g}/" for n, (p, g) in LAYOUTS.items()),
                       "3dgs: MODEL/<split>/ours_<N>/renders/ + gt/",
                       "dycheck: renders/novel_view/<split>/<frame>.png",
                       "kplanes: a log folder with step<N>.mp4 or step<N>-<i>.png, or one such "
                       "file"])
    if not found:
        return InputError(
            f"one folder was given but it holds no known render layout ({known}), neither directly "
            "nor in a sub-folder; pass PRED and GT folders instead",
            path=pred,
        )
    listing = ", ".join(f"{f.root.relative_to(pred).as_posix() or '.'} ({f.name})" for f in found
                        if f.root is not None)
    return InputError(
        f"several render layouts found: {listing}; point at one of these folders", path=pred
    )


def part_ref_from_text(text: str) -> Any:
    """The frame reference written as ``str(ref)`` for one part of a file that holds several
    (``"step30000.mp4#4 (prediction)"``: a K-Planes stack; ``"1_00000.png (ground truth)"``: a
    DyCheck render), read back so a report can show it; None for any other text.

    Raises:
        InputError: as ``kplanes.check_stack`` / ``dycheck.render_panels`` for the file.
    """
    where, sep, part = text.rpartition(" (")
    file, _, index = where.rpartition("#") if "#" in where else (where, "", "")
    path, part = Path(file), part[:-1] if part.endswith(")") else None
    if not sep or part is None or not path.is_file() or (index and not index.isdigit()):
        return None
    if is_stack_file(path) and part in STACK_PARTS:
        return StackedFrameRef(path, int(index) if index else None,
                               part=STACK_PARTS.index(part), rows=check_stack(path)[0])
    if not index and part in RENDER_PANELS:
        panels, width = render_panels(path)
        return PanelFrameRef(path, panel=RENDER_PANELS.index(part), width=width, panels=panels)
    return None

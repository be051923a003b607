"""The kinds of focus source (``--focus detector|motion|boxes:FILE|none``), one class each.

A kind says what it is once, as data its users read: whether it gives boxes (the ``focused_*``
variants), runs the detector on each ground-truth frame, reads a boxes file, makes its boxes from
the motion masks, gives boxes with classes (object presence, ``--classes``), why a frame has no
box, and what the run's "no box anywhere" headline calls what found nothing.
``dynaeval.regions.focus`` (opening the sources, each frame's boxes), the run (plan, scoring, the
temporal stage, ``evaluate``) and the results (the headline) branch on these facts, never on the
name (issue 41: the name was compared as a string literal at ~17 sites;
``tests/dynaeval/test_architecture.py`` holds it).

Adding a kind: a subclass here, registered in ``SOURCE_KINDS``, and where its boxes come from in
``regions.focus`` (``open_sources``, ``_frame_boxes``); docs/architecture.md "Where do I add X".
Light: imports nothing of dynaeval but the ground floor.
"""

from __future__ import annotations

from typing import ClassVar

from dynaeval.core.errors import InputError, did_you_mean


class FocusSource:
    """One kind of focus source; its facts as class attributes (subclasses set them)."""

    name: ClassVar[str] = ""
    """The name of ``--focus`` and of the results' ``settings.focus.source`` and
    ``regions.source``."""
    spec: ClassVar[str] = ""
    """How ``--focus`` spells it (``boxes:FILE`` for a boxes file)."""
    gives_boxes: ClassVar[bool] = True
    """Frames get focus boxes: the ``focused_*`` variants are computed (False: ``none``)."""
    detects: ClassVar[bool] = False
    """Runs the ONNX detector on every ground-truth frame (``--detector``, ``--classes``)."""
    reads_file: ClassVar[bool] = False
    """Reads the boxes from a boxes file (``dynaeval detect`` or a scene generator's)."""
    from_motion: ClassVar[bool] = False
    """Makes its boxes from the motion masks (they are computed even with ``--no-masked``; a
    moving camera spoils them; a video is needed)."""
    classed: ClassVar[bool] = False
    """Its boxes carry object classes: object presence can run."""
    no_box: ClassVar[str] = ""
    """Why a frame has no box when this source found none there (the focused metrics' null)."""
    none_found: ClassVar[str] = "the focus source found none"
    """The run's no-box headline (``dynaeval.core.outcome.no_box_reason``): what found none."""
    none_found_fix: ClassVar[str] = "check the focus source, or score with --focus none"
    """The headline's fix."""

    def nothing_found(self, bundled_detector: bool, classes: str) -> tuple[str, str]:
        """``(what found none, the fix)`` for the run's no-box headline; ``bundled_detector``:
        the boxes came from the detector shipped with dynaeval; ``classes``: those kept."""
        return self.none_found, self.none_found_fix


class DetectorSource(FocusSource):
    """The ONNX detector on the ground truth (the bundled one, or ``--detector``)."""

    name = spec = "detector"
    detects = classed = True
    no_box = "the detector found no object in the ground truth"
    none_found = "the detector found none"

    def nothing_found(self, bundled_detector: bool, classes: str) -> tuple[str, str]:
        if bundled_detector:
            return ("the bundled synthetic-scene detector found none",
                    "the bundled detector knows only dynaeval's synthetic scenes: for real "
                    "footage fetch a COCO detector (dynaeval detector fetch retinanet, then "
                    "--detector retinanet) or score with --focus motion")
        return (self.none_found, f"check --classes (the detector keeps: {classes}) and that the "
                "footage is what the detector was trained on, or score with --focus motion")


class MotionSource(FocusSource):
    """Connected components of each static camera's motion masks."""

    name = spec = "motion"
    from_motion = True
    no_box = "no moving region in the ground truth"
    none_found = "the motion masks hold no moving region"
    none_found_fix = ("motion boxes need a static camera and moving objects: score with --focus "
                      "detector or --focus boxes:FILE")


class BoxesFileSource(FocusSource):
    """A boxes file (``--focus boxes:FILE``)."""

    name = "boxes"
    spec = "boxes:FILE"
    reads_file = classed = True
    no_box = "the boxes file lists no box for this frame"
    none_found = "the boxes file lists none"
    none_found_fix = ("check that the file's keys are '<camera>/<frame>' of these frames "
                      "(dynaeval detect GT -o boxes.json writes them)")


class NoFocus(FocusSource):
    """No focus regions: the whole frame only (``--focus none``)."""

    name = spec = "none"
    gives_boxes = False


SOURCE_KINDS: dict[str, FocusSource] = {
    k.name: k() for k in (DetectorSource, MotionSource, BoxesFileSource, NoFocus)}
"""Every kind of focus source by name, in ``--focus`` order: the one place that lists them."""

BOXES_FILE_PREFIX = "boxes:"
"""``--focus boxes:FILE``: the prefix before the file name."""


def focus_source(name: object, what: str = "focus source") -> FocusSource:
    """The kind called ``name``.

    Raises:
        InputError: no such kind (the known ones listed, the closest suggested).
    """
    if not isinstance(name, str) or name not in SOURCE_KINDS:
        raise InputError(f"{what} must be one of {tuple(SOURCE_KINDS)}, got {name!r}"
                         f"{did_you_mean(name, SOURCE_KINDS)}")
    return SOURCE_KINDS[name]

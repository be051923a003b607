"""What became of a value, as data: ``Outcome(value, status, detail)`` and the one place that
turns a status into the text of a warning.

Every ``null`` of a results file has a ``Status`` beside it (the ``status`` of its warning, and
``summary_status`` for a null summary value; docs/results-format.md): code that needs to know
why a value is missing reads the status, never the text. The text (``reason``) is for people
and is made here, from the status and a ``detail`` the finding site gives (what, where, how to
fix), so a message can change without changing what any code decides.

Ground floor: every layer may import this module; it imports nothing of dynaeval.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any


class Status(str, Enum):
    """Why a value is what it is. The string is what results files hold (``"no-region"``)."""

    OK = "ok"
    """A finite value."""
    INFINITE = "infinite"
    """+infinity (PSNR of a prediction equal to its ground truth), written as null."""
    EMPTY_REGION = "empty-region"
    """The region to score holds no pixel (an empty box or mask, every pixel occluded, an
    empty static mask)."""
    NO_REGION = "no-region"
    """The frame, pair or camera has no region at all (no box, no mask, no object of a class,
    no region asked for); as a run-level warning without a metric: no box in any frame."""
    NOT_A_VIDEO = "not-a-video"
    """The frames are not one video (their sizes differ, separate test views)."""
    NOT_CONSECUTIVE = "not-consecutive"
    """The two frames of a pair, or a video's frames, are not consecutive (frames are missing)."""
    UNAVAILABLE = "unavailable"
    """The metric could not run here (its weights or package are missing)."""
    DISABLED = "disabled"
    """The run switched the metric off."""
    UNDEFINED = "undefined"
    """The metric is not defined for this input for another reason (fewer than 2 frames, a
    frame smaller than a window, a summary over values that are all null for several reasons)."""
    MISSING_FRAMES = "missing-frames"
    """Run-level: ground-truth frames with no prediction were left out (``--allow-missing``)."""
    PLUGIN_FAILED = "plugin-failed"
    """A metric plugin gave no usable number: it raised, or returned NaN, -infinity or a
    magnitude beyond the results' limit (null; the plugin and what it did named)."""
    NOTE = "note"
    """A warning that explains no null: about the inputs, the regions, the protocol."""


@dataclass(frozen=True)
class Outcome:
    """One value and what became of it: ``value`` a float (``inf`` with ``INFINITE``) or None,
    ``status`` why, ``detail`` the finding site's words (rendered by ``reason_text``)."""

    value: float | None
    """The number, ``math.inf`` for an infinite one, None for a null."""
    status: Status = Status.OK
    """``OK`` for a finite value; otherwise why it is null or infinite."""
    detail: str | None = None
    """What the finding site says about it (None: the status says all)."""

    @classmethod
    def of(cls, value: float | None, status: Status | None = None,
           detail: str | None = None) -> Outcome:
        """The outcome of ``value``: a given ``status`` for a null, else ``INFINITE`` for an
        infinite value, ``UNDEFINED`` for a null, ``OK`` otherwise."""
        if value is not None and math.isinf(value):
            return cls(value, Status.INFINITE, detail)
        if value is None:
            return cls(None, status or Status.UNDEFINED, detail)
        return cls(value, Status.OK, None)

    def reason(self) -> str | None:
        """The warning text of a null or infinite value (None for an ``OK`` one)."""
        return None if self.status is Status.OK else reason_text(self.status, self.detail)


VALUE_LIMIT = 1e300
"""Largest magnitude of a metric value or a time a results file holds: no metric comes near it,
and sums over up to 1e8 frames of values below it stay finite (a mean over 1e308 would
overflow). Read by the results check and by the check of a plugin's values."""

PAIR_UNDEFINED = "undefined for the pair (previous frame, this frame)"
"""The detail of a null per-pair value that nothing else explains."""


@dataclass(frozen=True)
class CameraTerm:
    """One camera-level term (a temporal term such as ``warp_error``, or a video metric such as
    ``jod``) of one camera, as the results document takes it: the camera's outcome and, for the
    terms scored per pair of consecutive frames, each pair's value and why a null one is null.
    Built by the temporal engine (``dynaeval.metrics.temporal.temporal_metrics``) and the run's
    video stage (``dynaeval.run.stages.video``), read by
    ``dynaeval.report.results.place_temporal``."""

    outcome: Outcome
    """The camera's value (the mean over its defined pairs, or one value per camera) and, when
    null, why."""
    per_pair: tuple[float | None, ...] = ()
    """Pair ``k`` = frames ``(k, k + 1)``: its value (None: undefined); empty for a term with one
    value per camera (``flicker``, ``jod``) or one null for the whole camera."""
    gaps: Mapping[int, str] = field(default_factory=dict)
    """Pair position -> why it is no pair (frames missing between its two frames,
    ``Status.NOT_CONSECUTIVE``)."""
    pair_null: Outcome | None = None
    """Why the other null pairs are null when the camera's value is defined (frames without a
    box); None: ``Status.UNDEFINED``, ``PAIR_UNDEFINED``."""
    parts: Mapping[str, float | None] = field(default_factory=dict)
    """The two sides and their signed difference behind the value (``warp_error``,
    ``flicker`` and their focused variants: ``signed``, ``pred``, ``gt``, means over the
    pairs; ``dynaeval.metrics.temporal.temporal_metrics``), else empty."""

    @classmethod
    def null(cls, status: Status, detail: str | None) -> CameraTerm:
        """A term null for the whole camera, and why."""
        return cls(Outcome(None, status, detail))

    def pair_outcome(self, k: int) -> Outcome:
        """Why the null value of pair ``k`` is null: a gap of missing frames, else the camera's
        own null (the term is null for every pair), else ``pair_null``, else undefined."""
        if k in self.gaps:
            return Outcome(None, Status.NOT_CONSECUTIVE, self.gaps[k])
        if self.outcome.detail:
            return Outcome(None, self.outcome.status, self.outcome.detail)
        return self.pair_null or Outcome(None, Status.UNDEFINED, PAIR_UNDEFINED)


_DEFAULT = {
    Status.INFINITE: ("prediction equals ground truth in the scored region: value is +infinity, "
                      "written as null"),
    Status.UNDEFINED: "undefined",
}
_PREFIX = {
    Status.MISSING_FRAMES: "--allow-missing: ",
}


def reason_text(status: Status | str, detail: str | None = None) -> str:
    """The text of a warning of ``status``: the status's own words, or ``detail`` (with the
    status's prefix where it has one)."""
    status = Status(status)
    if detail is None:
        return _DEFAULT.get(status, "undefined")
    return _PREFIX.get(status, "") + detail


def summary_reason(detail: str, *, per_camera: bool = False) -> str:
    """The text of the warning of a null summary value (its status: ``summary_status``)."""
    return f"summary is null: {detail}" + (" (per camera)" if per_camera else "")


def unavailable_reason(title: str, why: str) -> str:
    """The text of a metric that could not run (it names the metric: ``warning_line`` adds no
    prefix)."""
    return f"{title} not computed: {why}"


NO_REGIONS = "no focus box in any of the"
"""How the headline of a run without any box begins (``no_box_reason``)."""


def no_box_reason(who: str, fix: str, n_frames: int, *, presence: bool) -> str:
    """The text of the run-level ``NO_REGION`` headline: no box in any of ``n_frames`` frames,
    what found none (``who``), that every focused (and, with ``presence``, presence) value is
    null, and the ``fix`` (the focus source's words: ``FocusSource.nothing_found``)."""
    nulls = "focused_* value" + (" and presence value" if presence else "")
    return (f"{NO_REGIONS} {n_frames} ground-truth frames: {who}, so every {nulls} is null. "
            f"Fix: {fix}")


def warning(status: Status | str, detail: str | None = None, *, camera: str | None = None,
            frame: str | None = None, metric: str | None = None,
            reason: str | None = None) -> dict[str, Any]:
    """One results warning: ``{camera?, frame?, metric?, status, reason}``. ``reason`` (the
    text) is ``reason_text(status, detail)`` unless made by one of this module's functions."""
    status = Status(status)
    out: dict[str, Any] = {}
    if camera is not None:
        out["camera"] = camera
    if frame is not None:
        out["frame"] = frame
    if metric is not None:
        out["metric"] = metric
    out["status"] = status.value
    out["reason"] = reason if reason is not None else reason_text(status, detail)
    return out


def note(text: str, *, camera: str | None = None, metric: str | None = None) -> dict[str, Any]:
    """A warning that explains no null (``Status.NOTE``)."""
    return warning(Status.NOTE, text, camera=camera, metric=metric)


def status_of(warning_: dict[str, Any]) -> Status:
    """The status of a results warning (every warning of a loaded or built document has one)."""
    return Status(warning_["status"])


def warning_line(warning_: dict[str, Any]) -> str:
    """One results warning as a line of text: ``"tlp: summary is null: ..."`` (the metric first,
    but for a metric that could not run: ``unavailable_reason`` names it)."""
    metric = warning_.get("metric")
    reason = warning_["reason"]
    if metric and status_of(warning_) is not Status.UNAVAILABLE:
        return f"{metric}: {reason}"
    return reason

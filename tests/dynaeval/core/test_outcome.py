"""dynaeval.core.outcome: the statuses, the outcome of a value, and the one place warning text is made."""

from __future__ import annotations

import json
import math

import pytest

from dynaeval.core.outcome import (
    Outcome,
    Status,
    note,
    reason_text,
    status_of,
    summary_reason,
    unavailable_reason,
    warning,
    warning_line,
)
from dynaeval.report import schema_path


def test_the_schema_lists_every_status_a_warning_can_have():
    enum = json.loads(schema_path().read_text())["$defs"]["status"]["enum"]
    assert enum == [s.value for s in Status if s is not Status.OK]


@pytest.mark.parametrize("value,status", [(1.5, Status.OK), (math.inf, Status.INFINITE),
                                          (None, Status.UNDEFINED)])
def test_outcome_of_a_value(value, status):
    got = Outcome.of(value)
    assert got.status is status and got.value == value
    assert (got.reason() is None) == (status is Status.OK)


def test_a_null_keeps_the_status_it_is_given_a_number_does_not():
    assert Outcome.of(None, Status.NO_REGION, "no box").status is Status.NO_REGION
    assert Outcome.of(2.0, Status.NO_REGION, "no box") == Outcome(2.0)
    assert Outcome.of(math.inf, Status.NO_REGION).status is Status.INFINITE


def test_texts_are_made_from_status_and_detail():
    assert reason_text(Status.INFINITE) == ("prediction equals ground truth in the scored "
                                            "region: value is +infinity, written as null")
    assert reason_text(Status.NO_REGION, "no box here") == "no box here"
    assert reason_text("missing-frames", "2 frames") == "--allow-missing: 2 frames"
    assert reason_text(Status.EMPTY_REGION) == "undefined"
    assert summary_reason("x", per_camera=True) == "summary is null: x (per camera)"
    assert unavailable_reason("LPIPS", "no weights") == "LPIPS not computed: no weights"


def test_a_warning_holds_its_status_as_a_string_before_its_text():
    w = warning(Status.NO_REGION, "no box", camera="c", frame="0001", metric="focused_psnr")
    assert w == {"camera": "c", "frame": "0001", "metric": "focused_psnr",
                 "status": "no-region", "reason": "no box"}
    assert list(w)[-2:] == ["status", "reason"] and type(w["status"]) is str
    assert status_of(w) is Status.NO_REGION
    assert note("hello") == {"status": "note", "reason": "hello"}
    with pytest.raises(ValueError):
        warning("no-such-status", "x")


def test_the_console_line_names_the_metric_unless_its_text_does():
    summary = warning(Status.UNDEFINED, metric="tlp", reason=summary_reason("none"))
    assert warning_line(summary) == "tlp: summary is null: none"
    missing = warning(Status.UNAVAILABLE, metric="lpips",
                      reason=unavailable_reason("LPIPS", "no weights"))
    assert warning_line(missing) == "LPIPS not computed: no weights"
    assert warning_line(note("a camera note", camera="c")) == "a camera note"

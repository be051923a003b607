"""What a scoring run prints on stderr about its results: warnings, grouped, and regions."""

from __future__ import annotations

import sys
from collections import Counter

from dynaeval.core.outcome import warning_line
from dynaeval.regions.summary import describe_regions
from dynaeval.report.html import camera_label


def print_warnings(results: dict, output: str | None = None) -> None:
    """The run's warnings on stderr: run-level and whole-camera ones each, then the per-frame
    and per-camera-metric ones grouped by reason (``print_frame_warnings``); ``output``: the
    results file written (None: the console is the only place the user sees them)."""
    for w in results["warnings"]:
        if "camera" not in w:  # run-level warnings
            print(f"dynaeval: warning: {warning_line(w)}", file=sys.stderr)
    print_regions(results)
    for w in results["warnings"]:  # about a whole camera (its motion masks, its frames' sizes)
        if "camera" in w and "frame" not in w and "metric" not in w:
            print(f"dynaeval: warning: camera {w['camera']}: {w['reason']}", file=sys.stderr)
    print_frame_warnings([w for w in results["warnings"]
                          if "camera" in w and ("frame" in w or "metric" in w)], output)
    cams = results["inputs"]["unscored_cameras"]
    if cams:
        print(f"dynaeval: {len(cams)} ground-truth camera(s) without predictions not scored: "
              f"{', '.join(cams[:8])}{' …' if len(cams) > 8 else ''}", file=sys.stderr)


def print_frame_warnings(warnings: list[dict], output: str | None, most: int = 5) -> None:
    """Warnings about single frames (or one metric of a camera), one line per distinct reason
    with how many frames and cameras it concerns, the ``most`` commonest first; the others
    summarised with a count, pointing at ``output`` if it was written, else at ``-o``."""
    texts = [warning_line(w) for w in warnings]
    groups = Counter(texts)
    cameras: dict[str, set[str]] = {}
    frames: Counter[str] = Counter()
    for w, text in zip(warnings, texts, strict=True):
        cameras.setdefault(text, set()).add(w["camera"])
        frames[text] += "frame" in w
    for text, _ in groups.most_common(most):
        where = f"{len(cameras[text])} camera(s)"
        where = f"{frames[text]} frame(s) in {where}" if frames[text] else where
        print(f"dynaeval: warning: {text} ({where})", file=sys.stderr)
    rest = sum(n for _, n in groups.most_common()[most:])
    if rest:
        kept = f"all listed in {output}" if output else "pass -o results.json to keep them all"
        print(f"dynaeval: {rest} more warning(s) about single frames or cameras, of "
              f"{len(groups) - most} other kind(s) ({kept})", file=sys.stderr)


def print_regions(results: dict, most: int = 12) -> None:
    """One line per camera (at most ``most``): the boxes its regions hold."""
    regions = results.get("regions") or {}
    cameras = regions.get("cameras", {}) if regions.get("source") != "none" else {}
    for cam, summary in list(cameras.items())[:most]:
        # a flat folder's camera "." named as the report names it (its ground-truth folder)
        print(f"dynaeval: regions: {describe_regions(camera_label(results, cam), summary)}",
              file=sys.stderr)
    if len(cameras) > most:
        print(f"dynaeval: regions: {len(cameras) - most} more camera(s) in the results JSON "
              "('regions')", file=sys.stderr)

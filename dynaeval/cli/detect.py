"""``dynaeval detect GT -o boxes.json``: the ground truth's boxes once, for ``--focus boxes:FILE``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.io.atomic import check_writable
from dynaeval.regions import write_boxes_file
from dynaeval.regions.focus import BOXES_SOURCES, detect_ground_truth
from dynaeval.regions.sources import focus_source

from .common import EXIT_OK, FOLDERS_RULE, add_overwrite
from .options import add_options, parse_classes

NAME = "detect"


def add(sub: Any) -> None:
    t = sub.add_parser(NAME, help="find boxes in ground-truth frames once, for --focus boxes:FILE",
                       description="Write the boxes of every ground-truth frame (raw, unexpanded) "
                                   "to a boxes file that 'score --focus boxes:FILE' reuses, so "
                                   "every method is scored on the same pixels.")
    t.add_argument("gt", help="folder of ground-truth frames")
    t.add_argument("-o", "--output", required=True, metavar="boxes.json",
                   help=f"the boxes file to write ({FOLDERS_RULE})")
    t.add_argument("--source", choices=BOXES_SOURCES, default=BOXES_SOURCES[0],
                   help="ONNX detector (default) or connected components of the motion masks")
    t.add_argument("--detector", metavar="MODEL.onnx|NAME",
                   help="ONNX detector, or a name fetched with 'dynaeval detector fetch' "
                        "(default: the one shipped with dynaeval)")
    add_options(t, ("focus.classes", "device"))
    add_overwrite(t)
    add_options(t, ("progress",))


def run(args: argparse.Namespace) -> int:
    if args.detector and not focus_source(args.source).detects:
        raise InputError(f"--detector is only used with --source detector (got --source "
                         f"{args.source}): drop --detector, or pass --source detector")
    check_writable(args.output, overwrite=args.overwrite, what="boxes file",
                   inputs=[args.gt, args.detector])
    notes: list[dict] = []
    mapping, source = detect_ground_truth(args.gt, source=args.source,
                                          detector_model=args.detector, device=args.device,
                                          progress=not args.quiet,
                                          classes=parse_classes(args.classes), warnings=notes)
    for note in notes:
        where = f"camera {note['camera']}: " if "camera" in note else ""
        print(f"dynaeval: warning: {where}{note['reason']}", file=sys.stderr)
    write_boxes_file(args.output, mapping, source, overwrite=args.overwrite)
    n_boxes = sum(len(v) for v in mapping.values())
    empty = sum(not v for v in mapping.values())
    print(f"{n_boxes} boxes in {len(mapping)} frames ({empty} without any) written to "
          f"{args.output}")
    return EXIT_OK

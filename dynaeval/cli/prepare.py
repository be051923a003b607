"""``dynaeval prepare GT -o PREP``: the ground truth's regions and flows once."""

from __future__ import annotations

import argparse
from typing import Any

from dynaeval.run.prepare import prepare

from .common import EXIT_OK, FOLDERS_RULE, add_overwrite
from .options import add_options, config_from_args

NAME = "prepare"
SETTINGS = ("focus.source", "focus.detector_model", "focus.classes", "focus.expand",
            "focus.masked", "temporal", "flow", "background", "quantize", "protocol", "workers",
            "cache_mb", "progress")
"""The table's options ``prepare`` has: those that change what the ground truth gives (its
regions, its decoded frames and flows: ``dynaeval.run.prepared_gt.prepared_settings``), and how fast."""


def add(sub: Any) -> None:
    r = sub.add_parser(NAME, help="compute what depends on the ground truth alone, once",
                       description="Write GT's regions (boxes, motion masks) and ground-truth "
                                   "optical flows to PREP, for 'dynaeval score PRED GT --prepared "
                                   "PREP' (same numbers, faster): docs/performance.md. Pass the "
                                   "options the scoring runs will use.")
    r.add_argument("gt", help="folder of ground-truth frames (as given to 'dynaeval score')")
    r.add_argument("-o", "--output", required=True, metavar="PREP",
                   help=f"folder to write ({FOLDERS_RULE})")
    add_overwrite(r, "an existing PREP folder")
    add_options(r, SETTINGS, title="settings (as for 'dynaeval score')")


def run(args: argparse.Namespace) -> int:
    manifest = prepare(args.gt, args.output, config_from_args(args), overwrite=args.overwrite)
    n_flows = sum(len(c["flows"] or ()) * 2 for c in manifest["cameras"].values())
    print(f"{len(manifest['files'])} ground-truth files, {len(manifest['cameras'])} cameras, "
          f"{n_flows} flows prepared in {args.output} (id {manifest['id']})")
    return EXIT_OK

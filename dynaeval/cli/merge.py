"""``dynaeval merge PART.json ...``: the shards of one run back into its results."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from dynaeval.io.atomic import check_writable
from dynaeval.report import write_json_atomic
from dynaeval.report.merge import merge_results

from .common import EXIT_OK, FOLDERS_RULE, add_overwrite

NAME = "merge"


def add(sub: Any) -> None:
    m = sub.add_parser(NAME, help="combine the results of 'score --shard I/N' runs",
                       description="Merge the results files of all N shards of one scoring run "
                                   "into the results of the unsharded run (same numbers, bit for "
                                   "bit).")
    m.add_argument("parts", nargs="+", metavar="PART.json")
    m.add_argument("-o", "--output", required=True, metavar="results.json",
                   help=f"the merged results file ({FOLDERS_RULE})")
    add_overwrite(m)


def run(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite, what="results file", inputs=args.parts)
    merged = merge_results(args.parts)
    write_json_atomic(args.output, merged, overwrite=args.overwrite)
    print(f"{len(args.parts)} shards, {merged['summary']['n_frames']} frames merged into "
          f"{args.output}", file=sys.stderr)
    return EXIT_OK

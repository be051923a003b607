"""``dynaeval leaderboard RESULTS.json ...``: results files into one table."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from dynaeval.core.terminal import write_data
from dynaeval.io.atomic import check_writable, write_text_atomic
from dynaeval.report.leaderboard import FORMATS, GROUP_BY, build_leaderboard, forced_fields, render

from .common import EXIT_OK, FOLDERS_RULE, add_overwrite

NAME = "leaderboard"


def add(sub: Any) -> None:
    lb = sub.add_parser(NAME, help="combine results files into one table",
                        description="Combine results files (methods x scenes) into one table: "
                                    "means per scene and overall (mean of scene means) with "
                                    "bootstrap intervals over frames. Files whose number-changing "
                                    "settings differ are refused unless --force.")
    lb.add_argument("results", nargs="+", metavar="RESULTS.json")
    lb.add_argument("--format", choices=FORMATS, default=FORMATS[0],
                    help=f"output format (default: {FORMATS[0]})")
    lb.add_argument("--by", choices=GROUP_BY, default=GROUP_BY[0],
                    help="group rows by method (default) or by scene")
    lb.add_argument("--metrics", nargs="+", metavar="NAME",
                    help="metrics to show (default: every metric of the files)")
    lb.add_argument("--sort", metavar="METRIC",
                    help="rank each scene's methods by this metric, in its direction (default: "
                         "the first whole-frame metric)")
    lb.add_argument("--force", action="store_true",
                    help="combine files even when settings differ (the differences are recorded)")
    lb.add_argument("-o", "--output", metavar="FILE",
                    help=f"write here (atomically; {FOLDERS_RULE}) instead of stdout")
    add_overwrite(lb)


def run(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite, what="leaderboard file",
                   inputs=args.results)
    board = build_leaderboard(args.results, force=args.force, metrics=args.metrics,
                              sort=args.sort)
    text = render(board, args.format, args.by)
    for f in forced_fields(board):
        print(f"dynaeval: warning: combined despite differing setting {f!r} (--force)",
              file=sys.stderr)
    if args.output:
        write_text_atomic(args.output, text, overwrite=args.overwrite, what="leaderboard file")
        print(f"leaderboard written to {args.output}", file=sys.stderr)
    else:  # data: as it is in a file or a pipe
        write_data(text)
    return EXIT_OK

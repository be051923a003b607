"""``dynaeval demo``: score the sample scene shipped inside the package."""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from dynaeval.core.errors import InputError

from .common import sample_dir
from .options import add_options, config_from_args
from .score import Outputs, run_score

NAME = "demo"
SETTINGS = ("metrics", "metric_options", "fps", "workers", "progress")
"""The table's options ``demo`` has (its focus is the sample's boxes file)."""


def add(sub: Any) -> None:
    d = sub.add_parser(NAME, help="score the sample scene shipped with dynaeval",
                       description="Score the bundled sample predictions against the bundled "
                                   "ground truth, print the table and write results JSON.")
    d.add_argument("-o", "--output", default="dynaeval-demo-results.json", metavar="results.json",
                   help="where to write the results (default: %(default)s, replaced if present)")
    add_options(d, SETTINGS)
    d.add_argument("--report", metavar="DIR", help="also write an HTML report into DIR")
    d.set_defaults(focus=f"boxes:{sample_dir() / 'boxes.json'}")


def run(args: argparse.Namespace) -> int:
    root = sample_dir()
    if not (root / "pred").is_dir():
        raise InputError("the sample scene is missing from this installation", path=root)
    config = replace(config_from_args(args), method="sample-degraded", scene="sample")
    return run_score(str(root / "pred"), str(root / "gt"), config,
                     Outputs(args.output, args.report), overwrite=True)

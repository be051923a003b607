"""``dynaeval score PRED GT``: one ``dynaeval.score`` call, its outputs written as one."""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.io.atomic import check_writable, write_files_atomic
from dynaeval.io.layouts import layout_kind
from dynaeval.report import summary_table
from dynaeval.report.gaussian_splatting import gs_files, gs_paths
from dynaeval.report.html import RegionRecorder, render_report, report_index
from dynaeval.report.results import results_text
from dynaeval.run.config import ScoreConfig
from dynaeval.run.evaluate import DynaevalWarning, score

from .common import EXIT_OK, FOLDERS_RULE, add_overwrite
from .console import print_warnings
from .options import add_options, config_from_args

NAME = "score"


def add(sub: Any) -> None:
    """The ``score`` parser: PRED, GT, every option of the table, and the outputs."""
    p = sub.add_parser(NAME, help="score predicted frames against ground truth",
                       description="Score PRED frames against GT frames (folders of images, one "
                                   "sub-folder per camera, or videos), or one render folder of "
                                   "NeRFBaselines (color/ + gt-color/), ns-render (rgb/ + "
                                   "gt-rgb/), the 3DGS family (MODEL or MODEL/test/ours_N), "
                                   "DyCheck, or a K-Planes step<N>.mp4 / log folder: "
                                   "docs/integration.md.")
    p.add_argument("pred", help="folder of predicted frames, or a render folder")
    p.add_argument("gt", nargs="?",
                   help="folder of ground-truth frames, same layout (omit for a render folder)")
    add_options(p, title="settings (dynaeval.ScoreConfig: the results record every one that "
                         "changes a number)")
    p.add_argument("-o", "--output", metavar="results.json",
                   help=f"write the results JSON here (atomically; {FOLDERS_RULE})")
    add_overwrite(p)
    p.add_argument("--3dgs-json", dest="gs_json", metavar="DIR",
                   help="also write DIR/results.json and DIR/per_view.json in the shape of the "
                        "3DGS family's metrics.py (their numbers with --protocol 3dgs, or "
                        f"4dgaussians; {FOLDERS_RULE})")
    p.add_argument("--report", metavar="DIR",
                   help="also write an HTML report, DIR/index.html (one file, its images inlined): "
                        "summary, per-frame curves, worst frames with the scored regions drawn "
                        f"({FOLDERS_RULE})")


def run(args: argparse.Namespace) -> int:
    outputs = Outputs(args.output, args.report, args.gs_json)
    return run_score(args.pred, args.gt, config_from_args(args), outputs, overwrite=args.overwrite)


@dataclass(frozen=True)
class Outputs:
    """The files a scoring command writes (None: not written)."""

    results: str | None
    """``-o``: the results JSON."""
    report: str | None
    """``--report``: the HTML report's folder."""
    gs_json: str | None = None
    """``--3dgs-json``: the folder of the 3DGS family's two files."""


def run_score(pred: str, gt: str | None, config: ScoreConfig, outputs: Outputs, *,
              overwrite: bool) -> int:
    """Check every output, score, print the warnings and the table, write the outputs as one."""
    inputs = [pred, gt, config.focus.boxes_file, config.focus.detector_model]
    # every output checked before the long run (and before reading a frame)
    check_writable(outputs.results, overwrite=overwrite, what="results file", inputs=inputs)
    check_writable(outputs.report, overwrite=overwrite, what="report folder", inputs=inputs,
                   folder=True)
    for path in gs_paths(outputs.gs_json) if outputs.gs_json else ():
        check_writable(path, overwrite=overwrite, what="3DGS results file", inputs=inputs)
    if outputs.report and (Path(outputs.report) / "index.html").exists() and not overwrite:
        raise InputError("report exists; pass --overwrite or choose another --report folder",
                         path=Path(outputs.report) / "index.html")
    recorder = RegionRecorder() if outputs.report else None
    with warnings.catch_warnings():  # printed below, from the results, once
        warnings.simplefilter("ignore", DynaevalWarning)
        results = score(pred, gt, config, on_regions=recorder)
    _print_layout(results)
    print_warnings(results, outputs.results)
    _write_outputs(results, outputs, recorder, overwrite=overwrite)
    print(summary_table(results))
    return EXIT_OK


def _print_layout(results: dict) -> None:
    """What was scored against what, for a render folder or a K-Planes stack."""
    inputs = results["inputs"]
    if inputs.get("layout"):
        print(f"dynaeval: {layout_kind(inputs['layout']['name']).scored(inputs)}",
              file=sys.stderr)


def _write_outputs(results: dict, outputs: Outputs, recorder: Any, *, overwrite: bool) -> None:
    """Write the results file, the 3DGS files and the report as one (``write_files_atomic``):
    all of them or, on a full disk or an interrupt, none, with existing files as they were."""
    output, report, gs_json = outputs.results, outputs.report, outputs.gs_json
    files = [(Path(output), results_text(results), "results file")] if output else []
    if gs_json:
        files += gs_files(results, gs_json)
    if report:
        files.append((report_index(report, overwrite=overwrite),
                      render_report(results, recorder=recorder), "report"))
    write_files_atomic(files, overwrite=overwrite)
    if output:
        print(f"results written to {output}", file=sys.stderr)
    else:
        print("(pass -o results.json to save the per-frame results)", file=sys.stderr)
    if gs_json:
        _print_gs_written(results, gs_json)
    if report:
        print(f"report written to {Path(report) / 'index.html'}", file=sys.stderr)


def _print_gs_written(results: dict, folder: str) -> None:
    paths = gs_paths(folder)
    print(f"3DGS results written to {paths[0]} and {paths[1]}", file=sys.stderr)
    name = results["settings"]["protocol"]["name"]
    if name not in ("3dgs", "4dgaussians"):
        print(f"dynaeval: warning: these files hold --protocol {name} numbers, not the 3DGS "
              "family's own (pass --protocol 3dgs, or 4dgaussians, for those)", file=sys.stderr)

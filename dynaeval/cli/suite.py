"""``dynaeval suite SUITE.toml|ROOT``: many methods on many scenes, over ``dynaeval.run.suite``.

Exit codes: 0 every pair scored (now or before); 1 a pair (or a scene's prepare) failed, the
others finished (the summary lists each failure; run again to finish what is missing); 2 bad
input, found before any work starts; 130 interrupted (Ctrl-C: the pairs scored so far are kept,
a rerun finishes the others).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from dynaeval.core.deps import MissingDependency, load
from dynaeval.core.errors import InputError
from dynaeval.core.outcome import warning_line
from dynaeval.report.leaderboard import render
from dynaeval.report.results import load_results
from dynaeval.run.suite import (
    check_sort,
    folder_suite,
    load_suite,
    read_toml,
    run_suite,
    settings_config,
    summary_lines,
)

NAME = "suite"
EXIT_OK, EXIT_FAILED, EXIT_INTERRUPTED = 0, 1, 130


def add(sub: Any) -> None:
    """Add ``suite`` to the ``dynaeval`` sub-commands ``sub``."""
    s = sub.add_parser(
        NAME, help="score many methods on many scenes, resumable, locally or on Dask",
        description="Prepare each scene's ground truth once, score every (method, scene) "
                    "against it, skip what is already scored with the same settings and inputs, "
                    "write OUT/leaderboard.{md,csv,json} and OUT/index.html, and print the "
                    "leaderboard (methods ranked, the best marked). SUITE is a "
                    "SUITE.toml (docs/integration.md), or a folder ROOT/<method>/<scene> "
                    "with --gt GT (GT/<scene>) and -o OUT.")
    s.add_argument("suite", metavar="SUITE.toml|ROOT")
    s.add_argument("--gt", metavar="GT", help="folder form: the ground truth, GT/<scene>")
    s.add_argument("-o", "--output", metavar="OUT",
                   help="output folder (folder form: required; SUITE.toml: replaces its output)")
    s.add_argument("--settings", metavar="SETTINGS.toml",
                   help="folder form: a TOML file whose [settings] table holds ScoreConfig "
                        "fields, as in SUITE.toml")
    s.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run the tasks on this Dask scheduler (pip install 'dynaeval[dist]'; "
                        "every worker must see the folders at the same paths)")
    s.add_argument("--overwrite", action="store_true",
                   help="write into an output folder that holds other files than a suite's "
                        "own (its index.html and leaderboard.* are replaced)")
    s.add_argument("--sort", metavar="METRIC",
                   help="rank each scene's methods by this metric, in its direction, as "
                        "'dynaeval leaderboard --sort' (default: the first whole-frame metric)")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _suite_of(args: argparse.Namespace) -> Any:
    path = Path(args.suite)
    if not path.exists():
        raise InputError("no such file or folder (a SUITE.toml, or ROOT of the folder form)",
                         path=path)
    if path.is_file():
        for flag, given in (("gt", args.gt), ("settings", args.settings)):
            if given:
                raise InputError(f"--{flag} is for the folder form (ROOT --gt GT -o OUT); "
                                 f"{path} is a suite file: put it there", path=path)
        return load_suite(path, out=args.output, overwrite=args.overwrite)
    if not (args.gt and args.output):
        raise InputError("not a suite file; the folder form needs --gt GT and -o OUT", path=path)
    config, costs = None, None
    if args.settings:
        spath = Path(args.settings)
        doc = read_toml(spath)
        costs = doc.pop("costs", None) if "settings" in doc else None
        config = settings_config(doc.get("settings", doc), str(spath), spath.resolve().parent)
    return folder_suite(path, args.gt, args.output, config, overwrite=args.overwrite,
                        costs=costs)


def run(args: argparse.Namespace) -> int:
    """Run ``dynaeval suite`` with parsed ``args``; the exit code (module docstring)."""
    suite = _suite_of(args)
    check_sort(suite.config, args.sort)  # before the scheduler is reached (run_suite checks too)
    client = None
    if args.scheduler:
        try:
            Client = load("distributed").Client  # noqa: N806 - the class
        except MissingDependency as err:
            raise InputError(f"--scheduler needs dask.distributed: {err.install}") from None
        try:
            client = Client(args.scheduler, timeout=30)
        except OSError as err:
            raise InputError(f"cannot reach the Dask scheduler {args.scheduler}: {err}") from None
        except (ValueError, TypeError) as err:  # an address Dask cannot parse
            raise InputError(f"--scheduler {args.scheduler!r} is not a Dask scheduler address "
                             f"(tcp://HOST:PORT): {err}") from None
    try:
        outcome = run_suite(suite, client, progress=not args.quiet, sort=args.sort)
    except KeyboardInterrupt:
        print(f"dynaeval: interrupted; the pairs scored so far are kept in {suite.out / 'results'}: "
              "run the same command again to finish the others", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if client is not None:
            client.close()
    _print_run_warnings(outcome)
    if outcome.board is not None:  # ranked, the best marked: as OUT/leaderboard.md
        print(render(outcome.board, "md"))
    for line in summary_lines(outcome):
        print(line, file=sys.stderr if line.startswith("failed") else sys.stdout)
    return EXIT_FAILED if outcome.failed else EXIT_OK


def _print_run_warnings(outcome: Any) -> None:
    """The run-level warnings of the pairs this run scored, as ``dynaeval score`` prints them
    (e.g. LPIPS not computed), each once with the pairs it concerns (the suite kept them in the
    results files only); then the suite's own notes (a run file's cost figure left blank)."""
    seen: dict[str, list[str]] = {}
    for path in outcome.results:
        if path.stem in outcome.scored:
            for w in load_results(path)["warnings"]:
                if "camera" not in w:
                    seen.setdefault(warning_line(w), []).append(path.stem)
    for text, names in seen.items():
        more = " …" if len(names) > 4 else ""
        print(f"dynaeval: warning: {text} ({len(names)} pair(s): {', '.join(names[:4])}{more})",
              file=sys.stderr)
    for note in outcome.notes:
        print(f"dynaeval: warning: {note}", file=sys.stderr)


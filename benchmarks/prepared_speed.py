"""A method scored against a prepared ground truth (``dynaeval prepare``) against the first,
unprepared scoring of it, as a ratio measured in one run.

``python benchmarks/prepared_speed.py [--job DIR] [--rounds N] [--out docs/benchmarks.md]``

The job is ``benchmarks.temporal_speed.make_job``'s (the bundled sample, 2 cameras x 8 frames,
upscaled to 1920x1080). ``dynaeval prepare JOB/gt -o PREP --focus motion`` runs once (timed);
then ``dynaeval score JOB/pred JOB/gt --focus motion --no-lpips`` without and with
``--prepared PREP`` run in child processes, alternating (A, B, A, B, ...) after a warm-up
round, best of ``--rounds`` wall times each: the ratio of the two is the speed-up. The two
results documents must be equal apart from timing, date and ``settings.prepared``. Also given:
the size of the prepared folder per frame and where the unprepared run's time goes (its
``timing``). Section ``prepared`` of docs/benchmarks.md (``--out``) is replaced in place.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))

COMMAND = "python benchmarks/prepared_speed.py"
SCORE_ARGS = ["--focus", "motion", "--no-lpips", "-q"]


def _run(args: list[str]) -> float:
    """Wall seconds of ``python -m dynaeval ARGS`` in a child process."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "dynaeval", *args], check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def comparable(path: Path) -> dict:
    """A results file without what differs between equal runs (timing, date, the prepared
    folder's path)."""
    doc = json.loads(path.read_text())
    for key in ("timing", "created"):
        doc.pop(key, None)
    doc["settings"].pop("prepared", None)
    return doc


def _size_mb(folder: Path, pattern: str) -> float:
    return sum(p.stat().st_size for p in folder.rglob(pattern)) / 1e6


def bench_prepared(job: Path, rounds: int) -> str:
    """Markdown: prepare once, then unprepared and prepared scoring alternating."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        prep = tmp / "prep"
        t_prep = _run(["prepare", str(job / "gt"), "-o", str(prep), "--focus", "motion", "-q"])
        outs = {"first": tmp / "first.json", "prepared": tmp / "prepared.json"}
        extra = {"first": [], "prepared": ["--prepared", str(prep)]}

        def score(name: str) -> float:
            return _run(["score", str(job / "pred"), str(job / "gt"), *SCORE_ARGS, *extra[name],
                         "-o", str(outs[name]), "--overwrite"])

        from benchmarks.temporal_speed import interleaved, round_ratios

        # a warm-up round (page cache, imports), then the two alternating: wall times of the child
        runs = interleaved({name: (lambda n=name: score(n)) for name in outs}, rounds)
        best = {name: runs[name]["wall"] for name in outs}
        per = round_ratios(runs, "first", "prepared", "wall")
        same = comparable(outs["first"]) == comparable(outs["prepared"])
        timing = json.loads(outs["first"].read_text())["timing"]
        timing_p = json.loads(outs["prepared"].read_text())["timing"]
        n_frames = len(json.loads(outs["first"].read_text())["frames"])
        flows_mb, regions_mb = _size_mb(prep / "flows", "*.npy"), _size_mb(prep, "*.npz")
        frames_mb, visible_mb = _size_mb(prep / "frames", "*.npy"), _size_mb(prep / "visible", "*.npy")
        n_flows = len(list((prep / "flows").glob("*.npy")))
    ratio = best["first"] / best["prepared"]
    return "\n".join([
        f"`python -m dynaeval score {job}/pred {job}/gt {' '.join(SCORE_ARGS)} [--prepared PREP]` "
        f"in a child process (2 cameras x 8 frames, 1920x1080, 1 worker), without and with "
        f"`--prepared`, alternating after a warm-up round, best of {rounds} wall times each. "
        f"Results documents equal apart from timing, date and `settings.prepared`: "
        f"{'yes' if same else 'NO'}.", "",
        "| run | wall s | regions s | temporal s |", "|---|---:|---:|---:|",
        f"| `dynaeval prepare {job}/gt -o PREP --focus motion` (once) | {t_prep:.1f} | — | — |",
        f"| first scoring (no `--prepared`) | {best['first']:.1f} | {timing.get('regions', 0):.1f} "
        f"| {timing.get('temporal', 0):.1f} |",
        f"| scoring with `--prepared PREP` | {best['prepared']:.1f} | "
        f"{timing_p.get('regions', 0):.1f} | {timing_p.get('temporal', 0):.1f} |", "",
        f"Speed-up of a method scored against the prepared ground truth: **{ratio:.2f}x** "
        f"(target >= 1.6x); in each of the {rounds} rounds (the two runs of the round): median "
        f"{float(np.median(per)):.2f}, {per.min():.2f} to {per.max():.2f}. Regions and temporal "
        "seconds: the `timing` of each path's last run "
        "(sums of phases, not of the best run).", "",
        f"Size of PREP: {n_flows} flows, {flows_mb:.1f} MB ({flows_mb / max(n_frames, 1):.1f} MB per "
        f"frame: 2 float32 flows of {flows_mb / max(n_flows, 1):.1f} MB per consecutive pair), regions {regions_mb:.2f} MB "
        f"(compressed npz, motion masks bit-packed), visibility masks {visible_mb:.1f} MB "
        f"(bit-packed, one per pair), decoded 8-bit frames {frames_mb:.1f} MB (uint8, so "
        f"that scoring skips decoding the ground truth); the manifest holds the pairs' "
        f"ground-truth warping errors and flicker means.",
    ])


def main(argv: list[str] | None = None) -> int:
    from benchmarks.sections import command_line, publish, utc_stamp
    from benchmarks.temporal_speed import make_job

    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    parser.add_argument("--job", default="/tmp/dynaeval-bench-1080p", help="job folder (made if missing)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating timed rounds (best kept)")
    parser.add_argument("--out", default="docs/benchmarks.md", help="markdown file ('-': print only)")
    args = parser.parse_args(argv)
    command = command_line(COMMAND, argv)
    started = utc_stamp()
    body = bench_prepared(make_job(args.job), args.rounds)
    text = (f"## Ground truth prepared once (`dynaeval prepare`)\n\nCommand: `{command}` — run "
            f"{started}.\n\n{body}\n")
    publish(args.out, "prepared", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

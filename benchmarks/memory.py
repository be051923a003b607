"""Peak memory of one long 1080p camera: does it stop growing at the frame-cache budget?

Writes one camera of N distinct 1080p frames (the bundled sample's cam07 frames upscaled and
cycled, each with its own moving square so no two frames are equal, predictions with fresh
noise), scores it in a child process (``dynaeval score --focus motion --no-lpips``) and reads the
child's peak resident set size from ``os.wait4``. Run for several N and cache budgets:

    python benchmarks/memory.py --frames 16 300 --cache-mb 1024 256

prints a markdown table (and writes it into docs/benchmarks.md with ``--out``).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

COMMAND = "python benchmarks/memory.py"
SIZE = (1080, 1920)


def make_camera(dst: Path, n_frames: int, seed: int = 0) -> Path:
    """``dst/{gt,pred}/cam/NNNN.png``: ``n_frames`` distinct 1080p frames (kept if present)."""
    import cv2

    from dynaeval.cli import sample_dir

    if (dst / "gt" / "cam").is_dir() and len(list((dst / "gt" / "cam").glob("*.png"))) == n_frames:
        return dst
    rng = np.random.default_rng(seed)
    base = [cv2.resize(cv2.imread(str(f)), SIZE[::-1], interpolation=cv2.INTER_CUBIC)
            for f in sorted((sample_dir() / "gt" / "cam07").glob("*.png"))]
    for side in ("gt", "pred"):
        (dst / side / "cam").mkdir(parents=True, exist_ok=True)
    for i in range(n_frames):
        im = base[i % len(base)].copy()
        x = 100 + (7 * i) % (SIZE[1] - 300)
        im[500:620, x:x + 60] = (40 + i % 200, 90, 200)  # a moving square: every frame differs
        cv2.imwrite(str(dst / "gt" / "cam" / f"{i:04d}.png"), im)
        noisy = np.clip(im + rng.normal(0, 3, im.shape), 0, 255).astype(np.uint8)
        cv2.imwrite(str(dst / "pred" / "cam" / f"{i:04d}.png"), noisy)
    return dst


def peak_rss_mb(job: Path, cache_mb: int) -> tuple[float, float]:
    """(peak RSS in MB, wall s) of one ``dynaeval score`` child process on ``job``."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "dynaeval", "score", str(job / "pred"), str(job / "gt"),
               "--focus", "motion", "--no-lpips", "-q", "--cache-mb", str(cache_mb),
               "-o", str(Path(tmp) / "r.json")]
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"dynaeval score failed on {job}: {shlex.join(cmd)}")
    return usage.ru_maxrss / 1024, wall  # Linux: kB


FRAME_MB = SIZE[0] * SIZE[1] * 3 * 4 / 2**20
"""MB of one decoded 1080p frame in the frame cache (float32 RGB)."""
NOTE = (
    "What a camera holds does not grow with its frames beyond the frame cache: each frame keeps "
    "its motion mask bit-packed (`dynaeval.regions.packed.PackedMask`, 0.26 MB at 1080p instead "
    "of a 2.1 MB bool array), the static region of the temporal terms is ORed on the packed "
    "bits (it stacked every mask, (T, H, W), before), and the ISG median stacks at most 256 MiB "
    "of rows at a time (`MEDIAN_MAX_BYTES`; its 64 float32 frames took 1.6 GB, the peak of a "
    "long camera before). Left growing with the frames: the packed masks, the per-pair values "
    "and the frame cache up to its budget (a short camera's frames may not fill it)."
)


def cached_mb(n_frames: int, cache_mb: int) -> float:
    """MB the frame cache holds at most for a camera of ``n_frames`` (both sides)."""
    whole = int(cache_mb * 2**20 // (FRAME_MB * 2**20))  # frames that fit
    return min(2 * n_frames, whole) * FRAME_MB


def _growth(peaks: dict[tuple[int, int], float]) -> str:
    """One sentence per cache budget: the longest camera's peak against the shortest's."""
    out = []
    for mb in dict.fromkeys(m for _, m in peaks):
        ns = sorted(n for n, m in peaks if m == mb)
        if len(ns) < 2:
            continue
        lo, hi = peaks[ns[0], mb], peaks[ns[-1], mb]
        out.append(f"At `--cache-mb {mb}`: {ns[-1]} frames peak at {hi:.0f} MB, {hi - lo:+.0f} MB "
                   f"({100 * (hi - lo) / lo:+.1f} %) against {ns[0]} frames, of which "
                   f"{cached_mb(ns[-1], mb) - cached_mb(ns[0], mb):+.0f} MB more frames cached.")
    return " ".join(out) + ("\n\n" if out else "")


def _row(n: int, mb: int, rss: float, wall: float) -> str:
    return f"| {n} | {mb} | {cached_mb(n, mb):.0f} | {rss:.0f} | {wall:.1f} |"


def section(command: str, results: dict[tuple[int, int], tuple[float, float]]) -> str:
    """The markdown section: ``command`` (how and when it ran), one row per ``(frames,
    cache MB) -> (peak RSS MB, wall s)``, the growth per budget and what memory is made of."""
    rows = ["| frames | --cache-mb | frames cached (MB) | peak RSS (MB) | wall (s) |",
            "|---:|---:|---:|---:|---:|"] + [_row(n, mb, *got) for (n, mb), got in results.items()]
    peaks = {key: rss for key, (rss, _) in results.items()}
    return (f"## Memory of a long 1080p camera\n\nCommand: {command}. One camera of distinct "
            "1080p frames, `--focus motion --no-lpips`, one worker; peak resident set size of the "
            "scoring process (`os.wait4`). *Frames cached*: what the frame cache holds at most, "
            f"prediction and ground truth of {FRAME_MB:.1f} MB each (float32 RGB) up to "
            "`--cache-mb`.\n\n" + "\n".join(rows) + "\n\n" + _growth(peaks) + NOTE
            + f" Wall times: load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores at "
            "the end of the run.\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, nargs="+", default=[16, 300])
    parser.add_argument("--cache-mb", type=int, nargs="+", default=[1024])
    parser.add_argument("--root", default="/tmp/dynaeval-bench-memory", help="jobs (made if missing)")
    parser.add_argument("--out", default="-", help="markdown file to put the section in ('-': print)")
    args = parser.parse_args(argv)
    from benchmarks.sections import command_line, publish, utc_stamp

    command = command_line(COMMAND, argv)
    started = utc_stamp()
    results: dict[tuple[int, int], tuple[float, float]] = {}
    for n in args.frames:
        job = make_camera(Path(args.root) / f"n{n}", n)
        for mb in args.cache_mb:
            results[n, mb] = peak_rss_mb(job, mb)
            print(_row(n, mb, *results[n, mb]), flush=True)
    text = section(f"`{command}` — run {started}", results)
    publish(args.out, "memory", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

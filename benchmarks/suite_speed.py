"""``dynaeval suite`` against three plain ``score`` runs, and on 2 Dask workers against the
two-core floor, as ratios measured in one run.

``python benchmarks/suite_speed.py [--parts prepare,dask] [--job DIR] [--rounds N] [--out docs/benchmarks.md]``

The job is ``benchmarks.temporal_speed.make_job``'s (the bundled sample, 2 cameras x 8 frames,
upscaled to 1920x1080); three methods are its predictions and two noisier copies of them
(``JOB/suite/m1..m3``). Settings of every run: ``--focus motion --no-lpips`` (``metrics =
["psnr", "ssim"]``, temporal terms on), as in ``benchmarks/prepared_speed.py``.

* ``prepare``: ``dynaeval suite`` of 3 methods x 1 scene (prepares the scene once, then scores
  the 3 methods against it) against 3 plain ``dynaeval score`` runs one after the other, each
  in a child process, alternating after a warm-up round, best of ``--rounds`` wall times. The
  suite's results must equal the plain runs' apart from timing, date and ``settings.prepared``.
* ``dask``: the bigger job, 3 methods x 2 scenes (the job's ground truth as scene ``a`` and
  again as scene ``b``: 2 prepares and 6 scorings), with ``--scheduler`` on a loopback
  ``dask scheduler`` and 2 ``dask worker`` processes (``--nthreads 1``, OpenCV on one thread),
  against the two-core floor: the same suite run locally on one core (1 worker,
  ``OPENCV_FOR_THREADS_NUM=1``), its CPU seconds over 2. Target: within 25 % of the floor.
  The control: the same two scenes as 2 local ``dynaeval suite`` processes at once (one scene
  and one core each, no Dask): what two processes get of this machine. The results of every
  run must be equal.

Sections ``suite`` and ``suite-dask`` of docs/benchmarks.md (``--out``) are replaced in place.
"""

from __future__ import annotations

import argparse
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))

COMMAND = "python benchmarks/suite_speed.py"
REPO = Path(__file__).resolve().parents[1]
SCORE_ARGS = ["--focus", "motion", "--no-lpips", "-q"]
SETTINGS = '[settings]\nmetrics = ["psnr", "ssim"]\nfocus = "motion"\n'
METHODS = ("m1", "m2", "m3")
ONE_CORE = {"OPENCV_FOR_THREADS_NUM": "1"}


def _methods(job: Path) -> Path:
    """``JOB/suite/preds/m1..m3``: the job's predictions, and two noisier copies (sigma 2 and 4
    grey levels more), made once."""
    import cv2

    base = job / "suite" / "preds"
    for k, m in enumerate(METHODS):
        dst = base / m
        if dst.is_dir():
            continue
        rng = np.random.default_rng(100 + k)
        tmp = base / f".{m}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        for f in sorted((job / "pred").rglob("*.png")):
            im = cv2.imread(str(f)).astype(np.float32)
            if k:
                im += rng.normal(0, 2 * k, im.shape).astype(np.float32)
            target = tmp / f.relative_to(job / "pred")
            target.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(target), np.clip(im, 0, 255).astype(np.uint8))
        tmp.rename(dst)
    return base


def _root(job: Path, scenes: tuple[str, ...]) -> tuple[Path, Path]:
    """(ROOT, GT) of the folder form, as symbolic links: ROOT/<method>/<scene>, GT/<scene>."""
    preds = _methods(job)
    top = job / "suite" / "-".join(scenes)
    root, gt = top / "root", top / "gt"
    for scene in scenes:
        for m in METHODS:
            link = root / m / scene
            if not link.exists():
                link.parent.mkdir(parents=True, exist_ok=True)
                link.symlink_to(preds / m, target_is_directory=True)
        if not (gt / scene).exists():
            gt.mkdir(parents=True, exist_ok=True)
            (gt / scene).symlink_to((job / "gt").resolve(), target_is_directory=True)
    (top / "settings.toml").write_text(SETTINGS)
    return root, gt


def _child(args: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """``python -m dynaeval ARGS`` in a child process: (wall s, its user + system CPU s)."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "dynaeval", *args], check=True, cwd=REPO,
                   stdout=subprocess.DEVNULL, env={**os.environ, **(env or {})})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def _suite_args(root: Path, gt: Path, out: Path, *extra: str) -> list[str]:
    return ["suite", str(root), "--gt", str(gt), "-o", str(out), "--settings",
            str(root.parent / "settings.toml"), "-q", *extra]


def bench_prepare(job: Path, rounds: int) -> str:
    """Markdown: the suite of 3 methods x 1 scene against 3 plain scoring runs."""
    from benchmarks.prepared_speed import comparable
    from benchmarks.temporal_speed import interleaved, round_ratios

    root, gt = _root(job, ("scene",))
    cpu: dict[str, list[float]] = {"plain": [], "suite": []}  # children's CPU s, per round
    with tempfile.TemporaryDirectory(dir=job) as tmp:
        tmp = Path(tmp)

        def suite() -> None:
            shutil.rmtree(tmp / "suite", ignore_errors=True)  # everything again, every round
            cpu["suite"].append(_child(_suite_args(root, gt, tmp / "suite"))[1])

        def plain() -> None:
            cpu["plain"].append(sum(
                _child(["score", str((root / m / "scene").resolve()),  # the suite's paths
                        str((gt / "scene").resolve()), *SCORE_ARGS, "--method", m, "--scene",
                        "scene", "-o", str(tmp / f"{m}.json"), "--overwrite"])[1]
                for m in METHODS))

        runs = interleaved({"plain": plain, "suite": suite}, rounds)
        same = all(comparable(tmp / f"{m}.json")
                   == comparable(tmp / "suite" / "results" / f"scene__{m}.json") for m in METHODS)
    timed = {k: np.asarray(v[1:]) for k, v in cpu.items()}  # the warm-up round left out
    per = round_ratios(runs, "plain", "suite", "wall")
    per_cpu = timed["plain"] / timed["suite"]
    ratio = runs["plain"]["wall"] / runs["suite"]["wall"]
    cpu_ratio = timed["plain"].min() / timed["suite"].min()
    return "\n".join([
        f"`python -m dynaeval suite ROOT --gt GT -o OUT --settings S.toml -q` (S.toml: "
        f"`{SETTINGS.splitlines()[1]}`, `{SETTINGS.splitlines()[2]}`; 3 methods x 1 scene of 2 "
        "cameras x 8 frames, 1920x1080, 1 worker; OUT removed before each run: it prepares "
        f"and scores everything) against 3 runs of `python -m dynaeval score PRED GT "
        f"{' '.join(SCORE_ARGS)}` one after the other, each a child process, alternating after a "
        f"warm-up round, best of {rounds} wall times each (CPU: the children's user + system "
        f"seconds, best of the rounds). Results equal (apart from timing, date and "
        f"`settings.prepared`): {'yes' if same else 'NO'}.", "",
        "| run | wall s | CPU s |", "|---|---:|---:|",
        f"| 3 plain `dynaeval score` runs | {runs['plain']['wall']:.1f} | "
        f"{timed['plain'].min():.1f} |",
        f"| `dynaeval suite` (prepare once, 3 scorings with `prepared=`) | "
        f"{runs['suite']['wall']:.1f} | {timed['suite'].min():.1f} |", "",
        f"Suite against the plain runs: **{ratio:.2f}x** wall, {cpu_ratio:.2f}x CPU (target >= 1.6x); in each of the {rounds} rounds: wall "
        f"median {float(np.median(per)):.2f}, {per.min():.2f} to {per.max():.2f}; CPU median "
        f"{float(np.median(per_cpu)):.2f}, {per_cpu.min():.2f} to {per_cpu.max():.2f}.",
    ])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cpu_of(pids: list[int]) -> float:
    """User + system CPU seconds of running processes (``/proc/PID/stat``)."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for pid in pids:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        total += int(fields[11]) + int(fields[12])
    return total / tick


class LoopbackCluster:
    """A ``dask scheduler`` and ``n`` ``dask worker`` processes (one thread, OpenCV on one
    thread each) on 127.0.0.1, killed on exit."""

    def __init__(self, n: int = 2) -> None:
        self.n = n
        self.address = f"tcp://127.0.0.1:{_free_port()}"
        self.procs: list[subprocess.Popen] = []

    def __enter__(self) -> LoopbackCluster:
        from distributed import Client

        dask = str(Path(sys.executable).with_name("dask"))
        env = {**os.environ, **ONE_CORE,
               "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
        kw = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env, "cwd": REPO}
        port = self.address.rsplit(":", 1)[1]
        try:
            self.procs.append(subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port",
                                                port, "--no-dashboard"], **kw))
            for i in range(self.n):
                self.procs.append(subprocess.Popen(
                    [dask, "worker", self.address, "--nthreads", "1", "--no-nanny", "--name",
                     f"w{i}", "--host", "127.0.0.1", "--no-dashboard", "--memory-limit", "0"], **kw))
            with Client(self.address, timeout=60) as client:
                client.wait_for_workers(self.n, timeout=120)
        except BaseException:
            self.__exit__()
            raise
        return self

    def worker_cpu(self) -> float:
        return _cpu_of([p.pid for p in self.procs[1:]])

    def __exit__(self, *exc: object) -> None:
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait(timeout=60)


def _numbers(out: Path) -> dict:
    """The results of a suite's output folder, by file name, without timing, date and the
    prepared folder's path (``comparable``)."""
    from benchmarks.prepared_speed import comparable

    return {p.name: comparable(p) for p in sorted((out / "results").glob("*.json"))}


def bench_dask(job: Path, rounds: int) -> str:
    """Markdown: the 3 x 2 suite on 2 Dask workers against one core's CPU over 2."""
    from benchmarks.temporal_speed import interleaved

    root, gt = _root(job, ("a", "b"))
    cpu: dict[str, list[float]] = {"one_core": [], "dask": [], "client": [], "two_processes": []}
    with tempfile.TemporaryDirectory(dir=job) as tmp, LoopbackCluster(2) as cluster:
        tmp = Path(tmp)

        def one_core() -> None:
            shutil.rmtree(tmp / "local", ignore_errors=True)
            cpu["one_core"].append(_child(_suite_args(root, gt, tmp / "local"), ONE_CORE)[1])

        def dask() -> None:
            shutil.rmtree(tmp / "dask", ignore_errors=True)
            w0 = cluster.worker_cpu()
            _, c = _child(_suite_args(root, gt, tmp / "dask", "--scheduler", cluster.address))
            cpu["dask"].append(cluster.worker_cpu() - w0)
            cpu["client"].append(c)

        def two_processes() -> None:  # the control: the machine's own parallelism, no Dask
            import resource

            halves = [(*_root(job, (scene,)), tmp / f"half-{scene}") for scene in ("a", "b")]
            for *_, out in halves:
                shutil.rmtree(out, ignore_errors=True)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            procs = [subprocess.Popen([sys.executable, "-m", "dynaeval", *_suite_args(r, g, o)],
                                      cwd=REPO, stdout=subprocess.DEVNULL,
                                      env={**os.environ, **ONE_CORE}) for r, g, o in halves]
            if any(p.wait() for p in procs):
                raise RuntimeError("a suite process failed")
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu["two_processes"].append(after.ru_utime - before.ru_utime + after.ru_stime
                                        - before.ru_stime)

        runs = interleaved({"one_core": one_core, "dask": dask, "two_processes": two_processes},
                           rounds)
        halves = {**_numbers(tmp / "half-a"), **_numbers(tmp / "half-b")}
        same = (_numbers(tmp / "local") == _numbers(tmp / "dask") == halves
                and len(halves) == 6)
    timed = {k: v[1:] for k, v in cpu.items()}  # the warm-up round's left out
    floor = min(timed["one_core"]) / 2
    wall = runs["dask"]["wall"]
    per = np.asarray(runs["dask"]["wall_rounds"]) / (np.asarray(timed["one_core"]) / 2)
    return "\n".join([
        f"`python -m dynaeval suite ROOT --gt GT -o OUT --settings S.toml -q --scheduler "
        f"tcp://127.0.0.1:PORT`: 3 methods x 2 scenes (2 prepares, 6 scorings; 2 cameras x 8 "
        f"frames, 1920x1080 each) on a loopback `dask scheduler` and 2 `dask worker` processes "
        f"(`--nthreads 1 --no-nanny`, `OPENCV_FOR_THREADS_NUM=1`), started before the timing; "
        f"against the same suite run locally on one core (`OPENCV_FOR_THREADS_NUM=1`, 1 worker), "
        f"alternating after a warm-up round, best of {rounds} each. Results equal: "
        f"{'yes' if same else 'NO'}.", "",
        "| run | wall s | CPU s |", "|---|---:|---:|",
        f"| local, one core | {runs['one_core']['wall']:.1f} | {min(timed['one_core']):.1f} |",
        f"| 2 Dask workers | {wall:.1f} | {min(timed['dask']):.1f} (workers) + "
        f"{min(timed['client']):.1f} "
        "(the `dynaeval suite` client) |",
        f"| control: 2 local `dynaeval suite` processes at once, one scene each, one core each, "
        f"no Dask | {runs['two_processes']['wall']:.1f} | {min(timed['two_processes']):.1f} |",
        "",
        f"The two-core floor, the one-core run's CPU over 2: **{floor:.1f} s**; 2 Dask workers are "
        f"**{100 * (wall / floor - 1):+.0f} %** above it (target: within 25 %); round by round "
        f"(that round's dask wall over its one-core CPU / 2): median "
        f"{100 * (float(np.median(per)) - 1):+.0f} %, {100 * (per.min() - 1):+.0f} % to "
        f"{100 * (per.max() - 1):+.0f} %. The control, the same work as 2 plain processes "
        f"without Dask, is {100 * (runs['two_processes']['wall'] / floor - 1):+.0f} % above the "
        f"floor, and Dask {100 * (wall / runs['two_processes']['wall'] - 1):+.0f} % above the "
        "control: what the floor misses and the control does not is the cores the machine "
        "really gives two processes at once.",
    ])


def main(argv: list[str] | None = None) -> int:
    from benchmarks.sections import command_line, publish, utc_stamp
    from benchmarks.temporal_speed import make_job

    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    parser.add_argument("--parts", default="prepare,dask", help="prepare, dask (comma-separated)")
    parser.add_argument("--job", default="/tmp/dynaeval-bench-1080p", help="job folder (made if missing)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating timed rounds (best kept)")
    parser.add_argument("--out", default="docs/benchmarks.md", help="markdown file ('-': print only)")
    args = parser.parse_args(argv)
    command = command_line(COMMAND, argv)
    job = make_job(args.job)
    parts = args.parts.split(",")
    if "prepare" in parts:
        body = bench_prepare(job, args.rounds)
        publish(args.out, "suite", f"## A suite of 3 methods x 1 scene (`dynaeval suite`)\n\n"
                f"Command: `{command}` — run {utc_stamp()}.\n\n{body}\n")
    if "dask" in parts:
        body = bench_dask(job, args.rounds)
        publish(args.out, "suite-dask", f"## A suite on 2 Dask workers against the two-core "
                f"floor\n\nCommand: `{command}` — run {utc_stamp()}.\n\n{body}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

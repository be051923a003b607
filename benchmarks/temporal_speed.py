"""The temporal pass, worker scaling and SSIM against their floors, as ratios measured in one run.

``python benchmarks/temporal_speed.py --job DIR [--parts pairs,workers,ssim] [--rounds N]
[--before CHECKOUT]``

On a shared machine absolute times say little (other jobs hold the cores), so every claim here is
a *ratio* of two paths timed in the same process, alternating (A, B, A, B, ...), best of
``--rounds`` each:

* ``pairs``: one camera's temporal pass (``dynaeval.metrics.temporal.temporal_metrics``, no tLP,
  a fresh flow cache; the process's allocator set as the ``dynaeval`` command sets it,
  ``dynaeval.core.runtime.keep_freed_memory``) per frame pair, divided by one DIS-medium optical flow of a pair of the
  same frames (``dynaeval.metrics.flow.flow_from_gray``, the estimator call alone): the pass
  needs 3 flows per pair (ground truth both ways, prediction), so 3.0 is its floor and the
  issue's target is <= 4.5. Also timed: the same terms from the pure per-term functions
  (``warping_error`` x4, ``tof`` x2, ``valid_warp_mask``, ``optical_flow`` x3: what the engine
  cost before it shared its per-pair work), and a cProfile of the engine: where the time goes.
* ``workers``: whole ``dynaeval score JOB/pred JOB/gt --focus motion --no-lpips`` runs in child
  processes, 1 and 2 workers alternating with a one-core run (OpenCV on one thread) and 2 shard
  processes at once (the cameras in processes instead of threads): wall-time ratio, the ceiling
  of 2 workers over 1 (1 worker's wall over half the one-core run's CPU), and the results equal
  bit for bit.
* ``ssim``: ``dynaeval.metrics.ssim`` of one 1080p pair against its arithmetic and memory floor,
  OpenCV on one thread
  (the five 11-tap separable Gaussian filters alone, on float32 planes: what any SSIM must
  filter) and against scikit-image on the same float32 input; the deviation from the float64
  reference (scikit-image on float64 input).
* ``--before CHECKOUT``: the workers runs are also made in another checkout (its code), and its
  ``structural.py`` is timed beside this one's SSIM, with a check that both give the same bits.

The job (``--job DIR``, made when missing) is the bundled sample (2 cameras x 8 frames) upscaled
to 1920x1080 with a fixed noise texture, so that the flow has detail to follow. Sections of
docs/benchmarks.md (``--out``) are replaced in place (``benchmarks.sections``).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))

COMMAND = "python benchmarks/temporal_speed.py"
REPO = Path(__file__).resolve().parents[1]
ONE_CORE = {"OPENCV_FOR_THREADS_NUM": "1"}
"""Environment of a run on one core: OpenCV's thread pool (DIS) on one thread."""
SIZE = (1080, 1920)


def make_job(dst: str | Path, size: tuple[int, int] = SIZE, seed: int = 0) -> Path:
    """Write the bundled sample's frames upscaled to ``size`` (H, W) under ``dst/{gt,pred}``.

    A fixed Gaussian texture (sigma 6 of 255) is added to every frame (static, so it does not
    move), predictions get fresh noise (sigma 3) on top. Returns ``dst``; an existing job is kept.
    """
    import cv2

    from dynaeval.cli import sample_dir

    dst = Path(dst)
    if (dst / "gt").is_dir() and (dst / "pred").is_dir():
        return dst
    src = sample_dir()
    rng = np.random.default_rng(seed)
    tex = rng.normal(0, 6, (*size, 3)).astype(np.float32)
    for side in ("gt", "pred"):
        for f in sorted((src / side).rglob("*.png")):
            im = cv2.resize(cv2.imread(str(f)), size[::-1], interpolation=cv2.INTER_CUBIC)
            im = im.astype(np.float32) + tex
            if side == "pred":
                im += rng.normal(0, 3, im.shape).astype(np.float32)
            target = dst / side / f.relative_to(src / side)
            target.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(target), np.clip(im, 0, 255).astype(np.uint8))
    return dst


def interleaved(paths: dict[str, Callable[[], Any]], rounds: int) -> dict[str, dict[str, Any]]:
    """Run each path once per round, in turn (A, B, ..., A, B, ...), after one warm-up round.

    Returns ``{name: {"wall": best wall s, "cpu": best CPU s of this process, "wall_rounds",
    "cpu_rounds": the seconds of each round}}``: a ratio of two paths per round cancels a machine
    that speeds up or slows down between rounds.
    """
    for fn in paths.values():
        fn()
    times: dict[str, dict[str, list[float]]] = {k: {"wall": [], "cpu": []} for k in paths}
    for _ in range(rounds):
        for name, fn in paths.items():
            w0, c0 = time.perf_counter(), time.process_time()
            fn()
            times[name]["wall"].append(time.perf_counter() - w0)
            times[name]["cpu"].append(time.process_time() - c0)
    return {name: {"wall": min(t["wall"], default=np.inf), "cpu": min(t["cpu"], default=np.inf),
                   "wall_rounds": t["wall"], "cpu_rounds": t["cpu"]} for name, t in times.items()}


def round_ratios(best: dict[str, dict[str, Any]], num: str, den: str, kind: str = "cpu") -> np.ndarray:
    """``kind`` (``"cpu"`` or ``"wall"``) time of path ``num`` over path ``den`` in each round of
    ``interleaved``."""
    return np.asarray(best[num][f"{kind}_rounds"]) / np.asarray(best[den][f"{kind}_rounds"])


def load_camera(job: Path, camera: str) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``(preds, gts)`` of one camera of the job, float32 RGB in [0, 1] (``read_image``)."""
    from dynaeval.io.images import read_image

    files = sorted((job / "gt" / camera).glob("*.png"))
    gts = [read_image(f) for f in files]
    preds = [read_image(job / "pred" / camera / f.name) for f in files]
    return preds, gts


def _regions(gts: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Static mask and per-frame focus masks from the motion masks (as ``--focus motion``)."""
    from dynaeval.regions.motion import iter_motion_masks

    masks = list(iter_motion_masks(gts))
    return ~np.logical_or.reduce(masks), masks


def _reference_pass(preds, gts, static, regions, flow_cfg) -> None:  # noqa: ANN001
    """The temporal terms from the pure per-term functions (no shared per-pair work)."""
    from dynaeval.metrics.flow import optical_flow, valid_warp_mask
    from dynaeval.metrics.temporal import flicker, tof, warping_error

    for t in range(1, len(gts)):
        fw = optical_flow(gts[t - 1], gts[t], flow_cfg)
        bw = optical_flow(gts[t], gts[t - 1], flow_cfg)
        fp = optical_flow(preds[t - 1], preds[t], flow_cfg)
        valid = valid_warp_mask(bw, fw)
        union = regions[t] | regions[t - 1]
        for r in (None, union):
            warping_error(preds[t - 1], preds[t], bw, valid, r)
            warping_error(gts[t - 1], gts[t], bw, valid, r)
            tof(fp, fw, r)
    flicker(preds, gts, static)


def bench_pairs(job: Path, rounds: int) -> str:
    """Markdown: the temporal pass per pair in DIS flows, and where its time goes."""
    from dynaeval.metrics.flow import FlowCache, FlowConfig, flow_from_gray, to_gray_u8
    from dynaeval.metrics.temporal import TemporalConfig, TemporalRun, temporal_metrics

    preds, gts = load_camera(job, "cam07")
    static, regions = _regions(gts)
    flow_cfg, cfg = FlowConfig(), TemporalConfig(tlp=False)
    grays = [(to_gray_u8(p), to_gray_u8(g)) for p, g in zip(preds, gts, strict=True)]
    pairs = len(gts) - 1

    def flows() -> None:  # the floor: the 3 flows of every pair, nothing else
        for (p0, g0), (p1, g1) in zip(grays, grays[1:], strict=False):
            for a, b in ((g0, g1), (g1, g0), (p0, p1)):
                flow_from_gray(a, b, flow_cfg)

    def engine() -> dict:
        return temporal_metrics(preds, gts, static_mask=static, region_masks=regions, config=cfg,
                                run=TemporalRun(flow_cache=FlowCache()))

    best = interleaved({
        "flows": flows,
        "engine": engine,
        "reference": lambda: _reference_pass(preds, gts, static, regions, flow_cfg),
    }, rounds)
    n_flows = 3 * pairs
    flow = {k: best["flows"][k] / n_flows for k in ("wall", "cpu")}  # one DIS flow: the camera's mean
    lines = [f"One camera, {len(gts)} frames ({pairs} pairs) at {SIZE[1]}x{SIZE[0]}; best of "
             f"{rounds} alternating rounds of each path, each path the whole camera. One DIS-medium "
             f"flow (mean of the camera's {n_flows}, the estimator call alone): "
             f"{1e3 * flow['wall']:.0f} ms wall, {1e3 * flow['cpu']:.0f} ms CPU here (shared machine: "
             "compare the ratios). Target of the issue: <= 4.5 flows per pair. The process's "
             "allocator is set as the `dynaeval` command sets it (`runtime.keep_freed_memory`).",
             "",
             "| path | per pair, wall (DIS flows) | per pair, CPU (DIS flows) |", "|---|---:|---:|"]
    for name, label in (("engine", "`temporal_metrics` (3 flows + every term)"),
                        ("reference", "the same terms from the pure per-term functions"),
                        ("flows", "floor: the 3 flows a pair needs")):
        w, c = best[name]["wall"] / pairs / flow["wall"], best[name]["cpu"] / pairs / flow["cpu"]
        lines.append(f"| {label} | {w:.2f} | {c:.2f} |")
    per = 3 * round_ratios(best, "engine", "flows")  # the floor is 3 flows per pair
    lines += ["", f"`temporal_metrics` per pair, in DIS flows of CPU, in each of the {rounds} "
              f"rounds: median **{np.median(per):.2f}**, {per.min():.2f} to {per.max():.2f}.",
              "", _profile(engine)]
    return "\n".join(lines)


def _profile(fn: Callable[[], Any], top: int = 10) -> str:
    """Markdown table: the ``top`` functions by own CPU time of one ``fn()`` run, as shares of
    the run (a share does not depend on how loaded the machine is at that moment)."""
    prof = cProfile.Profile(time.process_time)  # CPU time: other jobs' load does not count
    prof.enable()
    fn()
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    rows = sorted(stats.items(), key=lambda kv: -kv[1][2])[:top]
    total = sum(v[2] for v in stats.values())
    lines = ["Where the engine's time goes (one more run under cProfile, own CPU time; the DIS "
             "calls are the 3 flows per pair):", "",
             "| function | calls | share of the pass |", "|---|---:|---:|"]
    for (file, line, name), (_, calls, tottime, _, _) in rows:
        where = name if file == "~" else f"{Path(file).name}:{line}({name})"
        lines.append(f"| `{where}` | {calls} | {100 * tottime / total:.1f} % |")
    return "\n".join(lines)


def _score_command(job: Path, workers: int, out: Path) -> list[str]:
    """The benchmark's ``dynaeval score`` of ``job`` on ``workers`` workers, results to ``out``."""
    return [sys.executable, "-m", "dynaeval", "score", str(job / "pred"), str(job / "gt"),
            "--focus", "motion", "--no-lpips", "-q", "--workers", str(workers), "-o", str(out),
            "--overwrite"]


def _children(cmds: list[list[str]], checkout: Path | None = None,
              env: dict[str, str] | None = None) -> tuple[float, float]:
    """Run the commands as child processes at once (in ``checkout``, which they then import:
    ``-m`` puts the working directory first on ``sys.path``; ``env``: more environment
    variables) and wait for all; returns their user and system CPU seconds, summed."""
    import os
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              cwd=checkout or REPO, env={**os.environ, **(env or {})})
             for cmd in cmds]
    codes = [proc.wait() for proc in procs]
    if any(codes):
        raise subprocess.CalledProcessError(max(codes), cmds[codes.index(max(codes))])
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime


def _score(job: Path, workers: int, out: Path, checkout: Path | None = None,
           env: dict[str, str] | None = None) -> tuple[float, float]:
    """One whole run in a child process; returns its user and system seconds (``_children``)."""
    return _children([_score_command(job, workers, out)], checkout, env)


def _score_shards(job: Path, count: int, outs: list[Path]) -> tuple[float, float]:
    """``count`` one-worker runs at once, ``--shard i/count`` each, OpenCV on one thread in
    each (``ONE_CORE``): the cameras in processes instead of threads. Returns their user and
    system seconds, summed."""
    cmds = [[*_score_command(job, 1, out), "--shard", f"{i}/{count}"]
            for i, out in enumerate(outs, start=1)]
    return _children(cmds, env=ONE_CORE)


def _numbers(path: Path | list[Path]) -> dict:
    """The numbers of a results file (of its shards' files, merged), warnings included."""
    if isinstance(path, list):
        from dynaeval.report.merge import merge_results

        doc = merge_results(path)
    else:
        doc = json.loads(path.read_text())
    return {k: doc[k] for k in ("frames", "cameras", "summary", "warnings")}


def bench_workers(job: Path, rounds: int, counts: tuple[int, ...] = (1, 2),
                  before: Path | None = None) -> str:
    """Markdown: whole runs with 1 and 2 workers, on one core, as 2 shard processes at once (and
    the ``before`` checkout's), alternating; wall ratios, CPU seconds, the ceiling of 2 workers
    over 1 that the one-core run's CPU sets; numbers equal."""
    from benchmarks.sections import checkout_commit

    top_n = counts[-1]
    runs = [("", n) for n in counts] + [("1core", 1), ("shards", top_n)]
    runs += [("before", n) for n in counts] if before else []
    cpu: dict[str, float] = {}  # best user + system seconds of each run
    system: dict[str, float] = {}  # the system seconds of that round
    with tempfile.TemporaryDirectory() as tmp:
        outs: dict[str, Path | list[Path]] = {
            f"{tag}{n}": Path(tmp) / f"{tag}w{n}.json" for tag, n in runs if tag != "shards"}
        outs[f"shards{top_n}"] = [Path(tmp) / f"shard{i}.json" for i in range(1, top_n + 1)]

        def one(tag: str, n: int) -> None:
            key = f"{tag}{n}"
            user, sys_s = (_score_shards(job, n, outs[key]) if tag == "shards" else _score(
                job, n, outs[key], before if tag == "before" else None,
                ONE_CORE if tag == "1core" else None))
            if user + sys_s < cpu.get(key, np.inf):
                cpu[key], system[key] = user + sys_s, sys_s

        best = interleaved({f"{tag}{n}": (lambda t=tag, n=n: one(t, n)) for tag, n in runs}, rounds)
        same = all(_numbers(outs[k]) == _numbers(outs[str(counts[0])]) for k in outs)
    base = best[str(counts[0])]["wall"]
    lines = [f"`python -m dynaeval score {job}/pred {job}/gt --focus motion --no-lpips -q "
             "--workers N` in a child process (2 cameras x 8 frames, 1920x1080), "
             f"{'checkouts and ' if before else ''}runs alternating, best of {rounds} wall times "
             f"each (CPU: the children's user + system seconds, best of the rounds). Results equal "
             f"for every run{' and checkout' if before else ''} (the shards merged): "
             f"{'yes' if same else 'NO'}.", "",
             "| code | workers | wall s | CPU s | of which system s | speed-up over 1 worker "
             "(this code) |", "|---|---:|---:|---:|---:|---:|"]
    for tag, n in runs:
        key = f"{tag}{n}"
        own = best[f"{'before' if tag == 'before' else ''}{counts[0]}"]["wall"]
        w = best[key]["wall"]
        label = {"": "this checkout", "1core": "this checkout, OpenCV on one thread (one core)",
                 "shards": f"this checkout, {n} processes at once (`--shard i/{n}`, one worker "
                           "and one OpenCV thread each)",
                 "before": f"before (`{checkout_commit(before)}`)"}[tag]
        lines.append(f"| {label} | {n} | {w:.1f} | {cpu[key]:.1f} | {system[key]:.1f} | "
                     f"{own / w:.2f} |")
    top = best[str(top_n)]["wall"]
    floor = cpu["1core1"] / top_n
    per = round_ratios(best, str(counts[0]), str(top_n), "wall")
    lines += ["", f"{top_n} workers against this checkout's 1: **{base / top:.2f}x** (issue 20: "
              f">= 1.7x); against one core (`{' '.join(f'{k}={v}' for k, v in ONE_CORE.items())}`): "
              f"{best['1core1']['wall'] / top:.2f}x. The speed-up in each of the {rounds} rounds "
              f"(1 worker's wall over {top_n} workers' of the same round): median "
              f"{np.median(per):.2f}, {per.min():.2f} to {per.max():.2f}.", "",
              f"**The ceiling.** 1 worker keeps {cpu[str(counts[0])] / base:.2f} cores busy "
              "(OpenCV's DIS runs on its 2 threads). With more workers OpenCV runs on one thread "
              "in each (`dynaeval.core.runtime.opencv_threads`), so their work is the one-core run's, "
              f"and its CPU seconds over {top_n}, **{floor:.1f} s**, are the {top_n} cores' floor: "
              f"{top_n} workers are {100 * (top / floor - 1):+.0f} % above it (below 0 when the "
              "floor's best round fell in a slower spell of the machine than theirs). So no "
              f"scheduling of this work can make {top_n} workers more than 1 worker's wall over "
              f"that floor, **{base / floor:.2f}x**, faster than 1 worker: the faster one worker's "
              "own threads make it, the lower this ceiling. Above the floor: the "
              f"{top_n} worker threads spend {cpu[str(top_n)]:.1f} CPU s, of which "
              f"{system[str(top_n)]:.1f} system, against the one-core run's {cpu['1core1']:.1f} "
              f"and {system['1core1']:.1f}; the shards, processes that share no address space "
              f"and no GIL, spend {cpu[f'shards{top_n}']:.1f}, of which "
              f"{system[f'shards{top_n}']:.1f} system, and take "
              f"{best[f'shards{top_n}']['wall']:.1f} s against the threads' {top:.1f} s. Work "
              "on both cores at once costs more CPU, in threads or in processes."]
    return "\n".join(lines)


def _ssim_floor(planes: list[np.ndarray], outs: list[np.ndarray], threads: int | None = None) -> None:
    """The five separable 11-tap Gaussian filters of SSIM (of x, y, x^2, y^2, xy) on float32
    ``(H, W, C)`` planes made beforehand, into buffers made beforehand: the arithmetic and
    memory floor of any SSIM of the pair (dynaeval's fused moments need four). ``threads``:
    OpenCV's thread count for them (None: as it is)."""
    import cv2

    from dynaeval.core.runtime import opencv_threads
    from dynaeval.metrics.structural import _kernel

    k = _kernel()
    with opencv_threads(threads):
        for plane, out in zip(planes, outs, strict=True):
            cv2.sepFilter2D(plane, cv2.CV_32F, k, k, dst=out)


def _module_of(checkout: Path, relpath: str, name: str) -> Any:
    """A module of another checkout, loaded from its file (it imports this checkout's others)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, checkout / relpath)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod


def bench_ssim(rounds: int, before: Path | None = None) -> str:
    """Markdown: dynaeval SSIM of a 1080p pair against its floor and scikit-image (and the
    ``before`` checkout's ``dynaeval/metrics/structural.py``)."""
    import skimage.metrics as skm

    import dynaeval.metrics as M
    from benchmarks.bench import sample_pair
    from benchmarks.sections import checkout_commit
    from dynaeval.core.runtime import opencv_threads

    pred, gt, _ = sample_pair(*SIZE)
    planes = [pred, gt, pred * pred, gt * gt, pred * gt]
    outs = [np.empty_like(p) for p in planes]
    paths = {
        "dynaeval": lambda: M.ssim(pred, gt, data_range=1.0),
        "floor": lambda: _ssim_floor(planes, outs),
        "floor2": lambda: _ssim_floor(planes, outs, threads=2),
        "skimage": lambda: skm.structural_similarity(pred, gt, data_range=1.0, channel_axis=2,
                                                     gaussian_weights=True, sigma=1.5,
                                                     use_sample_covariance=False),
    }
    old = None
    if before is not None:
        old = _module_of(before, "dynaeval/metrics/structural.py", "structural_before")
        paths["before"] = lambda: old.ssim(pred, gt, data_range=1.0)
    with opencv_threads(1):  # the floor's full-frame filters would otherwise use both cores,
        best = interleaved(paths, rounds)  # whose CPU time counts their synchronisation too
    ref = skm.structural_similarity(pred.astype(np.float64), gt.astype(np.float64), data_range=1.0,
                                    channel_axis=2, gaussian_weights=True, sigma=1.5,
                                    use_sample_covariance=False)
    got = float(M.ssim(pred, gt, data_range=1.0))
    floor = best["floor"]["cpu"]
    lines = [f"One {SIZE[1]}x{SIZE[0]} RGB float32 pair (`benchmarks.bench.sample_pair`), best of "
             f"{rounds} alternating rounds, CPU time, OpenCV on one thread (as in a worker: the "
             "floor's full-frame filters on two threads cost more CPU time, their "
             "synchronisation, and would flatter the ratio). dynaeval's deviation from the float64 "
             f"reference (scikit-image on float64 input): {abs(got - ref):.1e}."]
    if old is not None:
        same = (old.ssim(pred, gt, data_range=1.0) == got
                and np.array_equal(old.ssim_map(pred, gt), M.ssim_map(pred, gt)))
        lines[0] += (f" Before (`{checkout_commit(before)}`) and now give the same bits (value and "
                     f"map): {'yes' if same else 'NO'}.")
    lines += ["", "| path | CPU ms | / floor |", "|---|---:|---:|"]
    labels = [("dynaeval", "dynaeval `ssim`")]
    if old is not None:
        labels.append(("before", f"dynaeval `ssim` before (`{checkout_commit(before)}`)"))
    labels += [("floor", "floor: the 5 separable Gaussian filters alone, float32"),
               ("floor2", "the same filters, OpenCV on two threads (CPU time of both)"),
               ("skimage", "scikit-image, float32 input")]
    for name, label in labels:
        c = best[name]["cpu"]
        lines.append(f"| {label} | {1e3 * c:.0f} | {c / floor:.2f} |")
    per = round_ratios(best, "dynaeval", "floor")
    lines += ["", f"dynaeval `ssim` / floor in each of the {rounds} rounds: median "
              f"**{np.median(per):.2f}**, {per.min():.2f} to {per.max():.2f}; at most 1.3 in "
              f"{int((per <= 1.3).sum())} of {rounds} (issue 20: within 1.3x)."]
    return "\n".join(lines)


SECTIONS = {
    "pairs": ("temporal-pairs", "The temporal pass against its floor", bench_pairs),
    "workers": ("workers", "Two workers on a 1080p job", bench_workers),
    "ssim": ("ssim-floor", "SSIM against its floor", bench_ssim),
}


def main(argv: list[str] | None = None) -> int:
    from benchmarks.sections import command_line, publish, utc_stamp

    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    parser.add_argument("--job", default="/tmp/dynaeval-bench-1080p", help="job folder (made if missing)")
    parser.add_argument("--parts", default="pairs,workers,ssim", help="comma-separated: " + ",".join(SECTIONS))
    parser.add_argument("--rounds", type=int, default=3, help="alternating timed rounds (best kept)")
    parser.add_argument("--out", default="docs/benchmarks.md", help="markdown file ('-': print only)")
    parser.add_argument("--before", type=Path, metavar="CHECKOUT",
                        help="also time another checkout of dynaeval (workers, ssim): its runs and "
                             "its SSIM, alternating with this one's")
    args = parser.parse_args(argv)
    command = command_line(COMMAND, argv)
    started = utc_stamp()
    from dynaeval.core.runtime import keep_freed_memory

    keep_freed_memory()  # the in-process parts run with the allocator of the dynaeval command
    job = make_job(args.job)
    for part in args.parts.split(","):
        name, title, fn = SECTIONS[part]
        if part == "ssim":
            body = fn(args.rounds, before=args.before)
        elif part == "workers":
            body = fn(job, args.rounds, before=args.before)
        else:
            body = fn(job, args.rounds)
        text = f"## {title}\n\nCommand: `{command}` — run {started}.\n\n{body}\n"
        publish(args.out, name, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

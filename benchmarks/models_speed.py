"""Speed of the reference models' training and rendering, this checkout against an older one.

For every model preset it trains ``--steps`` steps and renders ``--views`` eval views with the
models' own command lines, once with this checkout and once with ``--before DIR`` (a worktree of
an older commit), one after the other so both see the same machine load, and prints seconds per
step, rays per second (wall and CPU) and render seconds per view with the ratios::

    git worktree add --detach /tmp/before a1f0bb6
    python -m reference_models.scenes render single-player-closeup DATA --size small --frames 24
    python benchmarks/models_speed.py DATA --before /tmp/before [--out docs/reference-models.md]

Step times are the training loop's own (``log.jsonl``'s ``it_per_s`` over the last logged window,
evaluation excluded), and so are the rays per CPU second (``train_cpu_seconds`` over that
window: the compute a step needs, whatever else runs on the machine); render times are those of
``render_image`` (each checkout's own, with its default chunk) over ``--views`` eval views
spread over the clip, model and data loading not counted. One torch thread each
(``--threads``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

if not __package__:  # run as `python benchmarks/NAME.py`: make `benchmarks` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

COMMAND = "python benchmarks/models_speed.py"
REPO = Path(__file__).resolve().parents[1]

STUDY = ("--batch-rays", "1024", "--sampling", "isg", "--static-warmup", "0.15",
         "--importance-fraction", "0.5")
"""The study's training arguments (the 30-minute close-up runs of docs/reference-models.md)."""

VARIANTS = (
    ("kplanes", "small-dynbox-fine", STUDY),
    ("kplanes", "small", ()),
    ("kplanes", "small-dynbox", ()),
    ("nerfplayer", "small", ()),
)
"""(model, size, extra train arguments). A checkout whose command line lacks one of the extra
arguments (``supports``) is not measured for that row (—)."""


_RENDER = """
import sys, time, importlib, numpy as np, torch
from reference_models.common.data import load_dataset
from reference_models.common import train as T
run, model, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
torch.set_num_threads(1)
if hasattr(T, "PLANE_HEAP"):  # this checkout's render_run keeps freed memory: so does its measure
    T.keep_freed_memory(largest=T.PLANE_HEAP)
load_run = T.load_run
cfg, net, _ = load_run(run, importlib.import_module("reference_models." + model).SPEC)
views = load_dataset(cfg["data"]).eval
net.eval()
idx = np.round(np.linspace(0, len(views) - 1, n)).astype(int)
net.render_image(torch.from_numpy(views.c2w[0]), torch.from_numpy(views.intrinsics[0]),
                 float(views.times[0]), views.height, views.width, stride=max(views.height, views.width))
t0 = time.perf_counter()
for i in idx:
    net.render_image(torch.from_numpy(views.c2w[i]), torch.from_numpy(views.intrinsics[i]),
                     float(views.times[i]), views.height, views.width)
print((time.perf_counter() - t0) / len(idx))
"""
"""Renders ``n`` eval views of a run with the checkout's own ``render_image`` (its default chunk)
and prints seconds per view: model and data loading are not counted, nor is a first one-pixel
render (loading compiled loops: numba's cache, ~0.25 s a function). The allocator is set as the
checkout's ``render_run`` sets it (``keep_freed_memory(largest=PLANE_HEAP)`` where it has
``PLANE_HEAP``; before, this measure left glibc returning freed buffers to the kernel, which
``render_run`` no longer does, so its render column was not what a render costs)."""


def _run(code: Path, args: list[str], threads: int) -> str:
    """Stdout of ``python ARGS`` (``-m ...`` or ``-c ...``) run in the checkout ``code`` with it
    first on the path (``-m`` and ``-c`` put the working directory first); raises on failure."""
    env = {**os.environ, "PYTHONPATH": str(code), "OMP_NUM_THREADS": str(threads)}
    done = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, cwd=code)
    if done.returncode:
        raise RuntimeError(f"{' '.join(args[:3])} failed:\n{done.stderr[-2000:]}")
    return done.stdout


def supports(code: Path, model: str, extra: tuple[str, ...], threads: int) -> bool:
    """Whether the checkout ``code``'s ``train`` command takes every option in ``extra``."""
    usage = _run(code, ["-m", f"reference_models.{model}", "train", "--help"], threads)
    return all(a in usage for a in extra if a.startswith("--"))


def measure(code: Path, data: Path, model: str, size: str, extra: tuple[str, ...], steps: int,
            views: int, threads: int) -> dict:
    """One row: s/step, rays per wall second and per CPU second of training, and render s/view
    of ``model``'s ``size`` with the code at ``code`` (its processes run in ``code``, which ``-m`` /
    ``-c`` put first on the path). Training speeds are those of the last logged window (the
    loop's ``it_per_s`` and the ``train_cpu_seconds`` between the last two log lines)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        _run(code, ["-m", f"reference_models.{model}", "train", str(data), "--out", str(run), "--size", size,
                    "--iters", str(steps), "--threads", str(threads), "--quiet", *extra], threads)
        log = [json.loads(x) for x in (run / "log.jsonl").read_text().splitlines()]
        rays = json.loads((run / "config.json").read_text())["train_config"]["batch_rays"]
        step_s = 1.0 / log[-1]["it_per_s"]
        if len(log) < 2:
            raise RuntimeError(f"{model} {size}: {steps} steps log one window only; use more --steps")
        cpu_s = ((log[-1]["train_cpu_seconds"] - log[-2]["train_cpu_seconds"])
                 / (log[-1]["step"] - log[-2]["step"]))
        per_view = float(_run(code, ["-c", _RENDER, str(run), model, str(views)], threads).split()[-1])
    return {"model": model, "size": size + (" " + " ".join(extra) if extra else ""), "rays": rays,
            "s_per_step": step_s, "rays_per_s": rays / step_s, "rays_per_cpu_s": rays / cpu_s,
            "render_s_per_view": per_view}


def table(rows: list[dict]) -> str:
    """Markdown table of paired rows with after/before ratios (speed-ups: after / before rays per
    second, before / after render time)."""
    head = ("| model | preset | rays/step | s/step before | s/step after | rays/s before | "
            "rays/s after | speed-up (wall) | rays/CPU-s before | rays/CPU-s after | "
            "speed-up (CPU) | render s/view before | after | speed-up |")
    out = [head, "|" + "---|" * 14]
    for r in rows:
        b, a = r.get("before"), r["after"]

        def fmt(key: str, row: dict | None, spec: str = ".3f") -> str:
            return "—" if row is None else format(row[key], spec)

        wall_up = "—" if b is None else f"{a['rays_per_s'] / b['rays_per_s']:.2f}x"
        cpu_up = "—" if b is None else f"{a['rays_per_cpu_s'] / b['rays_per_cpu_s']:.2f}x"
        render_up = "—" if b is None else f"{b['render_s_per_view'] / a['render_s_per_view']:.2f}x"
        out.append(f"| {a['model']} | {a['size']} | {a['rays']} | {fmt('s_per_step', b)} | "
                   f"{a['s_per_step']:.3f} | {fmt('rays_per_s', b, '.0f')} | {a['rays_per_s']:.0f} | {wall_up} | "
                   f"{fmt('rays_per_cpu_s', b, '.0f')} | {a['rays_per_cpu_s']:.0f} | {cpu_up} | "
                   f"{fmt('render_s_per_view', b, '.2f')} | {a['render_s_per_view']:.2f} | "
                   f"{render_up} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    from benchmarks.sections import checkout_commit, command_line, put_section, utc_stamp

    p = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n")[0])
    p.add_argument("data", type=Path, help="dataset folder (the scene generator's output)")
    p.add_argument("--before", type=Path, required=True, help="checkout of the older code")
    p.add_argument("--steps", type=int, default=50, help="training steps per measurement")
    p.add_argument("--views", type=int, default=2, help="eval views rendered per measurement")
    p.add_argument("--threads", type=int, default=1, help="torch threads per process")
    p.add_argument("--out", type=Path, help="write the table into this file's `models-speed` section")
    args = p.parse_args(argv)
    args.data, args.before = args.data.resolve(), args.before.resolve()
    if not (args.data / "transforms.json").is_file():
        print(f"error: {args.data}: no transforms.json (render a scene first)", file=sys.stderr)
        return 2
    if not (args.before / "reference_models").is_dir():
        print(f"error: {args.before}: not a checkout of this repository", file=sys.stderr)
        return 2
    rows = []
    for k, (model, size, extra) in enumerate(VARIANTS):
        row = {}
        codes = [("before", args.before), ("after", REPO)]
        for name, code in [(n, c) for n, c in codes if supports(c, model, extra, args.threads)]:
            print(f"[{k + 1}/{len(VARIANTS)}] {model} {size} {' '.join(extra)} {name}", file=sys.stderr)
            row[name] = measure(code, args.data, model, size, extra, args.steps, args.views,
                                args.threads)
        rows.append(row)
    text = (f"`{command_line(COMMAND, argv)}` ({utc_stamp()}; before = {checkout_commit(args.before)}, after = {checkout_commit(REPO)}; "
            f"load average at the end {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores):\n\n"
            + table(rows) + "\n")
    print(text)
    if args.out:
        put_section(args.out, "models-speed", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""CPU seconds of the study's training step, for an A/B of two checkouts run one after the other.

    PYTHONPATH=CHECKOUT python benchmarks/study_step.py DATA [--size small-dynbox-fine-fp]
        [--rays 2048] [--iters 100] [--label NAME]

Trains K-Planes on DATA (a scene generator output) with the study's sampling (ISG, half of each
batch by importance, no static warm-up) for ``--iters`` steps on one thread, without
evaluation, in a temporary folder, and prints one line: CPU milliseconds per step and rays per
CPU second over the steps after the first logged window (set-up, compilation and the first
steps' allocations excluded), and the batch PSNR at the last step, so two checkouts can be seen
to compute the same numbers. Run it with ``PYTHONPATH`` at each checkout in turn, under the same
load (``benchmarks/models_speed.py`` compares whole presets with ``--before``; this one takes a
size that an older checkout may lack, e.g. the ``-fp`` presets).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path)
    ap.add_argument("--size", default="small-dynbox-fine-fp")
    ap.add_argument("--rays", type=int, default=2048)
    ap.add_argument("--iters", type=int, default=100)
    ap.add_argument("--label", default="")
    args = ap.parse_args()
    import torch

    from reference_models.common.train import train
    from reference_models.kplanes import SPEC

    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        train(SPEC, args.data, out, size=args.size, iters=args.iters, sampling="isg",
              progress=False, overrides={"batch_rays": args.rays, "importance_fraction": 0.5,
                                         "static_warmup": 0.0, "eval_every": 10**9,
                                         "log_every": max(1, args.iters // 5)})
        log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    first, last = log[0], log[-1]
    cpu = (last["train_cpu_seconds"] - first["train_cpu_seconds"]) / (last["step"] - first["step"])
    print(f"{args.label or args.size} {args.size} {args.rays} rays: {cpu * 1000:.0f} ms CPU/step, "
          f"{args.rays / cpu:.0f} rays/CPU-s, batch PSNR at step {last['step']} {last['psnr']!r}")


if __name__ == "__main__":
    main()

"""Size and speed of a model preset: parameters, time per training step, peak memory::

    python -m reference_models.common.bench DATA --model kplanes --size small [--steps 5] [--threads 1]

Prints one Markdown table row. Times are per step of the preset's batch (wall and process CPU
seconds, the median over ``--steps`` steps after one warm-up step); memory is the process's peak
resident set (MB, Linux ``ru_maxrss``), which includes the loaded dataset.
"""

from __future__ import annotations

import argparse
import importlib
import resource
import statistics
import sys
import time

from dynaeval.errors import InputError


def measure(data: str, model: str, size: str, steps: int) -> dict:
    """Parameters and step times of ``model``'s ``size`` preset on the dataset ``data``."""
    import torch

    from reference_models.common.data import load_dataset
    from reference_models.common.importance import RaySampler
    from reference_models.common.model import RayBatch
    from reference_models.common.rays import pixel_rays
    from reference_models.common.train import build_model, make_optimizer, scene_info

    spec = importlib.import_module(f"reference_models.{model}").SPEC
    if size not in spec.presets:
        raise InputError(f"unknown size {size!r}; expected one of {', '.join(spec.presets)}")
    ds = load_dataset(data)
    model_cfg, render_cfg, train_cfg = spec.presets[size]
    scene = scene_info(ds)
    if spec.scene_extras is not None:
        scene.update(spec.scene_extras(model_cfg, ds))
    net = build_model(spec, model_cfg, render_cfg, scene)
    optim = make_optimizer(net, train_cfg)
    sampler = RaySampler(ds.train)
    views = ds.train
    c2w, intr = torch.from_numpy(views.c2w), torch.from_numpy(views.intrinsics)
    walls, cpus = [], []
    for i in range(steps + 1):
        v, r, c = sampler.sample(train_cfg.batch_rays)
        t0, c0 = time.perf_counter(), time.process_time()
        o, d = pixel_rays(c2w[v], intr[v], r, c)
        res = net.render(RayBatch(o, d, torch.from_numpy(views.times)[v]), training=True)
        target = torch.from_numpy(views.images)[v, r, c].float() / 255.0
        loss = ((res.rgb - target) ** 2).mean() + sum(res.losses.values()) + sum(net.regularizers().values())
        optim.zero_grad()
        loss.backward()
        optim.step()
        if i:  # the first step warms up allocators and caches
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
    return {
        "model": model, "size": size, "rays": train_cfg.batch_rays,
        "samples": f"{'+'.join(map(str, render_cfg.proposal_samples))}+{render_cfg.final_samples}",
        "params_M": sum(p.numel() for p in net.parameters()) / 1e6,
        "encoding_params_M": sum(p.numel() for p in net.encoding.parameters()) / 1e6,
        "step_wall_s": statistics.median(walls), "step_cpu_s": statistics.median(cpus),
        "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 done, 2 bad input)."""
    p = argparse.ArgumentParser(prog="python -m reference_models.common.bench",
                                description="Parameters, seconds per training step, peak memory.")
    p.add_argument("data", help="dataset folder")
    p.add_argument("--model", default="kplanes", choices=("kplanes", "nerfplayer"))
    p.add_argument("--size", default="small", help="preset name")
    p.add_argument("--steps", type=int, default=5, help="timed steps (after one warm-up)")
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    args = p.parse_args(argv)
    import torch

    torch.set_num_threads(args.threads)
    try:
        row = measure(args.data, args.model, args.size, max(args.steps, 1))
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    row["threads"] = args.threads
    from reference_models.common.curves import markdown_table

    print(markdown_table([row]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""CPU seconds of one eval-view render with the decoder MLPs' ReLUs in place against out of place,
interleaved in one process, and whether the two renders are equal.

    python benchmarks/render_relu.py DATA [--iters 30] [--repeats 3]

Trains each reference model (K-Planes ``small``, ``small-dynbox-fine`` and NeRFPlayer ``small``)
for ``--iters`` steps on DATA (a scene generator output) in a temporary folder, then renders the
first eval view ``--repeats`` times each way, alternating (in place, then out of place, ...), on
one thread, and prints per model: median CPU seconds a view both ways, their ratio, and the
largest absolute difference between the two images (0: the same float32 image). Alternating in
one process keeps the comparison fair on a shared machine, where two separate runs of
``benchmarks/models_speed.py`` moved by 20 %.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

MODELS = (("kplanes", "small"), ("kplanes", "small-dynbox-fine"), ("nerfplayer", "small"))
"""(model, preset) rendered."""


def _render_seconds(net, views, inplace: bool) -> tuple[float, object]:
    import torch

    for m in net.modules():
        if isinstance(m, torch.nn.ReLU):
            m.inplace = inplace
    c0 = time.process_time()
    img = net.render_image(torch.from_numpy(views.c2w[0]), torch.from_numpy(views.intrinsics[0]),
                           float(views.times[0]), views.height, views.width)
    return time.process_time() - c0, img


def main() -> None:
    import importlib

    import torch

    from reference_models.common.data import load_dataset
    from reference_models.common.train import load_run, train

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path)
    ap.add_argument("--iters", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    torch.set_num_threads(1)
    views = load_dataset(args.data).eval
    print("| model | preset | out of place CPU s/view | in place | speed-up | max abs difference |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for model, size in MODELS:
            spec = importlib.import_module(f"reference_models.{model}").SPEC
            run = Path(tmp) / f"{model}-{size}"
            train(spec, args.data, run, size=size, iters=args.iters, progress=False,
                  overrides={"eval_every": 0})
            _, net, _ = load_run(run, spec)
            net.eval()
            times: dict[bool, list[float]] = {True: [], False: []}
            images = {}
            for _ in range(args.repeats):
                for inplace in (True, False):
                    seconds, images[inplace] = _render_seconds(net, views, inplace)
                    times[inplace].append(seconds)
            off, on = statistics.median(times[False]), statistics.median(times[True])
            diff = float((images[True] - images[False]).abs().max())
            print(f"| {model} | {size} | {off:.2f} | {on:.2f} | {off / on:.2f}x | {diff:.1e} |",
                  flush=True)


if __name__ == "__main__":
    main()

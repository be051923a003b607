"""``python -m reference_models.detector train|export|calibrate|evaluate``; exit 2 on bad input."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from dataclasses import replace
from pathlib import Path

DEFAULT_CACHE = Path.home() / ".cache" / "dynaeval-detector"
"""Where rendered views are cached (outside the repository)."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m reference_models.detector",
                                description="Train, export and evaluate the default ONNX detector.")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="render training views, train, export RUN/detector.onnx")
    t.add_argument("--out", required=True, help="run folder (model.pt, train.json, detector.onnx)")
    t.add_argument("--size", default="small", choices=("tiny", "small"),
                   help="tiny: seconds (tests); small: the shipped model")
    t.add_argument("--seed", type=int, default=0, help="seed of initialisation and augmentation")
    t.add_argument("--steps", type=int, help="optimiser steps (default: the size's)")
    t.add_argument("--seeds", type=int, help="training scenes per preset (default: the size's)")
    t.add_argument("--threads", type=int, help="torch threads (default 1)")
    t.add_argument("--lr", type=float, help="peak learning rate (default: the size's)")
    t.add_argument("--init", help="start from this model.pt (a second training stage)")
    t.add_argument("--cache", default=str(DEFAULT_CACHE), help="render cache folder")
    t.add_argument("--fp16", action="store_true", help="store ONNX weights as float16")
    e = sub.add_parser("export", help="export a checkpoint (model.pt) to YOLO-convention ONNX")
    e.add_argument("checkpoint")
    e.add_argument("--out", required=True)
    e.add_argument("--fp16", action="store_true")
    c = sub.add_parser("calibrate", help="per-class score thresholds on calibration renders, "
                                         "written into the ONNX metadata")
    c.add_argument("model", help="ONNX file to calibrate")
    c.add_argument("--out", required=True, help="calibrated copy (may be the same file)")
    c.add_argument("--json", help="write the counts per threshold here")
    c.add_argument("--cache", default=str(DEFAULT_CACHE), help="render cache folder")
    v = sub.add_parser("evaluate", help="AP / recall / precision on held-out seeds via dynaeval")
    v.add_argument("model", help="ONNX file")
    v.add_argument("--out", help="write the Markdown table here")
    v.add_argument("--json", help="write the raw numbers here")
    v.add_argument("--size", default="small", choices=("tiny", "small"),
                   help="tiny: one 64x36 view per preset (tests); small: the docs table")
    v.add_argument("--seeds", type=int, help="held-out scenes per preset (default 5)")
    v.add_argument("--cache", default=str(DEFAULT_CACHE), help="render cache folder")
    return p


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _train(args) -> int:
    from reference_models.detector.data import TINY_PLAN, RenderPlan, training_samples
    from reference_models.detector.model import export_onnx
    from reference_models.detector.train import TINY_CONFIG, TrainConfig, train

    plan = TINY_PLAN if args.size == "tiny" else RenderPlan()
    cfg = TINY_CONFIG if args.size == "tiny" else TrainConfig()
    if args.seeds:
        plan = replace(plan, seeds=args.seeds)
    cfg = replace(cfg, seed=args.seed, **({"steps": args.steps} if args.steps else {}),
                  **({"threads": args.threads} if args.threads else {}),
                  **({"lr": args.lr} if args.lr else {}))
    out = Path(args.out)
    start = time.perf_counter()
    samples = training_samples(Path(args.cache), plan, progress=_log if args.size != "tiny" else None)
    render_s = time.perf_counter() - start
    _log(f"{len(samples)} training views ready in {render_s:.0f} s")
    net = train(samples, cfg, out, log=_log, init=Path(args.init) if args.init else None)
    meta = {"trained_by": "python -m reference_models.detector " + shlex.join(sys.argv[1:]),
            "train_seed": str(args.seed), "render_plan": json.dumps(plan.__dict__)}
    export_onnx(net, out / "detector.onnx", meta, fp16=args.fp16)
    info = json.loads((out / "train.json").read_text())
    info.update(render_plan=plan.__dict__, render_or_load_seconds=round(render_s, 1),
                command=meta["trained_by"])
    (out / "train.json").write_text(json.dumps(info, indent=1) + "\n")
    _log(f"wrote {out / 'detector.onnx'} ({(out / 'detector.onnx').stat().st_size / 1e6:.2f} MB)")
    return 0


def _export(args) -> int:
    import torch

    from reference_models.detector.model import CenterNetSmall, export_onnx

    net = CenterNetSmall()
    net.load_state_dict(torch.load(args.checkpoint, map_location="cpu", weights_only=True))
    export_onnx(net, args.out, {"trained_by": "python -m reference_models.detector train"}, fp16=args.fp16)
    _log(f"wrote {args.out}")
    return 0


def _calibrate(args) -> int:
    from reference_models.detector.calibrate import CALIB_SETS, choose, sweep, write_thresholds

    counts = sweep(args.model, args.cache, CALIB_SETS, progress=_log)
    chosen = choose(counts)
    command = "python -m reference_models.detector " + shlex.join(sys.argv[1:])
    write_thresholds(args.model, args.out, {c: r["threshold"] for c, r in chosen.items()}, command)
    if args.json:
        Path(args.json).write_text(json.dumps({"counts": counts, "chosen": chosen,
                                               "command": command}, indent=1) + "\n")
    for c, r in chosen.items():
        print(f"{c}: threshold {r['threshold']:.2f}  recall {r['recall']:.3f}  precision "
              f"{r['precision']:.3f}  F1 {r['f1']:.3f}  ({r['gt']} ground-truth boxes)")
    return 0


def _evaluate(args) -> int:
    from dynaeval.core.runtime import file_sha256
    from reference_models.detector.evaluate import EVAL_SETS, TINY_SETS, evaluate, to_markdown

    sets = TINY_SETS if args.size == "tiny" else EVAL_SETS
    if args.seeds:
        sets = tuple(replace(s, seeds=args.seeds) for s in sets)
    start = time.perf_counter()
    result = evaluate(args.model, args.cache, sets, progress=_log)
    seconds = time.perf_counter() - start
    command = "python -m reference_models.detector " + shlex.join(sys.argv[1:] if sys.argv[1:] else [])
    md = to_markdown(result, command, seconds, file_sha256(args.model))
    if args.out:
        Path(args.out).write_text(md)
    if args.json:
        Path(args.json).write_text(json.dumps({**result, "seconds": seconds}, indent=1) + "\n")
    print(md)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 done, 2 bad input)."""
    from dynaeval.errors import InputError

    args = _parser().parse_args(argv)
    try:
        return {"train": _train, "export": _export, "calibrate": _calibrate,
                "evaluate": _evaluate}[args.command](args)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

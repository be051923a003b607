"""The command line every reference model shares (exit 0 done, 2 bad input)::

    python -m reference_models.<model> train DATA --out RUN [--size tiny|small] [--iters N]
        [--minutes M] [--sampling uniform|isg|ist] [--importance-fraction F]
        [--static-warmup F] [--batch-rays N] [--clock wall|cpu] [--regularize-every K]
        [--proposal-rays-every K] [--resume] [--init STADIUM [--carry-optimizer]] [--threads 1]
        [--device cpu|cuda|auto]
    python -m reference_models.<model> stadium CLIP_DATA STADIUM_DATA --out STADIUM [--size ...]
        [--iters N] [--minutes M] [--clock wall|cpu] [--batch-rays N] [--device cpu|cuda|auto]
    python -m reference_models.<model> render RUN [--data DATA] [--every N] [--device cpu|cuda|auto]
"""

from __future__ import annotations

import argparse
import sys

from dynaeval.errors import InputError
from reference_models.common.device import DEVICES
from reference_models.common.importance import SAMPLING
from reference_models.common.stadium import train_stadium
from reference_models.common.train import ModelSpec, render_run, train

_DEVICE_HELP = ("where the model runs: cpu (default), cuda (an error without a GPU) or auto (cuda "
                "when torch sees one, else cpu); a run trained on one renders on any")


def _parser(spec: ModelSpec) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=f"python -m reference_models.{spec.name}",
                                description=f"Train the reference {spec.name} model and render "
                                            "its evaluation cameras for `dynaeval score`.")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train on a dataset folder (transforms.json)")
    t.add_argument("data", help="dataset folder (scene generator, nerfstudio or D-NeRF files)")
    t.add_argument("--out", required=True, help="run folder (config, checkpoint, log)")
    t.add_argument("--size", default="small", help=f"preset: {', '.join(spec.presets)} (default small)")
    t.add_argument("--iters", type=int, help="optimisation steps (default: the preset's)")
    t.add_argument("--minutes", type=float,
                   help="training-time budget: stop (and anneal) by then even before --iters")
    t.add_argument("--sampling", choices=SAMPLING, help="ray sampling (default: the preset's, uniform)")
    t.add_argument("--importance-fraction", type=float,
                   help="share of each batch drawn by importance weights (default: the preset's)")
    t.add_argument("--static-warmup", type=float,
                   help="fraction of the run that learns the static scene first (K-Planes)")
    t.add_argument("--batch-rays", type=int, help="rays per step (default: the preset's)")
    t.add_argument("--clock", choices=("wall", "cpu"),
                   help="what --minutes counts: elapsed (wall, default) or process CPU time")
    t.add_argument("--regularize-every", type=int,
                   help="steps between the plane regularisers, at that many times their weights (default: the preset's)")
    t.add_argument("--proposal-rays-every", type=int,
                   help="every k-th ray of a batch trains the proposals (default: the preset's)")
    t.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    t.add_argument("--init", metavar="STADIUM",
                   help="start from the weights of a pre-trained stadium run (see `stadium`)")
    t.add_argument("--carry-optimizer", action="store_true",
                   help="with --init: also its Adam state for the parameters it trained")
    t.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1: faster than 2 on a shared machine)")
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.add_argument("--device", choices=DEVICES, default="cpu", help=_DEVICE_HELP)
    st = sub.add_parser("stadium", help="pre-train the static field on the empty stadium, the "
                                        "start of every run on the clip (train --init)")
    st.add_argument("clip", help="the clip's dataset folder (the model is built for its scene)")
    st.add_argument("stadium", help="the same cameras without players and ball (scenes render "
                                    "PRESET OUT --hide person --hide ball --frames 1)")
    st.add_argument("--out", required=True, help="run folder (config, checkpoint, log)")
    st.add_argument("--size", default="small", help=f"preset: {', '.join(spec.presets)} (default small)")
    st.add_argument("--iters", type=int, help="optimisation steps (default: the preset's)")
    st.add_argument("--minutes", type=float, help="training-time budget (see train)")
    st.add_argument("--clock", choices=("wall", "cpu"), help="what --minutes counts (see train)")
    st.add_argument("--batch-rays", type=int, help="rays per step (default: the preset's)")
    st.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    st.add_argument("--quiet", action="store_true", help="no progress bar")
    st.add_argument("--device", choices=DEVICES, default="cpu", help=_DEVICE_HELP)
    r = sub.add_parser("render", help="render the eval cameras to RUN/pred/<camera>/<frame>.png")
    r.add_argument("run", help="run folder written by train")
    r.add_argument("--data", help="dataset folder (default: the one the run was trained on)")
    r.add_argument("--every", type=int, default=1,
                   help="render every N-th eval frame only (score with --allow-missing)")
    r.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1: faster than 2 on a shared machine)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--device", choices=DEVICES, default="cpu", help=_DEVICE_HELP)
    return p


def _summary(rec: dict) -> str:
    return ", ".join(f"{k} {rec[k]:.4g}" for k in ("step", "psnr", "eval_psnr", "train_seconds")
                     if k in rec)


def main(spec: ModelSpec, argv: list[str] | None = None) -> int:
    """Run the CLI for ``spec``; returns the exit code."""
    args = _parser(spec).parse_args(argv)
    import torch

    torch.set_num_threads(max(1, args.threads))
    try:
        if args.command == "train":
            given = {"minutes": args.minutes, "importance_fraction": args.importance_fraction,
                     "static_warmup": args.static_warmup, "batch_rays": args.batch_rays,
                     "clock": args.clock, "regularize_every": args.regularize_every,
                     "proposal_rays_every": args.proposal_rays_every}
            over = {k: v for k, v in given.items() if v is not None}
            if args.carry_optimizer:
                if args.init is None:
                    raise InputError("--carry-optimizer goes with --init (the run whose Adam "
                                     "state it carries)")
                over["init_optimizer"] = True
            rec = train(spec, args.data, args.out, size=args.size, iters=args.iters,
                        sampling=args.sampling, resume=args.resume, progress=not args.quiet,
                        overrides=over, init=args.init, device=args.device)
            print(f"trained {spec.name}: {_summary(rec)}; checkpoint in {args.out}", file=sys.stderr)
        elif args.command == "stadium":
            given = {"minutes": args.minutes, "batch_rays": args.batch_rays, "clock": args.clock}
            rec = train_stadium(spec, args.clip, args.stadium, args.out, size=args.size,
                                iters=args.iters, progress=not args.quiet, device=args.device,
                                overrides={k: v for k, v in given.items() if v is not None})
            print(f"pre-trained the {spec.name} stadium: {_summary(rec)}; checkpoint in {args.out}",
                  file=sys.stderr)
        else:
            files = render_run(spec, args.run, args.data, progress=not args.quiet, every=args.every,
                               device=args.device)
            print(f"rendered {len(files)} views to {args.run}/pred", file=sys.stderr)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0

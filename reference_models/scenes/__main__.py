"""``python -m reference_models.scenes render PRESET OUT [options]``; exit 2 on bad input."""

from __future__ import annotations

import argparse
import sys

from dynaeval.errors import InputError
from reference_models.scenes.output import render_scene
from reference_models.scenes.presets import PRESETS, SIZES


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m reference_models.scenes",
                                description="Render synthetic soccer scenes with exact ground truth.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a preset into a folder")
    r.add_argument("preset", help=f"one of: {', '.join(PRESETS)}")
    r.add_argument("out", help="output folder (new or empty)")
    r.add_argument("--size", default="small", help=f"one of: {', '.join(SIZES)} (default small)")
    r.add_argument("--width", type=int)
    r.add_argument("--height", type=int)
    r.add_argument("--frames", type=int)
    r.add_argument("--fps", type=float)
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--spp", type=int, help="samples per pixel, a square number (1, 4, 9, ..)")
    r.add_argument("--hide", action="append", default=[],
                   help="leave out a class (ball, person) or an instance id; repeatable")
    r.add_argument("--cameras", help="comma-separated camera names to render (default: all)")
    r.add_argument("--overwrite", action="store_true", help="allow a non-empty output folder")
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 done, 2 bad input)."""
    args = _parser().parse_args(argv)
    from tqdm import tqdm

    hide = tuple(int(h) if h.isdigit() else h for h in args.hide)
    bar = tqdm(total=0, unit="view", file=sys.stderr, desc=args.preset)

    def progress(done: int, total: int) -> None:
        bar.total = total
        bar.update(done - bar.n)

    try:
        meta = render_scene(args.preset, args.out, size=args.size, seed=args.seed, width=args.width,
                            height=args.height, frames=args.frames, fps=args.fps, spp=args.spp,
                            hide=hide, overwrite=args.overwrite, progress=progress,
                            cameras=tuple(args.cameras.split(",")) if args.cameras else None)
    except InputError as err:
        bar.close()
        print(f"error: {err}", file=sys.stderr)
        return 2
    bar.close()
    print(f"rendered {args.preset} to {args.out} in {meta['render_seconds']:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

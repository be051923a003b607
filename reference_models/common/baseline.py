"""The constant-colour baseline: every eval pixel painted the mean colour of the training images::

    python -m reference_models.common.baseline DATA --out RUN [--every N]

Writes ``RUN/pred/<camera>/<frame>.png`` like a trained model's ``render``, so ``dynaeval score``
puts a floor under the models' numbers.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from dynaeval.errors import InputError
from reference_models.common.data import load_dataset


def write_constant_baseline(data: str | Path, out: str | Path, every: int = 1) -> list[Path]:
    """Write the baseline's eval frames (every ``every``-th of each camera); returns the files."""
    import cv2

    ds = load_dataset(data)
    if ds.eval is None:
        raise InputError("the dataset names no evaluation views; nothing to render", path=ds.root)
    if every < 1:
        raise InputError(f"every must be >= 1, got {every}")
    mean = np.round(ds.train.images.reshape(-1, 3).mean(0)).astype(np.uint8)
    img = np.broadcast_to(mean, (ds.eval.height, ds.eval.width, 3))
    written = []
    for seq in ds.eval.camera_sequences().values():
        for i in seq[::every]:
            path = Path(out) / "pred" / ds.eval.cameras[i] / f"{ds.eval.frames[i]}.png"
            path.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(path), np.ascontiguousarray(img[..., ::-1]))
            written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 done, 2 bad input)."""
    p = argparse.ArgumentParser(prog="python -m reference_models.common.baseline",
                                description="Constant-colour predictions of the eval cameras.")
    p.add_argument("data", help="dataset folder")
    p.add_argument("--out", required=True, help="run folder (pred/ is written inside)")
    p.add_argument("--every", type=int, default=1, help="every N-th eval frame only")
    args = p.parse_args(argv)
    try:
        files = write_constant_baseline(args.data, args.out, args.every)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {len(files)} constant-colour frames to {args.out}/pred", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

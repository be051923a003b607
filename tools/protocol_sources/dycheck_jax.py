"""DyCheck's own compute_psnr / compute_ssim (jax, float32) on arrays saved by compare_dycheck.py.

Run with an interpreter that has jax (not dynaeval's: jax wants its own numpy), pointing at a
checkout of KAIR-BAIR/dycheck:

    python tools/protocol_sources/dycheck_jax.py DYCHECK_REPO CASES.npz OUT.json

Only ``dycheck/core/metrics/image.py`` and ``dycheck/nn/functional/common.py`` are loaded (with
the package names they import stubbed), so gin, torch and DyCheck's other dependencies are not
needed. LPIPS is left out (it needs torch; dynaeval's LPIPS map is the lpips package's own).
"""

import json
import sys
import types
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", False)
import numpy as np  # noqa: E402


def _load(repo: Path):
    mods = {n: types.ModuleType(n) for n in (
        "dycheck", "dycheck.nn", "dycheck.nn.functional", "dycheck.nn.functional.common",
        "dycheck.utils", "dycheck.utils.types")}
    sys.modules.update(mods)
    mods["dycheck.utils.types"].Array = object
    mods["dycheck.utils"].types = mods["dycheck.utils.types"]
    mods["dycheck.nn"].functional = mods["dycheck.nn.functional"]
    common = mods["dycheck.nn.functional.common"]
    mods["dycheck.nn.functional"].common = common
    exec(compile((repo / "dycheck/nn/functional/common.py").read_text(), "common.py", "exec"),
         common.__dict__)
    image = types.ModuleType("dycheck_image")
    exec(compile((repo / "dycheck/core/metrics/image.py").read_text(), "image.py", "exec"),
         image.__dict__)
    return image


def main() -> None:
    repo, cases, out = Path(sys.argv[1]), np.load(sys.argv[2]), Path(sys.argv[3])
    image = _load(repo)
    names = sorted({k.split("/")[0] for k in cases.files})
    res = {}
    for n in names:
        gt, pred, mask = (cases[f"{n}/{k}"].astype(np.float32) for k in ("gt", "pred", "mask"))
        res[n] = {"psnr": float(image.compute_psnr(gt, pred)),
                  "ssim": float(image.compute_ssim(gt, pred)),
                  "mpsnr": float(image.compute_psnr(gt, pred, mask)),
                  "mssim": float(image.compute_ssim(gt, pred, mask))}
    out.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()

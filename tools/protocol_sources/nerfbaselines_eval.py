"""NeRFBaselines' own ``evaluation.evaluate`` on a render folder, per-image PSNR/SSIM as JSON.

Run with an interpreter that has ``nerfbaselines==1.2.12`` (its own venv: it pulls numpy 1.26 and
opencv-python):

    python tools/protocol_sources/nerfbaselines_eval.py RENDER_FOLDER OUT.json

RENDER_FOLDER holds ``info.json``, ``color/``, ``gt-color/`` and optionally ``mask/``. LPIPS is
replaced by 0 (it needs torch and downloaded weights; dynaeval's LPIPS equals the lpips package's).
"""

import base64
import json
import sys
import tempfile
from pathlib import Path

import nerfbaselines.metrics as nb_metrics
import numpy as np

nb_metrics.lpips = lambda a, b: np.zeros(a.shape[:-3], np.float32)
from nerfbaselines.evaluation import evaluate  # noqa: E402


def main() -> None:
    folder, out = sys.argv[1], Path(sys.argv[2])
    with tempfile.TemporaryDirectory() as tmp:
        evaluate(folder, str(Path(tmp) / "results.json"))
        doc = json.loads((Path(tmp) / "results.json").read_text())
    raw = {k: np.frombuffer(base64.b64decode(v), np.float32).tolist()
           for k, v in doc["metrics_raw"].items()}
    per_image = [dict(zip(raw, vals, strict=True)) for vals in zip(*raw.values(), strict=True)]
    out.write_text(json.dumps({"metrics": doc["metrics"], "per_image": per_image}, indent=1))


if __name__ == "__main__":
    main()

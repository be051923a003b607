"""``import dynaeval.metrics`` and PSNR/SSIM stay light: torch is imported only by LPIPS."""

from __future__ import annotations

import subprocess
import sys

CODE = """
import sys
import numpy as np
import dynaeval.metrics as M
a = np.random.default_rng(0).random((16, 16, 3))
M.psnr(a, a * 0.5); M.ssim(a, a * 0.5); M.masked_psnr(a, a, a[..., 0] > 0.5)
M.focused_ssim(a, a * 0.5, [[0, 0, 12, 12]]); M.quantize(a, 'round'); M.METRICS['psnr']
heavy = sorted(m for m in ('torch', 'torchvision', 'lpips', 'onnxruntime', 'matplotlib') if m in sys.modules)
print(','.join(heavy) or 'none')
"""


def test_metrics_import_and_psnr_ssim_do_not_import_torch():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "none", out.stdout + out.stderr


def test_the_check_can_fail():
    code = CODE.replace("M.METRICS['psnr']", "M.load_lpips")  # attribute access only: still light
    code = code.replace("heavy =", "import torch\nheavy =")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "torch" in out.stdout

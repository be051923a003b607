"""Importing the scene generator stays light: no torch, matplotlib, cv2 or tqdm until needed."""

import subprocess
import sys


def test_import_does_not_pull_heavy_modules():
    code = ("import sys, reference_models.scenes; "
            "print(sorted(m for m in ('torch', 'matplotlib', 'cv2', 'tqdm', 'onnxruntime') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"

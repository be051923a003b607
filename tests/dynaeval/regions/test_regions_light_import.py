"""Importing the regions package loads no heavy dependency (they load inside the functions)."""

from __future__ import annotations

import subprocess
import sys


def test_import_regions_stays_light():
    code = (
        "import sys, dynaeval.regions; "
        "print(','.join(m for m in ('onnxruntime', 'torch', 'cv2', 'scipy', 'onnx') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""

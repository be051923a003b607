"""Every hop does work (issue 41): one number of the bundled sample crosses few files and few
functions that only pass it on, as ``tools/value_path.py`` measures it (docs/architecture.md,
"The third step of issue 41, measured").

Before: ``focused_ssim`` crossed 14 files with 8 pass-through functions (the one-worker
executor, scoring's ``work`` closure, ``evaluate._score_one_camera``, the region closure of
``metrics/_common``, ``FrameRef.read``, ...) and ``warp_error`` 13 files.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

BOUNDS = {
    # key: (most files, most pass-through functions) from the input file to the JSON key
    "focused_ssim": (10, 3),  # the bound; the CLI's own run() counts among the 3
    "warp_error": (12, 3),  # a temporal number
}


def _value_path():
    spec = importlib.util.spec_from_file_location("value_path", ROOT / "tools" / "value_path.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("key", sorted(BOUNDS))
def test_a_number_crosses_few_files_and_few_hops_that_only_pass_it_on(key):
    with contextlib.redirect_stdout(io.StringIO()) as printed, \
            contextlib.redirect_stderr(io.StringIO()):
        report = _value_path().main(ROOT, key)
    path = report["input -> JSON key"]
    files, passing = BOUNDS[key]
    assert path["files"] <= files, printed.getvalue()
    assert len(path["pass"]) <= passing, printed.getvalue()

"""Fake OpenCV installs for the start-up probe's tests (``dynaeval.core.runtime.check_opencv``)."""

from __future__ import annotations

import sys
import types

MIXED = {"opencv-python": "5.1.0.95", "opencv-contrib-python-headless": "5.1.0.95"}
"""What ``pip install ultralytics`` leaves beside dynaeval's own OpenCV."""


def shadowed_cv2():
    """The real ``cv2`` with contrib's functions gone, as a non-contrib build installed over the
    contrib one leaves it: ``cv2.optflow`` is the empty namespace of contrib's stub folder."""
    import cv2

    fake = types.ModuleType("cv2")
    fake.__dict__.update({k: v for k, v in vars(cv2).items() if k != "optflow"})
    fake.optflow = types.ModuleType("cv2.optflow")
    return fake


def install(monkeypatch, dists, cv2_module):
    """Make ``dynaeval.core.runtime`` see ``dists`` installed and ``import cv2`` give ``cv2_module``
    (None: the import fails)."""
    from dynaeval.core import runtime

    monkeypatch.setattr(runtime, "installed_opencv", lambda: dict(dists), raising=False)
    monkeypatch.setitem(sys.modules, "cv2", cv2_module)

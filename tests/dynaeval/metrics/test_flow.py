"""Optical flow (``dynaeval.metrics.flow``) on a broken OpenCV install (the flows themselves are
tested with the temporal metrics, tests/dynaeval/metrics/test_temporal.py)."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.metrics.flow import FlowConfig, optical_flow

from ..opencv_fakes import MIXED, install, shadowed_cv2


def test_tvl1_on_a_shadowed_cv2_is_an_input_error_with_the_repair(monkeypatch):
    # 'pip install ultralytics' puts opencv-python over the contrib build: cv2.optflow stays an
    # empty stub folder, and the flow was an AttributeError (exit 1, a traceback)
    install(monkeypatch, MIXED, shadowed_cv2())
    frame = np.zeros((32, 32), np.uint8)
    with pytest.raises(InputError, match=r"flow 'tvl1'.*installed: opencv-python 5\.1\.0\.95.*"
                                         r"repair: pip uninstall -y opencv-python"):
        optical_flow(frame, frame, FlowConfig(method="tvl1"))
    assert optical_flow(frame, frame, FlowConfig(method="dis")).shape == (32, 32, 2)  # DIS runs

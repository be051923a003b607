"""Fixtures shared by the toolkit's tests."""

from __future__ import annotations

import pytest

from dynaeval import metrics as M
from dynaeval.metrics import perceptual


@pytest.fixture
def random_lpips(monkeypatch):
    """LPIPS with the package's real linear layers on a seeded random backbone (no download):
    every path that builds the network (``score``, ``ImageMetrics``, tLP, the onnxruntime
    export, ``M.lpips`` called directly) goes through the two loaders patched here; and no
    backbone file is needed, so a run naming LPIPS (``--metrics lpips``) is not refused for it."""
    load, load_onnx, fn = perceptual.load_lpips, perceptual.load_lpips_onnx, perceptual.lpips

    def random(loader):
        return lambda net="alex", **kw: loader(net, **{**kw, "pretrained_backbone": False})

    monkeypatch.setattr(perceptual, "load_lpips", random(load))
    monkeypatch.setattr(perceptual, "load_lpips_onnx", random(load_onnx))
    monkeypatch.setattr(M, "load_lpips", perceptual.load_lpips)
    monkeypatch.setattr(M, "lpips", lambda p, g, **kw: fn(p, g, **{**kw, "pretrained_backbone": False}))
    monkeypatch.setattr(perceptual, "_weights_absent", lambda net: None)

"""The video-quality study: its stands injection, and its tiny variant end to end (CI); the full
study is marked slow."""

from __future__ import annotations

import numpy as np
import pytest

from reference_models.studies.temporal_sensitivity import synthetic_sequence
from reference_models.studies.video_quality import (
    FULL,
    TINY,
    inject_stands_flicker,
    run,
    stands_mask,
)

pytest.importorskip("pycvvdp")
pytest.importorskip("flip_evaluator")


@pytest.fixture(autouse=True)
def one_thread():
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    yield
    torch.set_num_threads(before)  # the study sets 1


def test_stands_flicker_changes_the_stands_only_and_alternates():
    gt = synthetic_sequence(h=54, w=96, n_frames=3, seed=0)
    stands = stands_mask(gt)
    assert stands[:15].all() and not stands[16:].any()  # rows above 0.28 h
    pred = inject_stands_flicker(gt, 0.05, stands)
    for t, (p, g) in enumerate(zip(pred, gt.frames, strict=True)):
        np.testing.assert_array_equal(p[~stands], g[~stands])
        ratio = np.median(p[stands] / np.maximum(g[stands], 1e-6))
        assert ratio == pytest.approx(1 + 0.05 * (-1) ** t, abs=1e-3)
    for p, g in zip(inject_stands_flicker(gt, 0.0, stands), gt.frames, strict=True):
        np.testing.assert_array_equal(p, g)


def _check(rows):
    by = {(label, a): r for label, a, r in rows}
    ident = by["none (identical)", 0.0]
    assert ident["jod"] == pytest.approx(10.0, abs=1e-6) and ident["flip"] == 0.0
    assert ident["focused_jod"] == pytest.approx(10.0, abs=1e-6)
    for label, _, r in rows[1:]:
        assert r["jod"] < 10.0 and r["focused_jod"] < 10.0, label
    sigma = next(a for label, a, _ in rows if label.startswith("(d) static"))
    s, v = by["(d) static noise, sigma", sigma], by["(d) varying noise, sigma", sigma]
    # equal per-frame error: PSNR/SSIM/FLIP cannot tell them apart, JOD and flicker can
    assert abs(s["psnr"] - v["psnr"]) < 0.01 and abs(s["ssim"] - v["ssim"]) < 0.005
    assert abs(s["flip"] - v["flip"]) < 0.005
    assert abs(s["jod"] - v["jod"]) > 0.05
    assert v["flicker"] > s["flicker"]


def test_tiny_study_runs_and_jod_separates_static_from_varying_noise():
    block, rows = run(TINY)
    assert "| artefact | strength | psnr |" in block and "Spearman" in block
    assert len(rows) == 6
    _check(rows)


@pytest.mark.slow
def test_full_study():
    block, rows = run(FULL)
    assert "s per 1920x1080 frame" in block
    _check(rows)

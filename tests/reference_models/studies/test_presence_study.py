"""The presence study's degradations and threshold rule (the study itself takes minutes: not run)."""

from __future__ import annotations

import numpy as np
import pytest

from reference_models.studies.presence import (
    _widest_run,
    choose_thresholds,
    ghost,
    good_method,
    render_frames,
    shift,
)


def test_ghost_blends_linearly(rng):
    shown, erased = rng.random((4, 5, 3)), rng.random((4, 5, 3))
    np.testing.assert_allclose(ghost(shown, erased, 0.3), 0.3 * shown + 0.7 * erased, atol=1e-6)
    np.testing.assert_allclose(ghost(shown, erased, 1.0), shown, atol=1e-6)


def test_shift_moves_right_and_repeats_the_first_column(rng):
    img = rng.random((3, 6, 3)).astype(np.float32)
    out = shift(img, 1)
    np.testing.assert_array_equal(out[:, 1:], img[:, :-1])
    np.testing.assert_array_equal(out[:, 0], img[:, 0])


def test_good_method_is_deterministic_8_bit(rng):
    img = rng.random((8, 8, 3)).astype(np.float32)
    a, b = good_method(img, 3), good_method(img, 3)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a * 255, np.round(a * 255), atol=1e-4)
    assert not np.array_equal(a, good_method(img, 4))


def test_widest_run():
    np.testing.assert_array_equal(_widest_run(np.array([1, 1, 0, 1, 1, 1, 0], bool)), [3, 4, 5])
    np.testing.assert_array_equal(_widest_run(np.array([1, 1, 0, 1, 1], bool)), [0, 1])


def _rows(cls, kind, nccs, psnrs):
    return [{"class": cls, "kind": kind, "ncc": n, "psnr": p, "visibility": None}
            for n, p in zip(nccs, psnrs, strict=True)]


def test_choose_thresholds_puts_the_boundary_between_separable_sets():
    rows = (_rows("ball", "blur1", [0.8, 0.9, 0.85], [20.0, 22.0, 21.0])
            + _rows("ball", "erased", [0.2, 0.4, 0.3], [12.0, 13.0, 12.5]))
    th = choose_thresholds(rows, "ball")
    assert th["missed"] == 0.0 and th["false"] == 0.0
    assert 0.4 < th["ncc_min"] <= 0.8  # the middle of the separating ncc run ...
    assert th["ncc_min"] == pytest.approx(0.6, abs=0.01)
    assert th["psnr_min"] == 12.5  # ... then the middle of the psnr run (5 .. 20 dB) at that ncc
    with pytest.raises(ValueError, match="no calibration objects"):
        choose_thresholds(rows, "person")


def test_visibility_below_the_minimum_is_flagged_whatever_the_thresholds():
    rows = (_rows("ball", "blur1", [0.9, 0.9], [25.0, 25.0])
            + _rows("ball", "erased", [0.9, 0.9], [25.0, 25.0]))
    for r in rows:
        r["visibility"] = 1.0 if r["kind"] == "blur1" else 0.1
    th = choose_thresholds(rows, "ball")
    assert th["missed"] == 0.0 and th["false"] == 0.0


def test_render_frames_hides_the_ball():
    (frame,) = render_frames("single-player-closeup", "eval00", 0, [3], hide=("ball",), size="tiny")
    assert any(b["class"] == "ball" for b in frame.boxes)
    x0, y0, x1, y1 = next(b["box"] for b in frame.boxes if b["class"] == "ball")
    assert not np.allclose(frame.hidden["ball"][y0:y1, x0:x1], frame.gt[y0:y1, x0:x1])


def test_model_runs_join_the_shown_set_only_when_named(rng):
    """Model rows count as shown only under ``present_kinds``: a run whose players sit below the
    degradations' psnr pulls psnr_min down when it is a positive, and changes nothing as context."""
    rows = (_rows("person", "blur1", [0.9, 0.9], [26.0, 27.0])
            + _rows("person", "erased", [0.9, 0.9], [15.0, 16.0])  # only psnr separates
            + _rows("person", "model:a", [0.9, 0.9], [19.0, 20.0]))
    alone = choose_thresholds(rows, "person")
    with_model = choose_thresholds(rows, "person", present_kinds=("blur1", "model:a"))
    assert alone["n_present"] == 2 and with_model["n_present"] == 4
    assert with_model["missed"] == 0.0 and with_model["false"] == 0.0
    assert 16.0 < with_model["psnr_min"] <= 19.0 < alone["psnr_min"]


def test_model_rows_read_the_renders_and_the_boxes_file(tmp_path, rng):
    import json

    import cv2

    from reference_models.studies.presence import model_rows

    gt = (rng.random((40, 60, 3)) * 255).astype(np.uint8)
    (tmp_path / "scene" / "images" / "eval00").mkdir(parents=True)
    cv2.imwrite(str(tmp_path / "scene" / "images" / "eval00" / "0000.png"), gt)
    (tmp_path / "scene" / "boxes.json").write_text(json.dumps(
        {"eval00/0000": [{"box": [10, 5, 30, 35], "class": "person", "id": 1, "visible": 1.0}]}))
    (tmp_path / "run" / "eval00").mkdir(parents=True)
    cv2.imwrite(str(tmp_path / "run" / "eval00" / "0000.png"), gt)
    rows = model_rows(tmp_path / "scene", {"same": tmp_path / "run"})
    assert [(r["kind"], r["class"], r["frame"]) for r in rows] == [("model:same", "person", 0)]
    assert rows[0]["psnr"] > 40 and rows[0]["ncc"] == pytest.approx(1.0, abs=1e-3)

"""The 3DGS family's render folders (MODEL/<split>/ours_<N>/renders + gt), read as they are."""

from __future__ import annotations

import numpy as np
import pytest

import dynaeval
from dynaeval.errors import InputError
from dynaeval.io.layouts import detect_layout
from dynaeval.regions.focus import FocusConfig

NO_FOCUS = FocusConfig(source="none", masked=False)


def _iteration(model, split, n, frames=3, gt=True):
    rng = np.random.default_rng(n)
    base = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)
    seq = [np.roll(base, i, axis=1) for i in range(frames)]
    ours = model / split / f"ours_{n}"
    (ours / "renders").mkdir(parents=True)
    _write(ours / "renders", [np.clip(f.astype(int) + 4, 0, 255).astype(np.uint8) for f in seq])
    if gt:
        (ours / "gt").mkdir()
        _write(ours / "gt", seq)
    return ours


def _write(folder, frames):
    import cv2

    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:05d}.png"), f)


@pytest.fixture
def model(tmp_path):
    """A gaussian-splatting MODEL: test and train rendered at 7000 and 30000 iterations, and an
    iteration folder without ground truth (Deformable-3DGS' interpolate_* style) to skip."""
    m = tmp_path / "garden"
    for n in (7000, 30000):
        _iteration(m, "test", n)
        _iteration(m, "train", n)
    _iteration(m, "test", 99999, gt=False)
    (m / "test" / "interpolate_30000" / "renders").mkdir(parents=True)
    return m


def test_model_folder_scores_latest_test_iteration(model):
    lay = detect_layout(model)
    assert (lay.name, lay.pred, lay.gt) == ("3dgs", model / "test" / "ours_30000" / "renders",
                                            model / "test" / "ours_30000" / "gt")
    assert lay.details == {"family": "gaussian-splatting", "split": "test", "iteration": 30000,
                           "model": str(model), "sequence": False}
    assert lay.sequence is False
    notes = " ".join(lay.notes)
    assert "also rendered: ours_7000" in notes and "ours_99999" not in notes
    assert "also rendered: train" in notes


def test_iteration_and_split_select(model):
    lay = detect_layout(model, iteration=7000, split="train")
    assert lay.root == model / "train" / "ours_7000"
    assert detect_layout(model / "test").root == model / "test" / "ours_30000"
    assert detect_layout(model / "test", iteration=7000).root == model / "test" / "ours_7000"
    one = detect_layout(model / "test" / "ours_7000")
    assert (one.root, one.details["iteration"], one.notes) == (model / "test" / "ours_7000", 7000, ())


def test_selection_errors(model, tmp_path):
    with pytest.raises(InputError, match=r"no iteration 5 rendered in this split .*7000, 30000"):
        detect_layout(model, iteration=5)
    with pytest.raises(InputError, match="has no scoreable 'val' split .*test, train"):
        detect_layout(model, split="val")
    with pytest.raises(InputError, match="--split train asked but this folder is of split 'test'"):
        detect_layout(model / "test", split="train")
    with pytest.raises(InputError, match="--iteration 7000 asked but this is the folder of one"):
        detect_layout(model / "test" / "ours_30000", iteration=7000)
    (tmp_path / "p").mkdir()
    with pytest.raises(InputError, match="--iteration 3 only selects within a 3DGS-family"):
        detect_layout(tmp_path / "p", tmp_path / "p2", iteration=3)


def test_dynamic_families_are_sequences(tmp_path):
    four = tmp_path / "4dgs"
    ours = _iteration(four, "test", 14000)
    (ours / "video_rgb.mp4").write_bytes(b"")
    lay = detect_layout(four)
    assert (lay.details["family"], lay.sequence) == ("4DGaussians", True)
    assert any("--no-temporal" in n for n in lay.notes)
    deform = tmp_path / "deform3dgs"
    _iteration(deform, "test", 40000)
    (deform / "deform").mkdir()
    assert detect_layout(deform / "test" / "ours_40000").details["family"] == "Deformable-3DGS"


def test_score_reads_model_from_python(model):
    with pytest.warns(dynaeval.DynaevalWarning, match="also rendered: ours_7000"):
        res = dynaeval.score(model, metrics=("psnr",), temporal=False, focus=NO_FOCUS,
                             progress=False, presence=False, iteration=None)
    assert res["inputs"]["layout"]["iteration"] == 30000
    assert res["summary"]["n_frames"] == 3 and res["method"] == "garden"
    older = dynaeval.score(model / "test" / "ours_7000", metrics=("psnr",), temporal=False,
                           focus=NO_FOCUS, progress=False, presence=False)
    assert older["inputs"]["layout"]["iteration"] == 7000

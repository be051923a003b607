"""The grid's ceiling: the ground truth box-filtered to a grid's cells."""

import numpy as np
import pytest

from reference_models.studies.grid_ceiling import box_filtered, grid_ceiling
from tests.reference_models.common.tiny import render_tiny


@pytest.fixture(scope="module")
def tiny_data(tmp_path_factory):
    return render_tiny(tmp_path_factory.mktemp("ceiling") / "tiny")

BOX = np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])


def test_one_cell_paints_every_kept_pixel_the_mean_and_leaves_the_rest():
    rng = np.random.default_rng(0)
    img = rng.uniform(0, 255, (4, 5, 3))
    pts = rng.uniform(-0.9, 0.9, (4, 5, 3))
    keep = rng.uniform(size=(4, 5)) < 0.6
    out = box_filtered(img, pts, keep, BOX, (1, 1, 1))
    assert np.allclose(out[keep], img[keep].mean(0)) and np.array_equal(out[~keep], img[~keep])


def test_pixels_in_cells_of_their_own_are_kept_exactly():
    img = np.arange(2 * 3 * 3, dtype=np.float64).reshape(2, 3, 3)
    # six points in six different cells of an 8 x 8 x 8 grid over [-1, 1] (inside the box: p / 2)
    pts = np.array([[[-1.8, -1.8, 0.2], [-0.2, -1.8, 0.2], [1.8, -1.8, 0.2]],
                    [[-1.8, 1.8, 0.2], [-0.2, 1.8, 0.2], [1.8, 1.8, 0.2]]]) / 2.0
    assert np.array_equal(box_filtered(img, pts, np.ones((2, 3), bool), BOX, (8, 8, 8)), img)


def test_finer_grids_raise_the_ceiling(tiny_data):
    coarse, fine = grid_ceiling(tiny_data, (32, 32, 32)), grid_ceiling(tiny_data, (256, 256, 256))
    assert fine["whole"] > coarse["whole"] and fine["pitch"] > coarse["pitch"]

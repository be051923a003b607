"""The anisotropic world-plane rule: cells per axis from the cameras' pixel footprint."""

import numpy as np
import pytest
import torch

from dynaeval.errors import InputError
from reference_models.common.data import Views
from reference_models.common.footprint import (
    covered_asks,
    exit_distance,
    footprint_resolution,
    pixel_samples,
    pixel_steps,
)


def _views(width: int, height: int, eye=(0.0, 0.0, 1.0), fx: float = 100.0) -> Views:
    """One camera at ``eye`` looking along +x (OpenGL: -Z forward, +Y up)."""
    c2w = np.eye(4, dtype=np.float32)
    c2w[:3, :3] = np.array([[0, 0, -1], [-1, 0, 0], [0, 1, 0]], np.float32)  # cam -Z -> world +x
    c2w[:3, 3] = eye
    intr = np.array([[fx * width / 100, fx * width / 100, width / 2, height / 2]], np.float32)
    return Views(np.zeros((1, height, width, 3), np.uint8), c2w[None], intr,
                 np.zeros(1, np.float32), ["cam"], ["0000"])


def _rig(*cameras: tuple[tuple[float, float, float], float], width: int = 64,
         height: int = 32) -> Views:
    """Cameras at ``eye`` looking along +x turned by ``yaw`` degrees about +z, in that order."""
    views = [_views(width, height, eye) for eye, _ in cameras]
    for v, (_, yaw) in zip(views, cameras, strict=True):
        a = np.radians(yaw)
        turn = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]],
                        np.float32)
        v.c2w[0, :3, :3] = turn @ v.c2w[0, :3, :3]
    return Views(np.concatenate([v.images for v in views]), np.concatenate([v.c2w for v in views]),
                 np.concatenate([v.intrinsics for v in views]), np.zeros(len(views), np.float32),
                 [f"cam{i}" for i in range(len(views))], ["0000"] * len(views))


BOX = np.array([[-2.0, -2.0, 0.0], [2.0, 2.0, 2.0]], np.float32)
WALL = np.array([[-100.0, -100.0, -100.0], [30.0, 100.0, 100.0]])
"""An extent whose face x = 30 is all the camera sees (53 degrees of view along +x)."""


def test_exit_distance_matches_a_brute_force_march():
    rng = np.random.default_rng(0)
    d = torch.as_tensor(rng.normal(size=(200, 3)))
    d = d / d.norm(dim=-1, keepdim=True)
    o = torch.tensor([1.0, -2.0, 3.0], dtype=torch.float64)
    ext = torch.tensor([[-10.0, -5.0, 0.0], [8.0, 7.0, 6.0]], dtype=torch.float64)
    t = exit_distance(o, d, ext)
    ts = torch.linspace(0, 40, 400_001, dtype=torch.float64)
    for i in range(0, 200, 17):
        p = o + ts[:, None] * d[i]
        inside = ((p >= ext[0]) & (p <= ext[1])).all(-1)
        assert abs(float(ts[inside].max()) - float(t[i])) < 2e-4


def test_a_wall_looked_at_along_x_says_nothing_of_x_and_asks_y_and_z():
    steps = pixel_steps(_views(64, 32), BOX, WALL, every=4)
    # the rays end on the wall x = 30: one pixel moves y and z, barely x
    assert np.median(steps[:, 0]) < 0.1 * np.median(steps[:, 1])
    cells = footprint_resolution(_views(64, 32), BOX, WALL, multiple=2, max_cells=100_000, views_needed=1)
    assert cells[0] == 2 and cells[1] > 50 and cells[2] > 50


def test_a_grazing_floor_asks_cells_along_the_view():
    floor = np.array([[-100.0, -100.0, 0.0], [30.0, 100.0, 100.0]])
    c2w_tilt = _views(64, 32)
    # tilt the camera 20 degrees down: most pixels meet the floor z = 0 far ahead
    a = np.radians(-20.0)
    tilt = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]], np.float32)
    c2w_tilt.c2w[0, :3, :3] = c2w_tilt.c2w[0, :3, :3] @ tilt
    steps = pixel_steps(c2w_tilt, BOX, floor, every=4)
    assert np.median(steps[:, 0]) > np.median(steps[:, 2])  # on the floor a row moves along x
    assert footprint_resolution(c2w_tilt, BOX, floor, multiple=2, max_cells=100_000, views_needed=1)[0] > 50


def test_twice_the_pixels_ask_twice_the_cells():
    a = footprint_resolution(_views(64, 32), BOX, WALL, multiple=2, max_cells=100_000, every=2, views_needed=1)
    b = footprint_resolution(_views(128, 64), BOX, WALL, multiple=2, max_cells=100_000, every=4, views_needed=1)
    assert b[1] == pytest.approx(2 * a[1], rel=0.08) and b[2] == pytest.approx(2 * a[2], rel=0.08)


def test_a_nearer_wall_asks_more_cells_and_far_walls_converge():
    def cells(x: float) -> tuple[int, int, int]:
        wall = WALL.copy()
        wall[1, 0] = x
        return footprint_resolution(_views(64, 32), BOX, wall, multiple=2, max_cells=100_000, views_needed=1)

    # inside the box a cell is a fixed length, so a near wall's small pixels need many; beyond
    # it the contraction is nearly angular, so a frontal wall at 30 m or 90 m asks about the same
    assert cells(1.0)[1] > cells(1.8)[1] > cells(5.0)[1] > cells(30.0)[1]
    assert cells(90.0)[1:] == pytest.approx(cells(30.0)[1:], rel=0.05)


def test_cells_are_rounded_up_to_the_multiple_and_capped():
    cells = footprint_resolution(_views(64, 32), BOX, WALL, multiple=64, max_cells=128, views_needed=1)
    assert all(c % 64 == 0 and 64 <= c <= 128 for c in cells)
    free = footprint_resolution(_views(64, 32), BOX, WALL, multiple=1, max_cells=100_000, views_needed=1)
    assert footprint_resolution(_views(64, 32), BOX, WALL, multiple=64, max_cells=100_000,
                                views_needed=1)[1] == 64 * int(np.ceil(free[1] / 64))


def test_the_closeup_rig_asks_fewer_cells_along_z_than_along_x_and_y(tiny_data):
    from reference_models.common.data import load_dataset

    data = load_dataset(tiny_data)
    assert data.extent is not None  # the generator writes world.extent
    x, y, z = footprint_resolution(data.train, data.box, data.extent, multiple=1,
                                   max_cells=100_000, every=1, views_needed=1)
    assert z < 0.8 * min(x, y)


def test_walls_each_seen_by_one_camera_ask_nothing_beyond_the_coarse_grid():
    # one camera looks at the wall x = 30, the other turned round at the wall x = -100
    rig = _rig(((0.0, 0.0, 1.0), 0.0), ((0.0, 0.0, 1.0), 180.0))
    alone = footprint_resolution(rig, BOX, WALL, multiple=2, max_cells=100_000, views_needed=1)
    assert alone[1] > 50 and alone[2] > 50
    assert footprint_resolution(rig, BOX, WALL, multiple=2, max_cells=100_000,
                                views_needed=2) == (2, 2, 2)


def test_a_wall_seen_by_enough_cameras_asks_as_its_pixels_do():
    rig = _rig(((0.0, -0.5, 1.0), 0.0), ((0.0, 0.0, 1.0), 0.0), ((0.0, 0.5, 1.0), 0.0))
    own = footprint_resolution(rig, BOX, WALL, quantile=0.5, multiple=1, max_cells=100_000,
                               views_needed=1)
    covered = footprint_resolution(rig, BOX, WALL, quantile=0.5, multiple=1, max_cells=100_000,
                                   views_needed=3)
    assert covered[1:] == pytest.approx(own[1:], rel=0.05)
    # a fourth view is more than the rig has: nothing is covered
    assert footprint_resolution(rig, BOX, WALL, multiple=1, max_cells=100_000,
                                views_needed=4) == (1, 1, 1)


def test_more_cameras_never_lower_a_points_ask():
    few = _rig(((0.0, 0.0, 1.0), 0.0), ((0.0, 3.0, 1.5), 10.0))
    many = _rig(((0.0, 0.0, 1.0), 0.0), ((0.0, 3.0, 1.5), 10.0), ((-20.0, -4.0, 3.0), -15.0),
                ((5.0, 1.0, 0.5), 5.0), ((0.0, 0.0, 1.0), 180.0))
    samples = pixel_samples(few, BOX, WALL)  # the same pixels, judged by the two rigs
    for k in (1, 2, 3):
        a, b = covered_asks(few, samples, BOX, k), covered_asks(many, samples, BOX, k)
        assert np.array_equal(np.isnan(a), np.isnan(b))
        assert np.all(np.nan_to_num(b) >= np.nan_to_num(a) * (1 - 1e-9))
    assert np.nanmax(covered_asks(many, samples, BOX, 3)) > 0  # the extra views cover something
    assert np.nanmax(covered_asks(few, samples, BOX, 3)) == 0


def test_without_an_extent_or_with_a_bad_quantile_it_says_why():
    with pytest.raises(InputError, match="needs the scene's extent"):
        footprint_resolution(_views(64, 32), BOX, None)
    with pytest.raises(InputError, match="quantile must be in"):
        footprint_resolution(_views(64, 32), BOX, WALL, quantile=0.0)
    with pytest.raises(InputError, match="views_needed must be at least 1"):
        footprint_resolution(_views(64, 32), BOX, WALL, views_needed=0)


def test_planes_take_one_resolution_per_axis():
    from reference_models.common.encodings import PlaneEncoding

    enc = PlaneEncoding((8, 16, 4), 5, (1, 2), 3, max_resolution=(16, 32, 6))
    shapes = {(a, b, tuple(p.shape[-2:])) for (a, b), p in zip(enc.plane_pairs, enc.views(),
                                                                strict=True)}
    # rows run along b, columns along a; scale 2 doubles x and y, z is capped at 6
    assert (0, 1, (16, 8)) in shapes and (0, 1, (32, 16)) in shapes
    assert (0, 2, (4, 8)) in shapes and (0, 2, (6, 16)) in shapes
    assert (2, 3, (5, 4)) in shapes and (2, 3, (5, 6)) in shapes
    out = enc(torch.rand(10, 4) * 2 - 1)
    assert out.shape == (10, 6)
    with pytest.raises(ValueError, match="one resolution or three"):
        PlaneEncoding((8, 16), 5, (1,), 3)


def test_a_footprint_preset_records_its_cells_and_builds_planes_of_that_size(tiny_data, tmp_path):
    import json

    from reference_models.common.train import load_run, train
    from reference_models.kplanes import SPEC

    train(SPEC, tiny_data, tmp_path / "run", size="tiny-fp", iters=2, progress=False)
    cfg = json.loads((tmp_path / "run" / "config.json").read_text())
    cells = cfg["scene"]["world_resolution"]
    # the rule's inputs are kept beside its cells
    assert cfg["model_config"]["footprint_views"] >= 1
    assert cfg["model_config"]["footprint_quantile"] == 0.75
    _, model, _ = load_run(tmp_path / "run", SPEC)
    top = {tuple(p.shape[-2:]) for p, (a, b) in zip(model.encoding.views(),
                                                     model.encoding.plane_pairs, strict=True)
           if (a, b) == (0, 1)}
    assert (cells[1], cells[0]) in top  # the xy plane of the finest scale: rows y, columns x

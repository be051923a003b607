"""Presets: camera counts and names, scene contents, option checks, ball sizes on screen."""

import numpy as np
import pytest

from dynaeval.errors import InputError
from reference_models.scenes import PRESETS, build_scene
from reference_models.scenes.actors import BALL_RADIUS, Ball


@pytest.mark.parametrize(("preset", "n_train", "n_eval"), [
    ("single-player-closeup", 30, 1), ("single-player-broadcast", 20, 1), ("players-stadium", 30, 6)])
def test_camera_counts_and_names(preset, n_train, n_eval):
    scene = build_scene(preset, size="small")
    assert scene.train_cameras == [f"cam{i:02d}" for i in range(n_train)]
    assert scene.eval_cameras == [f"eval{i:02d}" for i in range(n_eval)]
    tiny = build_scene(preset, size="tiny")
    assert (len(tiny.train_cameras), len(tiny.eval_cameras)) == (4, 1)
    assert (tiny.width, tiny.height, tiny.n_frames) == (64, 36, 8)


@pytest.mark.parametrize("seed", range(6))
def test_stadium_has_10_to_22_players_and_1_or_2_balls(seed):
    classes = build_scene("players-stadium", seed=seed, size="tiny").classes
    values = list(classes.values())
    assert 10 <= values.count("person") <= 22
    assert 1 <= values.count("ball") <= 2
    assert sorted(classes) == list(range(1, len(classes) + 1))


def _ball_diameters(scene, cams):
    """Projected ball diameter (px) and whether the centre is in the image, per camera and frame."""
    out = []
    balls = [a for a in scene.actors if isinstance(a, Ball)]
    for f in range(scene.n_frames):
        for ball in balls:
            centre = ball.body(scene.time_of(f)).a
            for name in cams:
                cam = scene.camera(name)
                uv, depth = cam.project(centre)
                inside = depth[0] > 0 and 0 <= uv[0, 0] < cam.width and 0 <= uv[0, 1] < cam.height
                out.append((2 * BALL_RADIUS * cam.fx / depth[0], inside))
    return np.array(out)


def test_ball_is_a_few_pixels_in_stadium_views_and_large_in_closeups():
    wide = build_scene("players-stadium", size="hd")
    d = _ball_diameters(wide, wide.train_cameras)
    on_screen = d[d[:, 1] > 0, 0]
    assert 1.5 < np.median(on_screen) < 8 and on_screen.max() < 15
    small = build_scene("players-stadium", size="small")
    assert _ball_diameters(small, small.train_cameras)[:, 0].max() < 3
    close = build_scene("single-player-closeup", size="small")
    d = _ball_diameters(close, [c.name for c in close.cameras])
    assert d[:, 1].mean() > 0.9 and np.median(d[:, 0]) > 6


def test_stadium_shot_is_20_to_30_metres_per_second():
    scene = build_scene("players-stadium", size="small")
    ball = next(a for a in scene.actors if a.id == scene.action["shot_ball_id"])
    assert isinstance(ball, Ball) and 20 <= scene.action["shot_speed_m_s"] <= 30
    t0 = ball.segments[1].t0
    v = (ball.body(t0 + 0.02).a - ball.body(t0 + 0.01).a)[0] / 0.01
    assert 20 <= np.linalg.norm(v) <= 30


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"preset": "beach"}, "unknown preset 'beach'; expected one of single-player-closeup"),
    ({"size": "huge"}, "unknown size 'huge'; expected one of tiny, small, hd"),
    ({"spp": 3}, "spp must be a square number"),
    ({"width": 4}, "image size must be between 8x8"),
    ({"frames": -2}, "frames must be a positive integer"),
    ({"fps": -1.0}, "fps must be a positive number"),
    ({"seed": -1}, "seed must be a non-negative integer"),
])
def test_bad_options_raise_input_error(kwargs, match):
    args = {"preset": PRESETS[0], **kwargs}
    with pytest.raises(InputError, match=match):
        build_scene(**args)


def test_unknown_camera_raises():
    with pytest.raises(InputError, match="no camera 'camXX'"):
        build_scene(PRESETS[0], size="tiny").camera("camXX")

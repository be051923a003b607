"""Static world: lit sides face the pitch, lines where the laws put them, sky above."""

import numpy as np

from reference_models.scenes.world import (
    GROUND,
    SKY,
    STAND,
    _quads,
    intersect_static,
    line_distance,
    stand_points,
    sun_direction,
)


def test_stands_and_boards_face_the_pitch():
    for _, p0, e1, e2 in _quads():
        n = np.cross(e1, e2)
        middle = p0 + 0.5 * e1 + 0.5 * e2
        assert n @ -middle > 0
        assert n[2] >= 0


def test_line_distance_on_known_markings():
    x = np.array([0.0, 9.15, 52.5, 36.0, 10.0, 41.5, 20.0])
    y = np.array([5.0, 0.0, 20.0, 10.0, 34.0, 0.0, 10.0])
    np.testing.assert_allclose(line_distance(x, y)[:6], 0.0, atol=1e-12)
    assert line_distance(x, y)[6] > 5


def test_materials_seen_from_a_stand_camera():
    eye = stand_points(0, 0.5, 0.5, 1.5)
    d = np.array([[0.0, -0.8, -0.3], [0.0, -0.3, 0.9], [0.0, 0.6, -0.8]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hit = intersect_static(eye, d, sun_direction(), 0)
    assert hit.material.tolist() == [GROUND, SKY, STAND]
    np.testing.assert_allclose(hit.point[0, 2], 0.0, atol=1e-9)
    assert np.isinf(hit.t[1])

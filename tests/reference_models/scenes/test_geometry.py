"""Ray-primitive intersections against closed forms and against each other."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_models.scenes.geometry import (
    hash01,
    intersect_capsule,
    intersect_capsules,
    intersect_parallelogram,
    intersect_sphere,
    rot_axis,
)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_sphere_hit_distance_is_closed_form():
    o = np.array([0.0, 0.0, 0.0])
    d = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    t = intersect_sphere(o, d, np.array([5.0, 0, 0]), 1.0)
    np.testing.assert_allclose(t, [4.0, np.inf])


def test_capsule_side_and_cap_hits():
    a, b = np.array([0.0, 0, 0]), np.array([0.0, 0, 2])
    o = np.array([[5.0, 0, 1], [0.0, 0, 10]])
    d = np.array([[-1.0, 0, 0], [0.0, 0, -1]])
    np.testing.assert_allclose(intersect_capsule(o, d, a, b, 0.5), [4.5, 7.5])


def test_capsule_points_lie_on_surface(rng):
    a, b, r = np.array([0.1, -0.2, 0.3]), np.array([0.5, 0.4, 1.2]), 0.2
    o = np.array([3.0, 2.0, 1.0])
    d = _unit(rng.normal(size=(4000, 3)) * 0.2 + (np.array([0.3, 0.1, 0.7]) - o))
    t = intersect_capsule(o, d, a, b, r)
    hit = np.isfinite(t)
    assert hit.sum() > 100
    x = o + t[hit, None] * d[hit]
    s = np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    dist = np.linalg.norm(x - (a + s[:, None] * (b - a)), axis=1)
    np.testing.assert_allclose(dist, r, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_vectorised_capsules_match_the_per_capsule_reference(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(5, 3))
    b = a + rng.normal(size=(5, 3)) * rng.integers(0, 2, size=(5, 1))  # some spheres (a == b)
    r = rng.uniform(0.05, 0.5, size=5)
    o = rng.normal(size=3) * 4
    d = _unit(rng.normal(size=(300, 3)))
    fast = intersect_capsules(o, d, a, b, r)
    ref = np.stack([intersect_capsule(o, d, a[i], b[i], r[i]) for i in range(5)], -1)
    np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=1e-12)


def test_parallelogram_inside_and_outside():
    p0, e1, e2 = np.zeros(3), np.array([2.0, 0, 0]), np.array([0.0, 3.0, 0])
    o = np.array([[1.0, 1.0, 5.0], [3.0, 1.0, 5.0]])
    t, u, v = intersect_parallelogram(o, np.array([0.0, 0, -1]), p0, e1, e2)
    np.testing.assert_allclose(t, [5.0, np.inf])
    np.testing.assert_allclose([u[0], v[0]], [0.5, 1 / 3])


def test_rot_axis_is_a_rotation():
    r = rot_axis(np.array([1.0, 2.0, 3.0]), 0.7)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r @ np.array([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0])


def test_hash_is_deterministic_uniform_and_salted():
    ix, iy = np.meshgrid(np.arange(-50, 50), np.arange(-50, 50))
    h = hash01(ix, iy, 3)
    np.testing.assert_array_equal(h, hash01(ix, iy, 3))
    assert h.min() >= 0 and h.max() < 1
    assert abs(h.mean() - 0.5) < 0.02
    assert np.mean(h == hash01(ix, iy, 4)) < 0.01

"""Pinhole conventions: rays and projection agree, OpenGL axes, conservative culling blocks."""

import numpy as np

from reference_models.scenes.camera import Camera, look_at


def _cam(w=40, h=30):
    return Camera.from_fov("cam00", w, h, 60.0, look_at((3.0, -4.0, 2.0), (0.0, 0.0, 1.0)))


def test_look_at_is_opengl_convention():
    c2w = look_at((0.0, -10.0, 0.0), (0.0, 0.0, 0.0))
    np.testing.assert_allclose(c2w[:3, 2], [0, -1, 0], atol=1e-12)  # looks down -Z
    np.testing.assert_allclose(c2w[:3, 1], [0, 0, 1], atol=1e-12)  # +Y is up
    np.testing.assert_allclose(c2w[:3, :3] @ c2w[:3, :3].T, np.eye(3), atol=1e-12)


def test_points_along_pixel_rays_project_to_pixel_centres():
    cam = _cam()
    dirs, zscale = cam.ray_grid(1)
    pts = cam.centre + 7.0 * dirs
    uv, depth = cam.project(pts)
    cols, rows = np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)
    np.testing.assert_allclose(uv[..., 0], cols, atol=1e-9)
    np.testing.assert_allclose(uv[..., 1], rows, atol=1e-9)
    np.testing.assert_allclose(depth, 7.0 * zscale, rtol=1e-12)


def test_subpixel_grid_centre_sample_for_odd_k():
    cam = _cam()
    d3, _ = cam.ray_grid(3)
    d1, _ = cam.ray_grid(1)
    np.testing.assert_allclose(d3[1::3, 1::3], d1, atol=1e-12)


def test_sphere_block_contains_every_sample_that_hits(rng):
    cam = _cam()
    dirs, _ = cam.ray_grid(2)
    for _ in range(20):
        centre = rng.normal(size=3) * 2 + [0, 0, 1]
        radius = rng.uniform(0.1, 1.5)
        oc = cam.centre - centre
        b = dirs @ oc
        hits = (b * b - (oc @ oc - radius * radius) >= 0) & (-b > 0)
        rect = cam.rect_of_sphere(centre, radius, 2)
        if rect is None:
            assert not hits.any()
            continue
        r0, r1, c0, c1 = rect
        outside = hits.copy()
        outside[r0:r1, c0:c1] = False
        assert not outside.any()


def test_sphere_behind_camera_is_culled():
    cam = _cam()
    behind = cam.centre + cam.c2w[:3, 2] * 5.0  # +Z is behind an OpenGL camera
    assert cam.rect_of_sphere(behind, 1.0, 1) is None

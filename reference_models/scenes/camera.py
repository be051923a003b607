"""Pinhole cameras in the nerfstudio / OpenGL convention.

World: metres, pitch in the ``z = 0`` plane, ``x`` along the length, ``y`` across, ``z`` up.
Camera-to-world ``c2w`` (4, 4) float64: columns are the camera's right (+X), up (+Y) and back (+Z)
axes and its centre; the camera looks down -Z. Pixel ``(col, row)`` covers ``[col, col + 1) x
[row, row + 1)`` in continuous image coordinates, so its centre is ``(col + 0.5, row + 0.5)`` and a
centred principal point is ``(W / 2, H / 2)`` (the nerfstudio convention).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

NEAR = 0.05
"""Nearest distance (m) at which a ray may hit a surface."""


def look_at(eye: object, target: object, up: object = (0.0, 0.0, 1.0)) -> np.ndarray:
    """Camera-to-world (4, 4) float64 of a camera at ``eye`` looking at ``target`` (world metres)."""
    eye = np.asarray(eye, dtype=np.float64)
    fwd = np.asarray(target, dtype=np.float64) - eye
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(up, dtype=np.float64))
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, fwd)
    c2w = np.eye(4)
    c2w[:3, 0], c2w[:3, 1], c2w[:3, 2], c2w[:3, 3] = right, cam_up, -fwd, eye
    return c2w


@dataclass(frozen=True, eq=False)
class Camera:
    """A static pinhole camera (no distortion)."""

    name: str
    """``cam00``.. for training cameras, ``eval00``.. for held-out evaluation cameras."""
    width: int
    """Image width in pixels."""
    height: int
    """Image height in pixels."""
    fx: float
    """Focal length along x in pixels."""
    fy: float
    """Focal length along y in pixels."""
    cx: float
    """Principal point x in pixels (continuous coordinates, pixel centres at +0.5)."""
    cy: float
    """Principal point y in pixels."""
    c2w: np.ndarray = field(repr=False)
    """(4, 4) float64 camera-to-world matrix, OpenGL convention (looks down -Z, +Y up)."""

    @classmethod
    def from_fov(cls, name: str, width: int, height: int, hfov_deg: float, c2w: np.ndarray) -> Camera:
        """Square pixels, centred principal point, horizontal field of view ``hfov_deg`` degrees."""
        f = 0.5 * width / np.tan(np.radians(hfov_deg) / 2)
        return cls(name, width, height, float(f), float(f), width / 2, height / 2, c2w)

    @property
    def centre(self) -> np.ndarray:
        """(3,) float64 camera centre in world metres."""
        return self.c2w[:3, 3]

    def ray_grid(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Rays through a ``k x k`` sub-pixel grid of every pixel.

        Returns ``dirs`` (H*k, W*k, 3) float64 unit world directions and ``zscale`` (H*k, W*k),
        the cosine to the optical axis, so that a hit at ray distance ``t`` has depth ``t * zscale``.
        Sample ``j`` of pixel ``col`` sits at ``u = col + (j + 0.5) / k`` (``k = 1``: the centre).
        """
        u = (np.arange(self.width * k) + 0.5) / k
        v = (np.arange(self.height * k) + 0.5) / k
        uu, vv = np.meshgrid(u, v)
        d_cam = np.stack([(uu - self.cx) / self.fx, -(vv - self.cy) / self.fy, -np.ones_like(uu)], -1)
        norm = np.linalg.norm(d_cam, axis=-1)
        dirs = (d_cam / norm[..., None]) @ self.c2w[:3, :3].T
        return dirs, 1.0 / norm

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) to camera coordinates (..., 3) (x right, y up, -z forward)."""
        return (np.asarray(points, dtype=np.float64) - self.centre) @ self.c2w[:3, :3]

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points (..., 3) metres: ``uv`` (..., 2) pixels and ``depth`` (...,) metres.

        ``depth`` is the distance along the optical axis (z-depth); points with ``depth <= 0`` are
        behind the camera and their ``uv`` is meaningless.
        """
        pc = self.to_camera(points)
        depth = -pc[..., 2]
        safe = np.where(np.abs(depth) > 1e-12, depth, 1e-12)
        u = self.fx * pc[..., 0] / safe + self.cx
        v = -self.fy * pc[..., 1] / safe + self.cy
        return np.stack([u, v], -1), depth

    def rect_of_points(self, points: np.ndarray, k: int) -> tuple[int, int, int, int] | None:
        """Conservative ``(row0, row1, col0, col1)`` block of a ``k``-sample ray grid (see
        ``ray_grid``) that holds the projection of the convex hull of ``points`` (N, 3).

        Returns the whole grid when a point is behind the camera, None when the block is empty.
        """
        uv, depth = self.project(points)
        rows, cols = self.height * k, self.width * k
        if np.any(depth <= NEAR):
            return 0, rows, 0, cols
        c0 = max(int(np.floor(uv[:, 0].min() * k - 0.5)) - 1, 0)
        c1 = min(int(np.ceil(uv[:, 0].max() * k)) + 1, cols)
        r0 = max(int(np.floor(uv[:, 1].min() * k - 0.5)) - 1, 0)
        r1 = min(int(np.ceil(uv[:, 1].max() * k)) + 1, rows)
        if c1 <= c0 or r1 <= r0:
            return None
        return r0, r1, c0, c1

    def sphere_outside(self, centre: np.ndarray, radius: float) -> bool:
        """True when a sphere (world metres) lies wholly outside the view frustum."""
        p = self.to_camera(centre)
        w, h = self.width, self.height
        normals = np.array([[self.fx, 0, -self.cx], [-self.fx, 0, -(w - self.cx)],
                            [0, -self.fy, -self.cy], [0, self.fy, -(h - self.cy)]])
        dist = normals @ p / np.linalg.norm(normals, axis=1)
        return bool(-p[2] + radius <= NEAR or np.any(dist < -radius))

    def rect_of_sphere(self, centre: np.ndarray, radius: float, k: int) -> tuple[int, int, int, int] | None:
        """Block of the ``k``-sample ray grid that can see a sphere (via its enclosing cube)."""
        if self.sphere_outside(centre, radius):
            return None
        corners = centre + radius * np.array(
            [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64
        )
        return self.rect_of_points(corners, k)

"""Ray intersections with analytic primitives, rotations and a deterministic hash noise.

Rays are ``o + t * d`` with unit ``d``; ``o`` and ``d`` broadcast against each other, (..., 3)
float64, so the same code serves camera rays (one origin) and shadow rays (one direction). Misses
are ``inf``; only hits with ``t > near`` count.
"""

from __future__ import annotations

import numpy as np

from reference_models.scenes.camera import NEAR


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if np.ndim(b) == 1:  # many vectors with one: a matrix-vector product
        return np.asarray(a) @ b
    if np.ndim(a) == 1:
        return np.asarray(b) @ a
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def intersect_sphere(o: np.ndarray, d: np.ndarray, centre: np.ndarray, radius: float,
                     near: float = NEAR) -> np.ndarray:
    """First hit distance (...,) of rays with a sphere, ``inf`` where they miss."""
    oc = o - centre
    b = _dot(d, oc)
    h = b * b - (_dot(oc, oc) - radius * radius)
    t = -b - np.sqrt(np.maximum(h, 0.0))
    return np.where((h >= 0) & (t > near), t, np.inf)


def intersect_capsule(o: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float,
                      near: float = NEAR) -> np.ndarray:
    """First hit distance (...,) of rays with the capsule of points within ``radius`` of segment
    ``a``-``b`` (a sphere when ``a == b``), ``inf`` where they miss.

    The capsule is the union of a finite cylinder and two end spheres; the first hit of a union is
    the smallest first hit of its parts.
    """
    t = np.minimum(intersect_sphere(o, d, a, radius, near), intersect_sphere(o, d, b, radius, near))
    ba = b - a
    baba = float(ba @ ba)
    if baba <= 1e-12:
        return t
    oa = o - a
    bard, baoa = _dot(d, ba), _dot(oa, ba)
    qa = baba - bard * bard
    qb = baba * _dot(d, oa) - baoa * bard
    qc = baba * _dot(oa, oa) - baoa * baoa - radius * radius * baba
    h = qb * qb - qa * qc
    ok = (h >= 0) & (qa > 1e-9 * baba)
    tc = (-qb - np.sqrt(np.maximum(h, 0.0))) / np.where(ok, qa, 1.0)
    y = baoa + tc * bard
    ok &= (y > 0) & (y < baba) & (tc > near)
    return np.where(ok & (tc < t), tc, t)


def intersect_capsules(o: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray,
                       radius: np.ndarray, near: float = NEAR) -> np.ndarray:
    """First hit distances (..., P) of rays (..., 3) with P capsules ``a``, ``b`` (P, 3),
    ``radius`` (P,) at once; ``inf`` where a ray misses a capsule. Same result as calling
    ``intersect_capsule`` per capsule (the readable reference, tested against this)."""
    o, d = o[..., None, :], d[..., None, :]
    r2 = radius * radius
    t = np.full(np.broadcast_shapes(o.shape, d.shape, a.shape)[:-1], np.inf)
    for c in (a, b):
        oc = o - c
        hb = _dot(d, oc)
        h = hb * hb - (_dot(oc, oc) - r2)
        ts = -hb - np.sqrt(np.maximum(h, 0.0))
        t = np.where((h >= 0) & (ts > near) & (ts < t), ts, t)
    ba = b - a
    baba = np.maximum(_dot(ba, ba), 1e-12)
    oa = o - a
    bard, baoa = _dot(d, ba), _dot(oa, ba)
    qa = baba - bard * bard
    qb = baba * _dot(d, oa) - baoa * bard
    qc = baba * _dot(oa, oa) - baoa * baoa - r2 * baba
    h = qb * qb - qa * qc
    ok = (h >= 0) & (qa > 1e-9 * baba)
    tc = (-qb - np.sqrt(np.maximum(h, 0.0))) / np.where(ok, qa, 1.0)
    y = baoa + tc * bard
    ok &= (y > 0) & (y < baba) & (tc > near) & (baba > 1e-12)
    return np.where(ok & (tc < t), tc, t)


def closest_on_segment(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Closest points (N, 3) on segments ``a[i]``-``b[i]`` (N, 3) to points ``x`` (N, 3)."""
    ba = b - a
    baba = np.maximum(_dot(ba, ba), 1e-12)
    s = np.clip(_dot(x - a, ba) / baba, 0.0, 1.0)
    return a + s[:, None] * ba


def intersect_parallelogram(o: np.ndarray, d: np.ndarray, p0: np.ndarray, e1: np.ndarray,
                            e2: np.ndarray, near: float = NEAR) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hits with the parallelogram ``p0 + u e1 + v e2``, ``u, v`` in [0, 1], ``e1`` orthogonal to
    ``e2``. Returns ``t`` (...,) (``inf`` on a miss) and the hit's ``u``, ``v`` (...,)."""
    n = np.cross(e1, e2)
    denom = _dot(d, n)
    safe = np.where(np.abs(denom) > 1e-12, denom, 1e-12)
    t = _dot(p0 - o, n) / safe
    op = o - p0  # u = (o + t d - p0) . e1 / |e1|^2 without forming the hit points
    u = (_dot(op, e1) + t * _dot(d, e1)) / (e1 @ e1)
    v = (_dot(op, e2) + t * _dot(d, e2)) / (e2 @ e2)
    ok = (np.abs(denom) > 1e-12) & (t > near) & (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1)
    return np.where(ok, t, np.inf), u, v


def rot_x(angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about +x."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about +y (takes -z towards -x for ``angle > 0``)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about +z."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about ``axis`` (any length > 0; identity when 0)."""
    n = np.linalg.norm(axis)
    if n < 1e-12 or angle == 0:
        return np.eye(3)
    x, y, z = np.asarray(axis, dtype=np.float64) / n
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


def hash01(ix: np.ndarray, iy: np.ndarray, salt: int) -> np.ndarray:
    """Deterministic value noise: a float64 in [0, 1) per integer cell ``(ix, iy)`` and ``salt``.

    A splitmix64 finaliser over the cell coordinates; the same on every machine.
    """
    ix = np.atleast_1d(np.asarray(ix, dtype=np.int64)).view(np.uint64)
    iy = np.atleast_1d(np.asarray(iy, dtype=np.int64)).view(np.uint64)
    h = ix * np.uint64(0x9E3779B97F4A7C15) ^ (iy + np.uint64(salt & 0xFFFFFFFF)) * _M2
    h = h ^ (h >> np.uint64(30))
    h = h * _M1
    h = h ^ (h >> np.uint64(27))
    h = h * _M2
    h = h ^ (h >> np.uint64(31))
    return (h >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53))

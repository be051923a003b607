"""The static world: pitch (stripes, lines), goals, advertising boards, tiered stands, sky.

All colours are linear RGB albedos in [0, 1]. Geometry in metres, pitch centre at the origin,
``x`` along the 105 m length, ``y`` across the 68 m width, ``z`` up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reference_models.scenes.geometry import (
    hash01,
    intersect_capsule,
    intersect_parallelogram,
    intersect_sphere,
)

HALF_LENGTH = 52.5
"""Half the pitch length (m), goal lines at ``x = +-HALF_LENGTH``."""
HALF_WIDTH = 34.0
"""Half the pitch width (m), touch lines at ``y = +-HALF_WIDTH``."""
LINE_WIDTH = 0.12
"""Width of the white lines (m)."""
GOAL_HALF_WIDTH = 3.66
"""Half the distance between the goal posts (m)."""
GOAL_HEIGHT = 2.44
"""Height of the crossbar (m)."""
POST_RADIUS = 0.06
"""Radius of posts and crossbar (m)."""

SKY, GROUND, STAND, BOARD, GOAL = 0, 1, 2, 3, 4
"""Static material codes."""

AMBIENT = 0.35
"""Ambient (sky) light, linear."""
SUN = 0.85
"""Sun irradiance on a surface facing it, linear."""


def sun_direction(elevation_deg: float = 48.0, azimuth_deg: float = 35.0) -> np.ndarray:
    """(3,) unit vector towards the sun."""
    el, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def goal_segments() -> list[tuple[np.ndarray, np.ndarray]]:
    """Posts and crossbars of both goals as capsule segments ``(a, b)``."""
    segs = []
    for sx in (-1.0, 1.0):
        x = sx * (HALF_LENGTH + POST_RADIUS)
        p = [np.array([x, sy * (GOAL_HALF_WIDTH + POST_RADIUS), 0.0]) for sy in (-1.0, 1.0)]
        top = [q + np.array([0.0, 0.0, GOAL_HEIGHT + POST_RADIUS]) for q in p]
        segs += [(p[0], top[0]), (p[1], top[1]), (top[0], top[1])]
    return segs


def _quads() -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """(material, p0, e1, e2) of the stands (tilted, rising away from the pitch) and ad boards;
    ``e1 x e2`` (the lit side) faces the pitch."""
    a = np.array
    q = [
        (STAND, a([-90.0, 42, 0]), a([180.0, 0, 0]), a([0.0, 30, 18])),
        (STAND, a([90.0, -42, 0]), a([-180.0, 0, 0]), a([0.0, -30, 18])),
        (STAND, a([62.0, 42, 0]), a([0.0, -84, 0]), a([28.0, 0, 17])),
        (STAND, a([-62.0, -42, 0]), a([0.0, 84, 0]), a([-28.0, 0, 17])),
        (BOARD, a([-58.0, 38, 0]), a([116.0, 0, 0]), a([0.0, 0, 0.9])),
        (BOARD, a([58.0, -38, 0]), a([-116.0, 0, 0]), a([0.0, 0, 0.9])),
        (BOARD, a([57.0, 38, 0]), a([0.0, -76, 0]), a([0.0, 0, 0.9])),
        (BOARD, a([-57.0, -38, 0]), a([0.0, 76, 0]), a([0.0, 0, 0.9])),
    ]
    return q


def world_extent() -> np.ndarray:
    """(2, 3) float64 ``[min, max]`` corners (metres) of everything the world holds but the sky:
    the stands' and boards' corners and the pitch's surround (models size their grids from it)."""
    corners = [np.array([-HALF_LENGTH - 3.5, -HALF_WIDTH - 3.0, 0.0]),
               np.array([HALF_LENGTH + 3.5, HALF_WIDTH + 3.0, GOAL_HEIGHT])]
    for _, p0, e1, e2 in _quads():
        corners += [p0, p0 + e1, p0 + e2, p0 + e1 + e2]
    pts = np.stack(corners)
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def stand_points(which: int, u: float, v: float, lift: float) -> np.ndarray:
    """World point at ``(u, v)`` in [0, 1]^2 of stand ``which`` (0: +y, 1: -y, 2: +x, 3: -x),
    ``lift`` metres above its surface (a spectator's eye)."""
    _, p0, e1, e2 = _quads()[which]
    n = np.cross(e1, e2)
    return p0 + u * e1 + v * e2 + lift * n / np.linalg.norm(n)


def _dist_segment_axis(p: np.ndarray, q: np.ndarray, lo: float, hi: float, at: float) -> np.ndarray:
    """Distance from points ``(p, q)`` to the segment ``{(s, at): lo <= s <= hi}``."""
    return np.hypot(p - np.clip(p, lo, hi), q - at)


def line_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Distance (m) from pitch points to the nearest white line's centre line."""
    ax, ay = np.abs(x), np.abs(y)
    d = _dist_segment_axis(ax, ay, 0, HALF_LENGTH, HALF_WIDTH)  # touch lines
    d = np.minimum(d, _dist_segment_axis(ay, ax, 0, HALF_WIDTH, HALF_LENGTH))  # goal lines
    d = np.minimum(d, _dist_segment_axis(ay, ax, 0, HALF_WIDTH, 0.0))  # halfway line
    r = np.hypot(x, y)
    d = np.minimum(d, np.abs(r - 9.15))  # centre circle
    for depth, half in ((16.5, 20.16), (5.5, 9.16)):  # penalty and goal areas
        d = np.minimum(d, _dist_segment_axis(ay, ax, 0, half, HALF_LENGTH - depth))
        d = np.minimum(d, _dist_segment_axis(ax, ay, HALF_LENGTH - depth, HALF_LENGTH, half))
    rs = np.hypot(ax - (HALF_LENGTH - 11.0), ay)  # penalty spots and arcs outside the area
    arc = np.where(ax < HALF_LENGTH - 16.5, np.abs(rs - 9.15), np.inf)
    return np.minimum(np.minimum(d, arc), np.maximum(np.minimum(r, rs) - 0.05, 0.0))


def ground_albedo(x: np.ndarray, y: np.ndarray, seed: int) -> np.ndarray:
    """(N, 3) albedo of ground points: mown stripes, lines, grass noise, a track outside."""
    stripe = np.floor((x + HALF_LENGTH) / 5.25).astype(np.int64) % 2
    grass = np.where(stripe[:, None] == 0, [0.10, 0.30, 0.06], [0.075, 0.24, 0.045])
    noise = hash01(np.floor(x * 4), np.floor(y * 4), seed) - 0.5
    coarse = hash01(np.floor(x / 3), np.floor(y / 3), seed + 7) - 0.5
    grass = grass * (1 + 0.25 * noise + 0.15 * coarse)[:, None]
    outside = (np.abs(x) > HALF_LENGTH + 3.5) | (np.abs(y) > HALF_WIDTH + 3.0)
    track = np.array([0.25, 0.22, 0.2]) * (1 + 0.2 * noise)[:, None]
    alb = np.where(outside[:, None], track, grass)
    on_line = (line_distance(x, y) < LINE_WIDTH / 2) & ~outside
    return np.where(on_line[:, None], [0.8, 0.8, 0.8], alb)


_CROWD = np.array([[0.6, 0.1, 0.1], [0.1, 0.15, 0.5], [0.7, 0.7, 0.7], [0.05, 0.05, 0.05],
                   [0.7, 0.6, 0.1], [0.2, 0.4, 0.2], [0.5, 0.35, 0.25], [0.9, 0.9, 0.9]])


def stand_albedo(u: np.ndarray, v: np.ndarray, length: np.ndarray, depth: np.ndarray,
                 which: np.ndarray, seed: int) -> np.ndarray:
    """(N, 3) crowd texture: 0.5 m seats on 0.8 m rows, a random shirt or an empty grey seat."""
    su, sv = u * length, v * depth
    iu, iv = np.floor(su / 0.5).astype(np.int64), np.floor(sv / 0.8).astype(np.int64)
    h = hash01(iu + 1000 * which, iv, seed + 11)
    person = _CROWD[(h * 1000).astype(np.int64) % len(_CROWD)]
    empty = np.array([0.15, 0.17, 0.22])
    fu, fv = su / 0.5 - iu, sv / 0.8 - iv
    head = (np.hypot(fu - 0.5, (fv - 0.75) * 1.6) < 0.22)
    alb = np.where((h < 0.12)[:, None], empty, np.where(head[:, None], [0.55, 0.4, 0.3], person))
    step = fv < 0.12
    return np.where(step[:, None], [0.3, 0.3, 0.32], alb)


_BOARDS = np.array([[0.05, 0.1, 0.5], [0.7, 0.05, 0.05], [0.05, 0.05, 0.05], [0.8, 0.5, 0.02]])


def board_albedo(u: np.ndarray, v: np.ndarray, length: np.ndarray, which: np.ndarray,
                 seed: int) -> np.ndarray:
    """(N, 3) advertising boards: 6 m panels of a colour with a white band."""
    s = u * length
    h = hash01(np.floor(s / 6).astype(np.int64) + 100 * which, which, seed + 13)
    base = _BOARDS[(h * 1000).astype(np.int64) % len(_BOARDS)]
    band = (np.abs(v - 0.5) < 0.12) & ((np.floor(s / 0.4).astype(np.int64) % 3) != 0)
    return np.where(band[:, None], [0.85, 0.85, 0.85], base)


def sky_colour(d: np.ndarray) -> np.ndarray:
    """(N, 3) linear sky radiance for unit directions (N, 3): a vertical gradient."""
    w = np.clip(d[:, 2], 0.0, 1.0)[:, None] ** 0.6
    return (1 - w) * np.array([0.75, 0.82, 0.9]) + w * np.array([0.25, 0.45, 0.8])


@dataclass(frozen=True, eq=False)
class StaticHit:
    """First hits of rays (N,) with the static world."""

    t: np.ndarray
    """(N,) float64 ray distance in metres, ``inf`` for sky."""
    material: np.ndarray
    """(N,) int8 material code (SKY, GROUND, STAND, BOARD, GOAL)."""
    point: np.ndarray
    """(N, 3) float64 hit points in world metres (the ray origin for sky)."""
    albedo: np.ndarray
    """(N, 3) float64 linear albedo (sky: its radiance)."""
    sunlit: np.ndarray
    """(N,) float64 ``max(0, n . sun)``, the unshadowed sun factor."""


def intersect_static(o: np.ndarray, d: np.ndarray, sun: np.ndarray, seed: int) -> StaticHit:
    """Intersect rays from one origin ``o`` (3,) along unit ``d`` (N, 3) with the static world."""
    n_rays = d.shape[0]
    t = np.full(n_rays, np.inf)
    mat = np.zeros(n_rays, dtype=np.int8)
    normal = np.zeros((n_rays, 3))
    down = d[:, 2] < -1e-9
    tg = np.where(down, -o[2] / np.where(down, d[:, 2], -1.0), np.inf)
    hit = np.isfinite(tg) & (tg > 0)
    t[hit], mat[hit], normal[hit] = tg[hit], GROUND, (0.0, 0.0, 1.0)
    quad_uv = np.zeros((n_rays, 4))  # u, v, length, which
    for which, (m, p0, e1, e2) in enumerate(_quads()):
        tq, u, v = intersect_parallelogram(o, d, p0, e1, e2)
        closer = tq < t
        n = np.cross(e1, e2)
        t[closer], mat[closer], normal[closer] = tq[closer], m, n / np.linalg.norm(n)
        quad_uv[closer] = np.stack([u[closer], v[closer], np.full(closer.sum(), np.linalg.norm(e1)),
                                    np.full(closer.sum(), float(which))], -1)
    segments = goal_segments()
    near_goal = {}
    for g in range(2):  # bounding sphere of each goal frame: most rays skip its capsules
        ends = np.concatenate(segments[3 * g:3 * g + 3])
        centre = 0.5 * (ends.min(0) + ends.max(0))
        radius = np.linalg.norm(ends - centre, axis=1).max() + POST_RADIUS
        near_goal[g] = np.flatnonzero(np.isfinite(intersect_sphere(o, d, centre, radius, near=-np.inf)))
    for i, (a, b) in enumerate(segments):
        idx = near_goal[i // 3]
        tc = np.full(n_rays, np.inf)
        tc[idx] = intersect_capsule(o, d[idx], a, b, POST_RADIUS)
        closer = tc < t
        t[closer], mat[closer] = tc[closer], GOAL
        if closer.any():
            x = o + tc[closer, None] * d[closer]
            ba = b - a
            s = np.clip((x - a) @ ba / (ba @ ba), 0, 1)
            normal[closer] = (x - (a + s[:, None] * ba)) / POST_RADIUS
    point = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d
    albedo = np.zeros((n_rays, 3))
    sel = mat == GROUND
    albedo[sel] = ground_albedo(point[sel, 0], point[sel, 1], seed)
    sel = mat == STAND
    qs = quad_uv[sel]
    depth = np.where(qs[:, 3] < 2, np.hypot(30, 18), np.hypot(28, 17))
    albedo[sel] = stand_albedo(qs[:, 0], qs[:, 1], qs[:, 2], depth, qs[:, 3].astype(np.int64), seed)
    sel = mat == BOARD
    qs = quad_uv[sel]
    albedo[sel] = board_albedo(qs[:, 0], qs[:, 1], qs[:, 2], qs[:, 3].astype(np.int64), seed)
    albedo[mat == GOAL] = 0.85
    sel = mat == SKY
    albedo[sel] = sky_colour(d[sel])
    sunlit = np.clip(normal @ sun, 0.0, None)
    return StaticHit(t, mat, point, albedo, sunlit)

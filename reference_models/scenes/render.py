"""Ray casting of one view: colour (supersampled), depth, instance ids, exact forward flow, boxes.

Per camera the static world is intersected once (cameras are static) and reused for every frame;
per frame only the dynamic bodies are cast, each inside the image block its bounding sphere
projects to (bounding-volume culling), and ground points test shadow rays only against the bodies
whose shadow footprint they can lie in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dynaeval.core.boxes import mask_to_box
from reference_models.scenes.actors import Body
from reference_models.scenes.camera import Camera
from reference_models.scenes.geometry import intersect_capsule, intersect_capsules
from reference_models.scenes.world import AMBIENT, GROUND, SKY, SUN, StaticHit, intersect_static


@dataclass(frozen=True, eq=False)
class View:
    """One rendered view with its exact ground truth (pixel centres)."""

    rgb: np.ndarray
    """(H, W, 3) float32 sRGB in [0, 1], averaged over ``spp`` samples per pixel."""
    depth: np.ndarray
    """(H, W) float32 z-depth in metres along the optical axis; 0 where the ray sees sky."""
    ids: np.ndarray
    """(H, W) uint16 instance id: 0 static world and sky, ``>= 1`` a player or ball."""
    flow: np.ndarray | None
    """(H, W, 2) float32 forward flow in pixels ``(dx, dy)`` to the next frame; None for the last."""
    boxes: list[dict]
    """``{"class", "id", "box": [x0, y0, x1, y1] (max exclusive), "visible"}`` per visible object."""


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """sRGB transfer function of linear values, clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def intersect_body(o: np.ndarray, d: np.ndarray, body: Body) -> tuple[np.ndarray, np.ndarray]:
    """First hits of rays with a body: ``t`` (...,) (``inf`` on a miss) and part index (...,)."""
    shape = np.broadcast_shapes(np.shape(o), np.shape(d))[:-1]
    o = np.broadcast_to(o, shape + (3,)).reshape(-1, 3)
    d = np.broadcast_to(d, shape + (3,)).reshape(-1, 3)
    t = np.empty(len(o))
    part = np.empty(len(o), dtype=np.int64)
    step = max(1, _CHUNK // len(body.radius))
    for s in range(0, len(o), step):
        tp = intersect_capsules(o[s:s + step], d[s:s + step], body.a, body.b, body.radius)
        part[s:s + step] = np.argmin(tp, axis=-1)
        t[s:s + step] = np.take_along_axis(tp, part[s:s + step, None], -1)[:, 0]
    return t.reshape(shape), part.reshape(shape)


_CHUNK = 1 << 19
"""Rays x parts evaluated at once by ``intersect_body`` (bounds the temporary memory)."""
_PER_PART = 4096
"""Above this many rays in a body's block, each part is culled on its own."""


def _part_spheres(body: Body) -> list[tuple[tuple[np.ndarray, float], int]]:
    """Bounding sphere ``(centre, radius)`` and index of each capsule part."""
    half = 0.5 * np.linalg.norm(body.b - body.a, axis=1)
    return [((0.5 * (body.a[i] + body.b[i]), float(half[i] + body.radius[i])), i)
            for i in range(len(body.radius))]


class CameraRenderer:
    """Renders the frames of one camera; holds the camera's static-world hits (state reused over
    frames)."""

    def __init__(self, camera: Camera, sun: np.ndarray, seed: int, spp: int) -> None:
        self.camera, self.sun, self.seed = camera, sun, seed
        self.k = int(round(np.sqrt(spp)))
        self._grids = {1: self._static(1)}
        if self.k > 1:
            self._grids[self.k] = self._static(self.k)

    def _static(self, k: int) -> tuple[np.ndarray, np.ndarray, StaticHit]:
        dirs, zscale = self.camera.ray_grid(k)
        shape = dirs.shape[:2]
        flat = dirs.reshape(-1, 3)
        parts = [intersect_static(self.camera.centre, flat[s:s + _CHUNK], self.sun, self.seed)
                 for s in range(0, len(flat), _CHUNK)]  # chunks bound the memory of hd views
        fields = ("t", "material", "point", "albedo", "sunlit")
        hit = StaticHit(*(np.concatenate([getattr(p, f) for p in parts]).reshape(
            shape + getattr(parts[0], f).shape[1:]) for f in fields))
        return dirs, zscale, hit

    def _cast(self, k: int, bodies: list[Body], nxt: dict[int, Body] | None):
        """Colour (rows, cols, 3) linear, and for ``nxt`` given: t, ids, next points, alone counts."""
        dirs, _, st = self._grids[k]
        o = self.camera.centre
        t = st.t.copy()
        ids = np.zeros(t.shape, dtype=np.int64)
        colour = np.zeros(t.shape + (3,))
        x_next = np.zeros(t.shape + (3,)) if nxt is not None else None
        alone: dict[int, int] = {}
        for body in bodies:
            centre, radius = body.bound
            rect = self.camera.rect_of_sphere(centre, radius, k)
            alone[body.id] = 0
            if rect is None:
                continue
            r0, r1, c0, c1 = rect
            if (r1 - r0) * (c1 - c0) > _PER_PART:
                tb, pb = self._parts_in_block(k, body, rect)
            else:
                tb, pb = intersect_body(o, dirs[r0:r1, c0:c1], body)
            alone[body.id] = int(np.isfinite(tb).sum())
            win = tb < t[r0:r1, c0:c1]
            if not win.any():
                continue
            rr, cc = np.nonzero(win)
            rr, cc = rr + r0, cc + c0
            tw, part = tb[win], pb[win]
            x = o + tw[:, None] * dirs[rr, cc]
            local = body.to_local(x, part)
            n = body.normal(x, part)
            light = AMBIENT + SUN * np.clip(n @ self.sun, 0.0, None)
            colour[rr, cc] = body.albedo(local, part, self.seed) * light[:, None]
            t[rr, cc], ids[rr, cc] = tw, body.id
            if x_next is not None:
                x_next[rr, cc] = nxt[body.id].to_world(local, part)
        lit = np.ones(t.shape)
        ground = (ids == 0) & (st.material == GROUND)
        for body in bodies:
            rect = self._shadow_rect(*body.bound, k)
            if rect is None:
                continue
            per_part = (rect[1] - rect[0]) * (rect[3] - rect[2]) > _PER_PART
            spheres = ([(sphere, [i]) for sphere, i in _part_spheres(body)] if per_part
                       else [(body.bound, slice(None))])
            for (centre, radius), parts in spheres:
                sub = self._shadow_rect(centre, radius, k) if per_part else rect
                if sub is None:
                    continue
                r0, r1, c0, c1 = sub
                sel = ground[r0:r1, c0:c1] & (lit[r0:r1, c0:c1] > 0)
                if not sel.any():
                    continue
                p = st.point[r0:r1, c0:c1][sel] + np.array([0.0, 0.0, 1e-4])
                ts = intersect_capsules(p, self.sun, body.a[parts], body.b[parts],
                                        body.radius[parts]).min(-1)
                block = lit[r0:r1, c0:c1]
                block[sel] = np.where(np.isfinite(ts), 0.0, 1.0)
        static = st.albedo * (AMBIENT + SUN * st.sunlit * lit)[..., None]
        static = np.where((st.material == SKY)[..., None], st.albedo, static)
        colour = np.where((ids > 0)[..., None], colour, static)
        return colour, t, ids, x_next, alone

    def _parts_in_block(self, k: int, body: Body, rect: tuple[int, int, int, int]):
        """Like ``intersect_body`` on the grid block ``rect``, but each part is cast only in the
        sub-block its own bounding sphere projects to (for bodies that fill much of the image)."""
        dirs = self._grids[k][0]
        r0, r1, c0, c1 = rect
        t = np.full((r1 - r0, c1 - c0), np.inf)
        part = np.zeros(t.shape, dtype=np.int64)
        for (centre, radius), i in _part_spheres(body):
            sub = self.camera.rect_of_sphere(centre, radius, k)
            if sub is None:
                continue
            s0, s1, q0, q1 = max(sub[0], r0), min(sub[1], r1), max(sub[2], c0), min(sub[3], c1)
            if s1 <= s0 or q1 <= q0:
                continue
            ti = intersect_capsule(self.camera.centre, dirs[s0:s1, q0:q1], body.a[i], body.b[i],
                                   float(body.radius[i]))
            bt, bp = t[s0 - r0:s1 - r0, q0 - c0:q1 - c0], part[s0 - r0:s1 - r0, q0 - c0:q1 - c0]
            closer = ti < bt
            bt[closer], bp[closer] = ti[closer], i
        return t, part

    def _shadow_rect(self, centre: np.ndarray, radius: float, k: int) -> tuple[int, int, int, int] | None:
        """Grid block holding the ground points whose sun ray can meet a sphere."""
        if self.sun[2] <= 0.05:
            return None
        foot = centre[:2] - centre[2] / self.sun[2] * self.sun[:2]
        half = radius / self.sun[2]
        if self.camera.sphere_outside(np.array([foot[0], foot[1], 0.0]), half * np.sqrt(2)):
            return None
        corners = np.array([[foot[0] + sx * half, foot[1] + sy * half, 0.0]
                            for sx in (-1, 1) for sy in (-1, 1)])
        return self.camera.rect_of_points(corners, k)

    def render(self, bodies: list[Body], next_bodies: list[Body] | None) -> View:
        """Render bodies (this frame) with flow towards ``next_bodies`` (same ids, next frame)."""
        cam = self.camera
        nxt = {b.id: b for b in next_bodies} if next_bodies is not None else None
        colour, t, ids, x_next, alone = self._cast(1, bodies, nxt)
        _, zscale, _ = self._grids[1]
        depth = np.where(np.isfinite(t), t * zscale, 0.0).astype(np.float32)
        flow = None
        if next_bodies is not None:
            flow = np.zeros((cam.height, cam.width, 2), dtype=np.float32)
            dyn = ids > 0
            if dyn.any():
                x_now = cam.centre + t[dyn][:, None] * self._grids[1][0][dyn]
                flow[dyn] = (cam.project(x_next[dyn])[0] - cam.project(x_now)[0]).astype(np.float32)
        if self.k > 1:
            fine, *_ = self._cast(self.k, bodies, None)
            h, w, k = cam.height, cam.width, self.k
            colour = fine.reshape(h, k, w, k, 3).mean(axis=(1, 3))
        boxes = []
        for body in bodies:
            m = ids == body.id
            box = mask_to_box(m)
            if box is None:
                continue
            boxes.append({"class": body.cls, "id": body.id, "box": [int(v) for v in box],
                          "visible": round(float(m.sum()) / alone[body.id], 4)})
        rgb = linear_to_srgb(colour).astype(np.float32)
        return View(rgb, depth, ids.astype(np.uint16), flow, boxes)

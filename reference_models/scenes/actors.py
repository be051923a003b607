"""Dynamic objects: articulated players and balls, as rigid capsule parts at any time ``t``.

A ``Body`` is one object at one instant: capsule parts, each with the rigid transform
``world = R @ local + T`` of its part, so that a surface point can be followed to another instant
exactly (``local = R_t.T @ (x - T_t)``, ``x' = R_t' @ local + T_t'``): this is the exact flow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reference_models.scenes.geometry import (
    closest_on_segment,
    hash01,
    rot_axis,
    rot_x,
    rot_y,
    rot_z,
)

GRAVITY = 9.81
"""m/s^2."""
BALL_RADIUS = 0.11
"""m."""

SHIRT, SHORTS, THIGH, SOCK, ARM, HEAD, BOOT, BALL = range(8)
"""Dynamic material codes; ``THIGH`` is shorts on top and skin below, ``HEAD`` skin with hair."""


@dataclass(frozen=True, eq=False)
class Body:
    """One dynamic object at one instant."""

    id: int
    """Instance id (>= 1) written in the instance masks."""
    cls: str
    """``"person"`` or ``"ball"``."""
    a: np.ndarray
    """(P, 3) capsule segment starts, world metres."""
    b: np.ndarray
    """(P, 3) capsule segment ends (``== a`` for spheres)."""
    radius: np.ndarray
    """(P,) capsule radii in metres."""
    rot: np.ndarray
    """(P, 3, 3) rotations of the parts' local frames (world from local)."""
    trans: np.ndarray
    """(P, 3) translations of the parts' local frames."""
    material: np.ndarray
    """(P,) int material codes."""
    palette: np.ndarray
    """(8, 3) linear albedo per material code for this object."""

    @property
    def bound(self) -> tuple[np.ndarray, float]:
        """Bounding sphere ``(centre (3,), radius)`` of all parts."""
        ends = np.concatenate([self.a, self.b])
        centre = 0.5 * (ends.min(0) + ends.max(0))
        r = np.linalg.norm(ends - centre, axis=1).max() + self.radius.max()
        return centre, float(r)

    def to_local(self, x: np.ndarray, part: np.ndarray) -> np.ndarray:
        """World points (N, 3) on parts ``part`` (N,) to the parts' local coordinates (N, 3)."""
        return np.einsum("nji,nj->ni", self.rot[part], x - self.trans[part])

    def to_world(self, local: np.ndarray, part: np.ndarray) -> np.ndarray:
        """Local part coordinates (N, 3) back to world metres (N, 3) at this body's instant."""
        return np.einsum("nij,nj->ni", self.rot[part], local) + self.trans[part]

    def normal(self, x: np.ndarray, part: np.ndarray) -> np.ndarray:
        """(N, 3) unit outward normals at surface points ``x`` of parts ``part``."""
        n = x - closest_on_segment(x, self.a[part], self.b[part])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)

    def albedo(self, local: np.ndarray, part: np.ndarray, seed: int) -> np.ndarray:
        """(N, 3) linear albedo at local part coordinates: kit colours, fabric noise, ball pattern."""
        mat = self.material[part]
        alb = self.palette[mat].copy()
        thigh_skin = (mat == THIGH) & (local[:, 2] < -0.2)
        alb[thigh_skin] = self.palette[ARM]
        hair = (mat == HEAD) & ((local[:, 2] > 0.03) | ((local[:, 0] < -0.03) & (local[:, 2] > -0.04)))
        alb[hair] = self.palette[HEAD]
        face = (mat == HEAD) & ~hair
        alb[face] = self.palette[ARM]
        cloth = np.isin(mat, (SHIRT, SHORTS, SOCK))
        if cloth.any():
            q = np.floor(local[cloth] / 0.04).astype(np.int64)
            n = hash01(q[:, 0] * 131 + q[:, 1], q[:, 2] + 17 * part[cloth], seed + self.id)
            alb[cloth] *= (0.85 + 0.3 * n)[:, None]
            stripe = (mat[cloth] == SHIRT) & (np.floor(local[cloth, 1] / 0.06).astype(np.int64) % 2 == 0)
            alb[np.flatnonzero(cloth)[stripe]] *= 0.7
        ball = mat == BALL
        if ball.any():
            u = local[ball] / np.maximum(np.linalg.norm(local[ball], axis=1, keepdims=True), 1e-12)
            patch = (u @ _ICOSA.T).max(1) > 0.93
            alb[np.flatnonzero(ball)[patch]] = (0.03, 0.03, 0.03)
        return alb


def _icosahedron() -> np.ndarray:
    p = (1 + 5 ** 0.5) / 2
    v = [(0, s1, s2 * p) for s1 in (-1, 1) for s2 in (-1, 1)]
    v = v + [(s1, s2 * p, 0) for s1 in (-1, 1) for s2 in (-1, 1)]
    v = v + [(s2 * p, 0, s1) for s1 in (-1, 1) for s2 in (-1, 1)]
    arr = np.array(v, dtype=np.float64)
    return arr / np.linalg.norm(arr, axis=1, keepdims=True)


_ICOSA = _icosahedron()


# ----------------------------------------------------------------------------------------------
# Players


@dataclass(frozen=True)
class Kit:
    """Linear RGB albedos of a team's kit."""

    shirt: tuple[float, float, float]
    """Shirt and sleeves."""
    shorts: tuple[float, float, float]
    """Shorts."""
    socks: tuple[float, float, float]
    """Socks (the shins)."""
    skin: tuple[float, float, float] = (0.45, 0.3, 0.2)
    """Arms, face, lower thighs."""
    hair: tuple[float, float, float] = (0.05, 0.03, 0.02)
    """Hair."""
    boots: tuple[float, float, float] = (0.03, 0.03, 0.03)
    """Boots."""

    def palette(self) -> np.ndarray:
        """(8, 3) albedo table indexed by material code."""
        return np.array([self.shirt, self.shorts, self.shorts, self.socks, self.skin, self.hair,
                         self.boots, (0.85, 0.85, 0.85)], dtype=np.float64)


KITS = {
    "home": Kit((0.6, 0.03, 0.03), (0.8, 0.8, 0.8), (0.6, 0.03, 0.03)),
    "away": Kit((0.05, 0.12, 0.5), (0.03, 0.03, 0.08), (0.8, 0.8, 0.8)),
    "keeper_home": Kit((0.7, 0.6, 0.02), (0.05, 0.05, 0.05), (0.7, 0.6, 0.02)),
    "keeper_away": Kit((0.1, 0.45, 0.1), (0.1, 0.45, 0.1), (0.05, 0.05, 0.05)),
}
"""Team kits."""


@dataclass(frozen=True)
class Player:
    """An animated player: where it starts, which way it goes and what it does."""

    id: int
    """Instance id (>= 1)."""
    kit: str
    """Key of ``KITS``."""
    action: str
    """``"run"``, ``"walk"``, ``"kick"`` (run-up, right-foot kick at ``t_event``, walk on) or
    ``"dive"`` (goalkeeper stance, dive sideways at ``t_event``)."""
    start: tuple[float, float]
    """Pelvis position on the pitch at ``t = 0`` (m)."""
    heading: float
    """Facing direction at ``t = 0``, radians from +x."""
    speed: float = 0.0
    """Ground speed (m/s) for run/walk, run-up speed for kick."""
    turn_rate: float = 0.0
    """Heading change rate (rad/s) for run/walk."""
    t_event: float = 0.0
    """Time (s) of the kick's contact or the dive's take-off."""
    side: float = 1.0
    """Dive direction: +1 to the player's left, -1 to the right."""
    phase: float = 0.0
    """Gait phase at ``t = 0`` (radians)."""

    def pose(self, t: float) -> tuple[np.ndarray, np.ndarray, dict[str, float], bool]:
        """Root (pelvis) position (3,), body rotation (3, 3), joint angles (radians), and whether
        the pelvis height comes from foot contact (True) or the root's own z (False)."""
        if self.action in ("run", "walk"):
            return self._locomotion(t)
        if self.action == "kick":
            return self._kick(t)
        if self.action == "dive":
            return self._dive(t)
        raise ValueError(f"unknown action {self.action!r}")

    def _gait(self, t: float, fast: bool) -> dict[str, float]:
        f, amp, k0, k1, arm, elbow, lean = (
            (1.5, 40, 15, 75, 35, 85, 12) if fast else (0.9, 22, 5, 35, 15, 20, 3))
        ph = 2 * np.pi * f * t + self.phase
        s, c = np.sin(ph), np.cos(ph)
        r = np.radians
        return {"hip_l": r(amp) * s, "hip_r": -r(amp) * s,
                "knee_l": r(k0 + k1 * max(0.0, c)), "knee_r": r(k0 + k1 * max(0.0, -c)),
                "sh_l": -r(arm) * s, "sh_r": r(arm) * s, "el_l": r(elbow), "el_r": r(elbow),
                "abd_l": r(8), "abd_r": r(8), "lean": r(lean), "roll": 0.0}

    def _locomotion(self, t: float):
        yaw = self.heading + self.turn_rate * t
        x0, y0 = self.start
        if abs(self.turn_rate) < 1e-9:
            x = x0 + self.speed * t * np.cos(yaw)
            y = y0 + self.speed * t * np.sin(yaw)
        else:
            k = self.speed / self.turn_rate
            x = x0 + k * (np.sin(yaw) - np.sin(self.heading))
            y = y0 - k * (np.cos(yaw) - np.cos(self.heading))
        return np.array([x, y, 0.0]), rot_z(yaw), self._gait(t, self.action == "run"), True

    def _kick(self, t: float):
        tau = t - self.t_event
        slow = 1.0
        dist = self.speed * min(tau, 0.0) + slow * max(tau, 0.0)
        x = self.start[0] + dist * np.cos(self.heading)
        y = self.start[1] + dist * np.sin(self.heading)
        base = self._gait(t, fast=tau < 0)
        keys_t = [-0.45, -0.2, 0.0, 0.25, 0.4]
        kick = {
            "hip_r": np.interp(tau, keys_t, np.radians([-10, -45, 40, 85, 40])),
            "knee_r": np.interp(tau, keys_t, np.radians([30, 100, 20, 10, 30])),
            "hip_l": np.radians(15.0), "knee_l": np.radians(20.0),
            "sh_l": np.radians(20.0), "sh_r": np.radians(-20.0),
            "abd_l": np.radians(50.0), "abd_r": np.radians(30.0),
            "el_l": np.radians(30.0), "el_r": np.radians(30.0), "lean": np.radians(-5.0),
        }
        w = float(np.interp(tau, [-0.55, -0.4, 0.3, 0.5], [0, 1, 1, 0]))
        angles = {k: (1 - w) * v + w * kick.get(k, v) for k, v in base.items()}
        return np.array([x, y, 0.0]), rot_z(self.heading), angles, True

    def _dive(self, t: float):
        tau = t - self.t_event
        r = np.radians
        ready = {"hip_l": r(30), "hip_r": r(30), "knee_l": r(45), "knee_r": r(45),
                 "sh_l": r(20), "sh_r": r(20), "el_l": r(60), "el_r": r(60),
                 "abd_l": r(35), "abd_r": r(35), "lean": r(20), "roll": 0.0}
        if tau <= 0:
            return np.array([*self.start, 0.0]), rot_z(self.heading), ready, True
        k = min(tau / 0.45, 1.0)
        fly = {"hip_l": r(10), "hip_r": r(10), "knee_l": r(20), "knee_r": r(20),
               "sh_l": r(10), "sh_r": r(10), "el_l": r(10), "el_r": r(10),
               "abd_l": r(160), "abd_r": r(160), "lean": r(5), "roll": -self.side * r(80)}
        angles = {n: (1 - k) * ready[n] + k * fly[n] for n in ready}
        lateral = self.side * 3.5 * min(tau, 0.55)
        z = max(0.8 + 2.2 * tau - 0.5 * GRAVITY * tau * tau, 0.22)
        left = np.array([-np.sin(self.heading), np.cos(self.heading), 0.0])
        root = np.array([*self.start, 0.0]) + lateral * left
        root[2] = z
        return root, rot_z(self.heading), angles, False

    def body(self, t: float) -> Body:
        """The player's capsules at time ``t`` (s)."""
        root, yaw_rot, ang, contact = self.pose(t)
        rb = yaw_rot @ rot_x(ang["roll"]) @ rot_y(ang["lean"])
        parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, int]] = []

        def add(rot, org, la, lb, radius, mat):
            parts.append((rot, org, org + rot @ np.asarray(la, float),
                          org + rot @ np.asarray(lb, float), radius, mat))

        add(rb, np.zeros(3), (0, -0.09, 0), (0, 0.09, 0), 0.12, SHORTS)
        add(rb, np.zeros(3), (0, 0, 0.1), (0, 0, 0.32), 0.14, SHIRT)
        add(rb, np.zeros(3), (0, -0.12, 0.43), (0, 0.12, 0.43), 0.11, SHIRT)
        add(rb, rb @ np.array([0, 0, 0.72]), (0, 0, 0), (0, 0, 0), 0.11, HEAD)
        for side, sgn in (("l", 1.0), ("r", -1.0)):
            sh = rb @ np.array([0, sgn * 0.21, 0.45])
            r_ua = rb @ rot_x(sgn * ang[f"abd_{side}"]) @ rot_y(-ang[f"sh_{side}"])
            add(r_ua, sh, (0, 0, 0), (0, 0, -0.28), 0.05, SHIRT)
            el = sh + r_ua @ np.array([0, 0, -0.28])
            r_fa = r_ua @ rot_y(-ang[f"el_{side}"])
            add(r_fa, el, (0, 0, 0), (0, 0, -0.25), 0.042, ARM)
            hip = rb @ np.array([0, sgn * 0.1, -0.05])
            r_th = rb @ rot_y(-ang[f"hip_{side}"])
            add(r_th, hip, (0, 0, 0), (0, 0, -0.42), 0.075, THIGH)
            knee = hip + r_th @ np.array([0, 0, -0.42])
            r_sh = r_th @ rot_y(ang[f"knee_{side}"])
            add(r_sh, knee, (0, 0, 0), (0, 0, -0.42), 0.055, SOCK)
            ankle = knee + r_sh @ np.array([0, 0, -0.42])
            add(r_sh, ankle, (0, 0, -0.03), (0.17, 0, -0.05), 0.045, BOOT)
        rot = np.stack([p[0] for p in parts])
        org = np.stack([p[1] for p in parts])
        a = np.stack([p[2] for p in parts])
        b = np.stack([p[3] for p in parts])
        radius = np.array([p[4] for p in parts])
        if contact:
            root = root.copy()
            root[2] = -min((a[:, 2] - radius).min(), (b[:, 2] - radius).min())
        return Body(self.id, "person", a + root, b + root, radius, rot, org + root,
                    np.array([p[5] for p in parts]), KITS[self.kit].palette())


# ----------------------------------------------------------------------------------------------
# Balls


@dataclass(frozen=True)
class _Segment:
    t0: float
    p0: np.ndarray
    v0: np.ndarray
    kind: str  # rest | fly | roll
    rot0: np.ndarray
    spin: np.ndarray  # rad/s (fly)


class Ball:
    """A ball at rest until ``t_kick``, then ballistic flight with bounces, rolling and stopping.

    ``net_x``: a goal net at ``|x| = net_x`` takes the horizontal speed out of a ball that reaches
    it below the crossbar (so shots stay on the pitch).
    """

    def __init__(self, id: int, p0: object, t_kick: float, v0: object, spin: object = (0, 0, 0),
                 t_end: float = 10.0, net_x: float | None = None) -> None:
        self.id = id
        self.segments: list[_Segment] = []
        p = np.asarray(p0, dtype=np.float64).copy()
        p[2] = max(p[2], BALL_RADIUS)
        rot = np.eye(3)
        self.segments.append(_Segment(-np.inf, p, np.zeros(3), "rest", rot, np.zeros(3)))
        t, v, spin = float(t_kick), np.asarray(v0, dtype=np.float64), np.asarray(spin, float)
        g = np.array([0.0, 0.0, -GRAVITY])
        for _ in range(20):
            if t > t_end:
                break
            if v[2] > 0.5 or p[2] > BALL_RADIUS + 1e-6:
                seg = _Segment(t, p, v, "fly", rot, spin)
                self.segments.append(seg)
                dz = p[2] - BALL_RADIUS
                tau = (v[2] + np.sqrt(v[2] ** 2 + 2 * GRAVITY * dz)) / GRAVITY
                if net_x is not None and abs(v[0]) > 1e-9:
                    tn = (np.sign(v[0]) * net_x - p[0]) / v[0]
                    if 0 < tn < tau:
                        pn = p + v * tn + 0.5 * g * tn * tn
                        if pn[2] < 2.44:
                            tau = tn
                            p, rot = pn, rot_axis(spin, np.linalg.norm(spin) * tn) @ rot
                            v = (v + g * tn) * np.array([-0.1, -0.1, 0.5])
                            t += tn
                            continue
                p = p + v * tau + 0.5 * g * tau * tau
                p[2] = BALL_RADIUS
                rot = rot_axis(spin, np.linalg.norm(spin) * tau) @ rot
                v = v + g * tau
                v = np.array([0.8 * v[0], 0.8 * v[1], -0.55 * v[2]])
                spin = 0.6 * spin
                t += tau
                if v[2] < 1.0:
                    v[2] = 0.0
            else:
                self.segments.append(_Segment(t, p, v * np.array([1, 1, 0]), "roll", rot, spin))
                break

    def _state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        seg = self.segments[0]
        for s in self.segments:
            if t >= s.t0:
                seg = s
        tau = t - seg.t0
        if seg.kind == "rest":
            return seg.p0, seg.rot0
        if seg.kind == "fly":
            p = seg.p0 + seg.v0 * tau + 0.5 * np.array([0, 0, -GRAVITY]) * tau * tau
            return p, rot_axis(seg.spin, np.linalg.norm(seg.spin) * tau) @ seg.rot0
        speed = np.linalg.norm(seg.v0)
        if speed < 1e-9:
            return seg.p0, seg.rot0
        decel = 2.0
        tau = min(tau, speed / decel)
        dist = speed * tau - 0.5 * decel * tau * tau
        u = seg.v0 / speed
        axis = np.cross([0.0, 0.0, 1.0], u)
        return seg.p0 + dist * u, rot_axis(axis, dist / BALL_RADIUS) @ seg.rot0

    def body(self, t: float) -> Body:
        """The ball as a one-sphere body at time ``t`` (s)."""
        c, rot = self._state(t)
        c = c[None]
        return Body(self.id, "ball", c, c.copy(), np.array([BALL_RADIUS]), rot[None], c.copy(),
                    np.array([BALL]), KITS["home"].palette())

"""The three environments (presets) and their sizes: who plays, where the cameras stand."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dynaeval.errors import InputError
from reference_models.scenes.actors import Ball, Body, Player
from reference_models.scenes.camera import Camera, look_at
from reference_models.scenes.world import HALF_LENGTH, HALF_WIDTH, stand_points, sun_direction

PRESETS = ("single-player-closeup", "single-player-broadcast", "players-stadium")
"""Preset names."""


@dataclass(frozen=True)
class Size:
    """Resolution, length and sampling of a render; ``None`` camera counts keep the preset's."""

    width: int
    """Image width in pixels."""
    height: int
    """Image height in pixels."""
    frames: int
    """Number of frames."""
    fps: float
    """Frames per second (frame ``i`` shows time ``i / fps`` s of the action)."""
    spp: int
    """Samples per pixel for the colour (a square number: a k x k sub-pixel grid)."""
    n_train: int | None = None
    """Training cameras kept (evenly spread over the preset's), None for all."""
    n_eval: int | None = None
    """Evaluation cameras kept (the first ones), None for all."""


SIZES = {
    "tiny": Size(64, 36, 8, 5.0, 4, n_train=4, n_eval=1),
    "small": Size(320, 180, 24, 15.0, 4),
    "hd": Size(1920, 1080, 3, 15.0, 4),
}
"""``tiny`` for tests (seconds), ``small`` for reference models (minutes), ``hd`` for benchmarks."""


@dataclass(eq=False)
class Scene:
    """A built scene: cameras and animated objects, everything needed to render any view."""

    preset: str
    """Preset name."""
    seed: int
    """Seed of every random choice (placements, textures)."""
    size: str
    """Size name the scene was built from (before overrides)."""
    width: int
    """Image width in pixels."""
    height: int
    """Image height in pixels."""
    n_frames: int
    """Number of frames."""
    fps: float
    """Frames per second."""
    spp: int
    """Default samples per pixel."""
    cameras: list[Camera]
    """Training cameras first, then evaluation cameras."""
    eval_cameras: list[str]
    """Names of the held-out evaluation cameras."""
    actors: list[Player | Ball] = field(repr=False)
    """Players and balls (ids 1..)."""
    sun: np.ndarray = field(default_factory=sun_direction, repr=False)
    """(3,) unit vector towards the sun."""
    action: dict = field(default_factory=dict)
    """Who does what: kicker / striker / goalkeeper ids, kick time (s), shot speed (m/s)."""

    @property
    def train_cameras(self) -> list[str]:
        """Names of the training cameras."""
        return [c.name for c in self.cameras if c.name not in self.eval_cameras]

    @property
    def classes(self) -> dict[int, str]:
        """Instance id -> class (``"person"``/``"ball"``); id 0 is the static world."""
        return {a.id: ("ball" if isinstance(a, Ball) else "person") for a in self.actors}

    def camera(self, name: str) -> Camera:
        """The camera called ``name``; InputError if there is none."""
        for c in self.cameras:
            if c.name == name:
                return c
        raise InputError(f"no camera {name!r} in preset {self.preset!r}; cameras are "
                         f"{[c.name for c in self.cameras]}")

    def time_of(self, frame: int) -> float:
        """Time in seconds shown by ``frame`` (may be ``n_frames``: the flow target of the last)."""
        return frame / self.fps

    def bodies(self, frame: int, hide: tuple = ()) -> list[Body]:
        """Bodies at ``frame`` without the hidden ones (a class name or an id in ``hide``)."""
        t = self.time_of(frame)
        keep = [a for a in self.actors if a.id not in hide
                and ("ball" if isinstance(a, Ball) else "person") not in hide]
        return [a.body(t) for a in keep]


def _kick_ball(player: Player, ball_id: int, v0, spin, t_end: float, net_x=None) -> Ball:
    """A ball lying in front of the kicker's right boot at the kick's contact time."""
    body = player.body(player.t_event)
    tip = body.b[-1]
    fwd = np.array([np.cos(player.heading), np.sin(player.heading), 0.0])
    p0 = tip + 0.13 * fwd
    p0[2] = 0.11
    return Ball(ball_id, p0, player.t_event, v0, spin, t_end=t_end, net_x=net_x)


def _single_player(t_end: float) -> list[Player | Ball]:
    kicker = Player(1, "home", "kick", start=(-1.4, 0.0), heading=0.0, speed=3.5, t_event=0.4)
    ball = _kick_ball(kicker, 2, v0=(1.5, 0.0, 7.0), spin=(0.0, 15.0, 0.0), t_end=t_end)
    return [kicker, ball]


def _closeup_cameras(rng: np.random.Generator, size: Size) -> tuple[list[Camera], list[Camera]]:
    target = np.array([0.4, 0.0, 1.2])
    train = []
    for i in range(30):
        ang = 2 * np.pi * i / 30 + rng.uniform(-0.05, 0.05)
        rad, h = rng.uniform(4.0, 8.0), rng.uniform(1.0, 2.8)
        eye = target + np.array([rad * np.cos(ang), rad * np.sin(ang), h - target[2]])
        train.append(Camera.from_fov(f"cam{i:02d}", size.width, size.height, 65.0, look_at(eye, target)))
    ang = 2 * np.pi * 7.5 / 30
    eye = target + np.array([6.0 * np.cos(ang), 6.0 * np.sin(ang), 1.9 - target[2]])
    return train, [Camera.from_fov("eval00", size.width, size.height, 60.0, look_at(eye, target))]


def _broadcast_cameras(rng: np.random.Generator, size: Size) -> tuple[list[Camera], list[Camera]]:
    target = np.array([0.3, 0.0, 1.0])
    eyes = [(x, sy * 40.0, rng.uniform(7.0, 12.0)) for sy in (-1, 1) for x in np.linspace(-45, 45, 7)]
    eyes += [(sx * 59.5, y, rng.uniform(7.0, 9.0)) for sx in (-1, 1) for y in (-15.0, 0.0, 15.0)]

    def cam(name, eye):
        dist = np.linalg.norm(np.asarray(eye) - target)
        hfov = np.degrees(2 * np.arctan(8.0 / dist))
        return Camera.from_fov(name, size.width, size.height, hfov, look_at(eye, target))

    return ([cam(f"cam{i:02d}", e) for i, e in enumerate(eyes)],
            [cam("eval00", (22.0, -40.0, 4.5))])


def _stadium(rng: np.random.Generator, t_end: float) -> tuple[list, dict]:
    n_players = int(rng.integers(10, 23))
    n_balls = int(rng.integers(1, 3))
    keeper_x = HALF_LENGTH - 1.5
    target_y, target_z = rng.uniform(-2.5, 2.5), rng.uniform(0.5, 2.0)
    t_kick = 0.35
    sx, sy = HALF_LENGTH - rng.uniform(18.0, 26.0), rng.uniform(-12.0, 12.0)
    heading = float(np.arctan2(target_y - sy, HALF_LENGTH - sx))
    back = 4.0 * t_kick
    striker = Player(3, "home", "kick", start=(sx - back * np.cos(heading), sy - back * np.sin(heading)),
                     heading=heading, speed=4.0, t_event=t_kick)
    actors: list = [
        Player(1, "keeper_away", "dive", start=(keeper_x, 0.0), heading=np.pi,
               t_event=t_kick + 0.2, side=1.0 if target_y < 0 else -1.0),
        Player(2, "keeper_home", "walk", start=(-keeper_x, 0.0), heading=0.0, speed=0.6),
        striker,
    ]
    taken = [np.array(p.start) for p in actors]
    for pid in range(4, n_players + 1):
        while True:
            pos = np.array([rng.uniform(-45, 45), rng.uniform(-30, 30)])
            if min(np.linalg.norm(pos - q) for q in taken) > 2.5:
                break
        taken.append(pos)
        run = rng.random() < 0.7
        actors.append(Player(pid, "home" if pid % 2 else "away", "run" if run else "walk",
                             start=(float(pos[0]), float(pos[1])), heading=float(rng.uniform(-np.pi, np.pi)),
                             speed=float(rng.uniform(4, 7) if run else rng.uniform(1, 2)),
                             turn_rate=float(rng.uniform(-0.5, 0.5)), phase=float(rng.uniform(0, 2 * np.pi))))
    body = striker.body(t_kick)
    ball_start = body.b[-1] + 0.13 * np.array([np.cos(heading), np.sin(heading), 0.0])
    speed = rng.uniform(20.0, 30.0)
    dist = np.hypot(HALF_LENGTH - ball_start[0], target_y - ball_start[1])
    vh = 0.97 * speed
    tt = dist / vh
    vz = (target_z - 0.11 + 0.5 * 9.81 * tt * tt) / tt
    v0 = (vh * np.cos(heading), vh * np.sin(heading), vz)
    ball_id = n_players + 1
    actors.append(_kick_ball(striker, ball_id, v0, spin=(0.0, 0.0, 8.0), t_end=t_end, net_x=HALF_LENGTH + 2.0))
    action = {"striker_id": 3, "goalkeeper_id": 1, "shot_ball_id": ball_id,
              "shot_speed_m_s": round(float(speed), 3), "kick_time_s": t_kick}
    if n_balls == 2:
        passer = actors[3] if n_players > 3 else actors[1]
        ang = rng.uniform(-np.pi, np.pi)
        p0 = (*np.asarray(passer.start) + 0.6, 0.11)
        actors.append(Ball(ball_id + 1, p0, 0.2, (12 * np.cos(ang), 12 * np.sin(ang), 0.0), t_end=t_end))
    return actors, action


def _stadium_cameras(rng: np.random.Generator, size: Size, actors: list,
                     t_mid: float) -> tuple[list[Camera], list[Camera]]:
    train = []
    spots = [(0, 0.22 + 0.56 * (i + 0.5) / 10) for i in range(10)]
    spots += [(1, 0.22 + 0.56 * (i + 0.5) / 10) for i in range(10)]
    spots += [(w, 0.2 + 0.6 * (i + 0.5) / 5) for w in (2, 3) for i in range(5)]
    for i, (which, u) in enumerate(spots):
        eye = stand_points(which, u, rng.uniform(0.45, 0.65), 1.5)
        target = np.array([rng.uniform(-5, 5), rng.uniform(-4, 4), 0.0])
        train.append(Camera.from_fov(f"cam{i:02d}", size.width, size.height, 90.0, look_at(eye, target)))
    evals = []
    focus = [a for a in actors if isinstance(a, Player)]
    order = [2, 0] + [int(j) for j in rng.permutation(np.arange(3, len(focus)))[:4]]
    for j, idx in enumerate(order[:6]):
        body = focus[idx].body(t_mid)
        target = body.bound[0].copy()
        target[2] = 1.0
        for _ in range(100):  # stand on the pitch, not in the stands
            ang, dist = rng.uniform(-np.pi, np.pi), rng.uniform(9.0, 15.0)
            eye = target + np.array([dist * np.cos(ang), dist * np.sin(ang), rng.uniform(1.5, 3.5)])
            if abs(eye[0]) < HALF_LENGTH - 2 and abs(eye[1]) < HALF_WIDTH - 2:
                break
        evals.append(Camera.from_fov(f"eval{j:02d}", size.width, size.height, 40.0, look_at(eye, target)))
    return train, evals


def _pick(cams: list[Camera], n: int | None, prefix: str) -> list[Camera]:
    if n is None or n >= len(cams):
        return cams
    idx = np.round(np.linspace(0, len(cams) - 1, n)).astype(int) if prefix == "cam" else np.arange(n)
    return [Camera(f"{prefix}{j:02d}", c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.c2w)
            for j, c in enumerate(cams[i] for i in idx)]


def build_scene(preset: str, seed: int = 0, size: str = "small", width: int | None = None,
                height: int | None = None, frames: int | None = None, fps: float | None = None,
                spp: int | None = None) -> Scene:
    """Build a preset's cameras and animated objects (nothing is rendered).

    ``size`` is ``tiny``/``small``/``hd`` (see ``SIZES``); ``width``, ``height``, ``frames``,
    ``fps`` and ``spp`` override it. Raises InputError for an unknown preset or size, or bad values.
    """
    if preset not in PRESETS:
        raise InputError(f"unknown preset {preset!r}; expected one of {', '.join(PRESETS)}")
    if size not in SIZES:
        raise InputError(f"unknown size {size!r}; expected one of {', '.join(SIZES)}")
    base = SIZES[size]
    chosen = Size(width or base.width, height or base.height, frames or base.frames,
                  fps or base.fps, spp or base.spp, base.n_train, base.n_eval)
    for name, value in (("width", chosen.width), ("height", chosen.height), ("frames", chosen.frames)):
        if int(value) != value or value < 1:
            raise InputError(f"{name} must be a positive integer, got {value!r}")
    if chosen.width < 8 or chosen.height < 8 or chosen.width * chosen.height > 4096 * 4096:
        raise InputError(f"image size must be between 8x8 and 4096x4096 pixels, got "
                         f"{chosen.width}x{chosen.height}")
    if not (chosen.fps > 0 and np.isfinite(chosen.fps)):
        raise InputError(f"fps must be a positive number, got {chosen.fps!r}")
    k = int(round(np.sqrt(chosen.spp))) if chosen.spp >= 1 else 0
    if k < 1 or k * k != chosen.spp or k > 8:
        raise InputError(f"spp must be a square number of samples per pixel (1, 4, 9, .., 64), "
                         f"got {chosen.spp!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng(seed)
    t_end = (chosen.frames + 1) / chosen.fps + 1.0
    if preset == "players-stadium":
        actors, action = _stadium(rng, t_end)
        train, evals = _stadium_cameras(rng, chosen, actors, 0.5 * chosen.frames / chosen.fps)
    else:
        actors = _single_player(t_end)
        action = {"kicker_id": 1, "ball_id": 2, "kick_time_s": actors[0].t_event}
        make = _closeup_cameras if preset == "single-player-closeup" else _broadcast_cameras
        train, evals = make(rng, chosen)
    cams = _pick(train, chosen.n_train, "cam") + _pick(evals, chosen.n_eval, "eval")
    return Scene(preset, int(seed), size, chosen.width, chosen.height, chosen.frames, chosen.fps,
                 chosen.spp, cams, [c.name for c in cams if c.name.startswith("eval")], actors,
                 action=action)

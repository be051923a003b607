"""Players stand on the ground and parts move rigidly; balls fly ballistically and stay above it."""

import numpy as np
import pytest

from reference_models.scenes.actors import BALL_RADIUS, GRAVITY, Ball, Player


@pytest.mark.parametrize("action", ["run", "walk", "kick"])
def test_feet_touch_the_ground(action):
    p = Player(1, "home", action, start=(0.0, 0.0), heading=0.3, speed=3.0, t_event=0.5)
    for t in np.linspace(0, 1.5, 16):
        b = p.body(t)
        lowest = min((b.a[:, 2] - b.radius).min(), (b.b[:, 2] - b.radius).min())
        assert lowest == pytest.approx(0.0, abs=1e-9)
        assert 1.5 < b.a[:, 2].max() + 0.11 < 2.0  # head top, about 1.8 m


def test_parts_round_trip_between_world_and_local(rng):
    body = Player(1, "away", "dive", start=(50.0, 0.0), heading=np.pi, t_event=0.2).body(0.5)
    part = rng.integers(0, len(body.radius), size=50)
    x = rng.normal(size=(50, 3))
    np.testing.assert_allclose(body.to_world(body.to_local(x, part), part), x, atol=1e-12)


def test_ball_rests_then_follows_a_parabola_then_stays_above_ground():
    v0 = np.array([3.0, 1.0, 6.0])
    ball = Ball(1, (0.0, 0.0, BALL_RADIUS), 0.5, v0, spin=(0.0, 5.0, 0.0))
    np.testing.assert_allclose(ball.body(0.2).a[0], [0, 0, BALL_RADIUS])
    tau = 0.4
    expected = np.array([0, 0, BALL_RADIUS]) + v0 * tau + 0.5 * np.array([0, 0, -GRAVITY]) * tau**2
    np.testing.assert_allclose(ball.body(0.5 + tau).a[0], expected, atol=1e-12)
    z = [ball.body(t).a[0, 2] for t in np.linspace(0, 8, 400)]
    assert min(z) >= BALL_RADIUS - 1e-9
    assert ball.body(8.0).a[0] == pytest.approx(ball.body(9.0).a[0])  # came to rest


def test_net_stops_a_shot_on_target():
    ball = Ball(1, (40.0, 0.0, BALL_RADIUS), 0.0, (25.0, 0.0, 3.0), net_x=54.5)
    xs = [ball.body(t).a[0, 0] for t in np.linspace(0, 3, 300)]
    assert max(xs) < 54.6

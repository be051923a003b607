"""Ray importance sampling: weights are dynaeval's, draws follow them, the schedule, errors."""

import numpy as np
import pytest
import torch

from dynaeval.errors import InputError
from dynaeval.regions.motion import importance_weights
from reference_models.common.data import Views
from reference_models.common.importance import RaySampler, _search, view_weights


def _views(frames=6, cameras=2, size=(10, 8)):
    """Static grey cameras with one bright square moving right by a pixel per frame."""
    w, h = size
    imgs, cams, times = [], [], []
    for c in range(cameras):
        for f in range(frames):
            im = np.full((h, w, 3), 90, np.uint8)
            im[2:4, f:f + 2] = 250
            imgs.append(im)
            cams.append(f"cam{c}")
            times.append(f / max(frames - 1, 1))
    n = len(imgs)
    return Views(np.stack(imgs), np.tile(np.eye(4, dtype=np.float32), (n, 1, 1)),
                 np.tile(np.float32([5, 5, w / 2, h / 2]), (n, 1)), np.float32(times),
                 cams, [f"{i:04d}" for i in range(n)])


def test_weights_are_dynaevals_per_camera():
    v = _views()
    got = view_weights(v, "ist")
    np.testing.assert_array_equal(got[6:12], importance_weights(v.images[6:12], "ist"))


def test_binary_search_matches_searchsorted(rng):
    cdf = torch.tensor(np.cumsum(rng.uniform(0, 1, (5, 37)), axis=1), dtype=torch.float32)
    cdf = cdf / cdf[:, -1:]
    rows = torch.tensor(rng.integers(0, 5, 200))
    u = torch.rand(200, generator=torch.Generator().manual_seed(1)) * 0.999
    want = torch.stack([torch.searchsorted(cdf[r], u[i:i + 1], right=True)[0] for i, r in enumerate(rows)])
    np.testing.assert_array_equal(_search(cdf, rows, u).numpy(), want.numpy())


def test_importance_rays_land_on_the_moving_square():
    v = _views()
    s = RaySampler(v, "isg", importance_fraction=1.0, seed=0)
    view, row, col = s.sample(2000)
    frame = view % 6
    on_square = (row >= 2) & (row < 4) & (col >= frame) & (col < frame + 2)
    assert float(on_square.float().mean()) > 0.8  # the square is 4 of 80 pixels
    u = RaySampler(v, "uniform", seed=0).sample(2000)
    assert int(u[0].max()) < 12 and int(u[1].max()) < 8 and int(u[2].max()) < 10


def test_fraction_and_schedule():
    v = _views()
    s = RaySampler(v, "ist", importance_fraction=0.25, ist_from=0.5)
    assert [s.kind_at(p) for p in (0.0, 0.49, 0.5, 0.9)] == ["isg", "isg", "ist", "ist"]
    assert RaySampler(v, "isg").kind_at(0.9) == "isg" and RaySampler(v).kind_at(0.0) is None
    view, _, _ = s.sample(100, progress=0.7)
    assert len(view) == 100 and s._kind == "ist"


def test_same_seed_same_rays():
    a = RaySampler(_views(), "isg", seed=3).sample(50)
    b = RaySampler(_views(), "isg", seed=3).sample(50)
    assert all(torch.equal(x, y) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("kwargs, match", [
    ({"mode": "random"}, "sampling must be one of"),
    ({"importance_fraction": 1.5}, r"importance_fraction must be in \[0, 1\]"),
])
def test_bad_settings(kwargs, match):
    with pytest.raises(InputError, match=match):
        RaySampler(_views(), **kwargs)


def test_single_frame_cameras_cannot_be_importance_sampled():
    with pytest.raises(InputError, match="needs static cameras that film several frames"):
        RaySampler(_views(frames=1), "isg", importance_fraction=1.0).sample(4)

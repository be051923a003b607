"""K-Planes end to end on the tiny scene (train, render, `dynaeval score`) and its field."""

import numpy as np
import pytest
import torch

from dynaeval.errors import InputError
from reference_models.kplanes import SPEC, KPlanesConfig
from reference_models.kplanes.field import build_encoding
from tests.reference_models.common.tiny import check_tiny_run


def test_tiny_run_beats_a_constant_colour_and_scores(tiny_data, tmp_path):
    out = check_tiny_run(SPEC, tiny_data, tmp_path / "run", sampling="ist")
    assert {r["sampling"] for r in out["log"]} == {"isg", "ist"}  # the published schedule
    print(f"\nkplanes tiny: eval {out['log'][-1]['eval_psnr']:.2f} dB vs constant "
          f"{out['baseline']:.2f} dB")  # recorded, not asserted beyond the margin


def test_time_resolution_defaults_to_the_frames():
    enc = build_encoding(KPlanesConfig(resolution=8, scales=(1, 2), features=4, max_resolution=12),
                         {"n_frames": 24})
    shapes = [tuple(p.shape[-2:]) for p in enc.views()]
    assert shapes[5] == (24, 8) and shapes[11] == (24, 12)  # zt plane at both scales; space capped
    assert enc.out_dim == 8 and sum(p.numel() for p in enc.parameters()) > 0
    assert isinstance(enc(torch.zeros(3, 4)), torch.Tensor)


def test_moving_box_holds_the_player_and_the_ball(tiny_data):
    from reference_models.common.data import load_dataset
    from reference_models.kplanes.field import find_moving_box
    from reference_models.scenes import build_scene

    data = load_dataset(tiny_data)
    box = np.array(find_moving_box(KPlanesConfig(dynamic_box=True), data)["moving_box"])
    assert find_moving_box(KPlanesConfig(), data) == {}
    scene = build_scene("single-player-closeup", size="tiny")
    centres = np.concatenate([0.5 * (b.a + b.b) for f in range(scene.n_frames) for b in scene.bodies(f)])
    inside = np.all((centres >= box[0] - 0.3) & (centres <= box[1] + 0.3), axis=1)
    assert inside.mean() > 0.9, inside.mean()  # 4 cameras: a coarse hull, but it holds the action
    assert np.prod(box[1] - box[0]) < 0.25 * np.prod(data.box[1] - data.box[0])  # much smaller


def test_dynamic_box_encoding_is_static_outside_and_starts_static_inside():
    scene = {"n_frames": 5, "box": [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]],
             "moving_box": [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]]}
    enc = build_encoding(KPlanesConfig(resolution=8, scales=(1,), features=4, dynamic_box=True,
                                       dynamic_resolution=4), scene)
    assert len(enc.static.planes) == 3 and len(enc.time.planes) == 3
    x = torch.tensor([[0.0, 0.0, 0.0, -1.0], [0.0, 0.0, 0.0, 1.0], [0.4, 0.0, 0.0, 0.5]])
    with torch.no_grad():
        np.testing.assert_allclose(enc(x), enc.static(x), rtol=1e-6)  # time planes start at 1
        for p in enc.time.views():
            p.mul_(torch.linspace(0.5, 2.0, 5).view(1, 1, 5, 1))  # vary along time
        f = enc(x)
        assert not torch.allclose(f[0], f[1])  # inside the moving box time matters ...
        np.testing.assert_allclose(f[2], enc.static(x)[2], rtol=1e-6)  # ... outside it does not
    assert set(enc.regularizers()) == {"tv", "time_smooth", "time_l1"}


def test_moving_box_needs_something_that_moves(tmp_path):
    from dynaeval.errors import InputError
    from reference_models.common.data import Dataset
    from reference_models.kplanes.field import find_moving_box
    from tests.reference_models.common.test_importance import _views

    views = _views()
    views.images[:] = 90  # nothing moves any more
    data = Dataset(tmp_path, views, None, 6, np.array([[-1.0] * 3, [1.0] * 3], np.float32))
    with pytest.raises(InputError, match="found nothing that moves"):
        find_moving_box(KPlanesConfig(dynamic_box=True), data)


def test_fine_dynamic_box_adds_its_own_space_planes_starting_at_one():
    scene = {"n_frames": 5, "box": [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]],
             "moving_box": [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]]}
    cfg = KPlanesConfig(resolution=8, scales=(1,), features=4, dynamic_box=True,
                        dynamic_resolution=4, dynamic_planes="space-time")
    enc = build_encoding(cfg, scene)
    assert len(enc.time.planes) == 6 and all(bool((p == 1).all()) for p in enc.time.planes)
    x = torch.tensor([[0.1, 0.0, 0.0, -1.0], [0.1, 0.0, 0.0, 1.0], [-0.1, 0.0, 0.0, -1.0],
                      [0.9, 0.9, 0.9, 0.0]])
    with torch.no_grad():
        np.testing.assert_allclose(enc(x), enc.static(x), rtol=1e-6)  # a factor of ones
        assert enc.time.plane_pairs[0] == (0, 1)
        enc.time.plane(0).mul_(torch.linspace(0.5, 2.0, 4).view(1, 1, 1, 4))  # xy varies along x
        f = enc(x)
        np.testing.assert_allclose(f[0], f[1], rtol=1e-6)  # a space plane: no change in time
        assert not torch.allclose(f[0] / enc.static(x)[0], f[2] / enc.static(x)[2])  # but in x
        np.testing.assert_allclose(f[3], enc.static(x)[3], rtol=1e-6)  # outside the box: static
    with pytest.raises(InputError, match="dynamic_planes must be"):
        build_encoding(KPlanesConfig(dynamic_box=True, dynamic_planes="space"), scene)
    assert "small-dynbox-fine" in SPEC.presets and "tiny-dynbox-fine" in SPEC.presets


def test_scale_rows_multiplies_only_the_chosen_rows_and_has_autograd_s_gradient():
    from reference_models.kplanes.field import scale_rows

    torch.manual_seed(0)
    f = torch.rand(40, 6, dtype=torch.float64, requires_grad=True)
    factor = torch.rand(5, 6, dtype=torch.float64, requires_grad=True)
    idx = torch.tensor([0, 7, 8, 21, 39])
    want = f.detach().clone()
    want[idx] *= factor.detach()
    torch.testing.assert_close(scale_rows(f * 1.0, idx, factor), want, rtol=0, atol=0)
    assert torch.autograd.gradcheck(lambda a, b: scale_rows(a * 1.0, idx, b), (f, factor))

"""K-Planes planes (initialisation, coordinate convention, regularisers) and direction harmonics."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_models.common.encodings import PlaneEncoding, spherical_harmonics


@pytest.fixture(autouse=True)
def _no_grad():
    with torch.no_grad():
        yield


def test_time_planes_start_at_one_so_features_ignore_time():
    torch.manual_seed(0)
    enc = PlaneEncoding(8, 5, (1, 2), 4)
    assert enc.out_dim == 8 and len(enc.planes) == 12
    x = torch.rand(50, 4) * 2 - 1
    x2 = x.clone()
    x2[:, 3] = -x2[:, 3]
    np.testing.assert_allclose(enc(x), enc(x2), rtol=1e-6)
    space = [p for p, (_, b) in zip(enc.views(), enc.plane_pairs, strict=True) if b != 3]
    assert all(0.1 <= float(p.min()) and float(p.max()) <= 0.5 for p in space)
    reg = enc.regularizers()
    assert float(reg["time_l1"]) == 0.0 and float(reg["time_smooth"]) == 0.0 and float(reg["tv"]) > 0


def test_corners_of_minus_one_to_one_hit_the_corner_texels():
    """grid_sample takes [-1, 1] (align_corners): -1 and 1 are the first and last texels; a
    [0, 1] convention would read the middle of the plane at 0."""
    enc = PlaneEncoding(4, 3, (1,), 1, planes="space")
    for p in enc.views():
        p.copy_(torch.arange(16.0).view(1, 1, 4, 4) + 1.0)
    got = enc(torch.tensor([[-1.0, -1.0, -1.0, 0.0], [1.0, 1.0, 1.0, 0.0]])).squeeze(-1)
    np.testing.assert_allclose(got.numpy(), [1.0, 16.0 ** 3])


def test_features_multiply_across_planes_and_concatenate_across_scales():
    enc = PlaneEncoding(4, 3, (1, 2), 2)
    for k, p in enumerate(enc.views()):
        p.fill_(2.0 if k < 6 else 3.0)
    out = enc(torch.zeros(1, 4))
    np.testing.assert_allclose(out.numpy(), [[64, 64, 729, 729]])
    assert enc.plane(6).shape[-1] == 8 and enc.plane(5).shape[-2] == 3  # scale 2; time stays 3


def test_regularizers_see_what_they_penalise():
    enc = PlaneEncoding(4, 5, (1,), 1)
    for p in enc.planes:
        p.fill_(1.0)
    enc.plane(5)[0, 0, :, 0] = torch.tensor([1.0, 2.0, 3.0, 4.0, 5.0])  # zt plane, linear in t
    reg = enc.regularizers()
    assert float(reg["time_smooth"]) == pytest.approx(0.0, abs=1e-12)  # linear: no 2nd difference
    assert float(reg["time_l1"]) > 0 and float(reg["tv"]) > 0


@settings(max_examples=20, deadline=None)
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1))
def test_harmonics_addition_theorem(x, y, z):
    """sum_m Y_lm(d)^2 = (2l + 1) / (4 pi) for every degree l: an identity of true real SH."""
    d = torch.tensor([[x, y, z + 1e-3]], dtype=torch.float64)
    d = d / d.norm()
    sh = spherical_harmonics(d)[0].numpy()
    for lo, hi, deg in ((0, 1, 0), (1, 4, 1), (4, 9, 2), (9, 16, 3)):
        assert np.sum(sh[lo:hi] ** 2) == pytest.approx((2 * deg + 1) / (4 * np.pi), rel=1e-9)


def test_squared_difference_mean_has_autograd_s_gradient():
    from reference_models.common.encodings import squared_difference_mean

    torch.manual_seed(1)
    with torch.enable_grad():
        for dim in (-1, -2):
            p = torch.rand(1, 3, 7, 5, dtype=torch.float64, requires_grad=True)
            want = torch.autograd.grad(p.diff(dim=dim).square().mean(), p)[0]
            value = squared_difference_mean(p, dim)
            got = torch.autograd.grad(value, p)[0]
            assert float(value.detach()) == pytest.approx(float(p.detach().diff(dim=dim).square().mean()), rel=1e-12)
            torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-15)


def test_static_only_is_the_same_field_while_time_planes_are_one():
    torch.manual_seed(2)
    enc = PlaneEncoding(8, 5, (1, 2), 4)
    x = torch.rand(40, 4) * 2 - 1
    full = enc(x)
    enc.static_only = True
    torch.testing.assert_close(enc(x), full, rtol=1e-6, atol=0)  # a look-up of ones is 1 (an ulp)
    assert enc.plane_pairs[2] == (0, 3)
    enc.planes[2].add_(0.5)  # a time plane (xt) moves: only the full field sees it
    torch.testing.assert_close(enc(x), full, rtol=1e-6, atol=0)
    enc.static_only = False
    assert float((enc(x) - full).abs().max()) > 1e-3

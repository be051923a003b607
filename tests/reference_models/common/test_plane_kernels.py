"""The compiled CPU plane look-up against grid_sample: values and gradients, float32."""

import pytest
import torch

from reference_models.common.encodings import (
    PlaneEncoding,
    grid_sample_product,
    squared_difference_mean,
)
from reference_models.common.plane_kernels import plane_product, plane_tv, uses_fused_lookup

RTOL, ATOL = 1e-5, 1e-5
"""float32: the texel coordinates are computed in grid_sample's own order, so the values agree
to a few ulps; gradients sum many products in another order (scatter vs per-channel)."""


def _planes(shapes, features, seed):
    g = torch.Generator().manual_seed(seed)
    return [torch.rand(1, features, h, w, generator=g).contiguous(memory_format=torch.channels_last)
            .requires_grad_() for h, w in shapes]


def _coords(n, seed):
    """Random points in [-1.3, 1.3] (out of range: border padding) plus every corner, edge
    midpoint and the centre of [-1, 1]^4's faces, and points just outside the corners."""
    g = torch.Generator().manual_seed(seed)
    x = torch.rand(n, 4, generator=g) * 2.6 - 1.3
    special = torch.cartesian_prod(*[torch.tensor([-1.0, 0.0, 1.0])] * 4)
    outside = torch.cartesian_prod(*[torch.tensor([-1.0001, 1.0001, -7.0, 3.0])] * 2)
    outside = torch.cat([outside, outside.flip(-1)], -1)
    return torch.cat([special, outside, x])


@pytest.mark.parametrize("shapes", [
    [(4, 4), (4, 4), (4, 4)],
    [(64, 1024), (1024, 64), (7, 5)],          # non-square, both ways
    [(2, 2), (24, 256), (256, 24), (9, 33), (33, 9), (256, 256)],  # six planes of a scale
    [(3, 130)],                                  # one plane: no product
])
def test_fused_product_equals_grid_sample(shapes):
    features = 16 if len(shapes) > 1 else 3
    planes = _planes(shapes, features, seed=len(shapes))
    pairs = [(0, 1), (0, 2), (1, 2), (0, 3), (1, 3), (2, 3)][:len(shapes)]
    x = _coords(3000, seed=7)
    assert uses_fused_lookup(x, planes)
    grad = torch.randn(x.shape[0], features, generator=torch.Generator().manual_seed(3))
    want = grid_sample_product(x, planes, pairs)
    want_g = torch.autograd.grad(want, planes, grad)
    got = plane_product(x, planes, pairs)
    got_g = torch.autograd.grad(got, planes, grad)
    torch.testing.assert_close(got, want, rtol=RTOL, atol=ATOL)
    for g, w, p in zip(got_g, want_g, planes, strict=True):
        assert g.shape == p.shape
        torch.testing.assert_close(g, w, rtol=RTOL, atol=ATOL * float(w.abs().max()))


def _varied_encoding(*args):
    """A ``PlaneEncoding(*args)`` whose planes are uniform in [0.5, 1.5] (seed 0): every plane
    varies, time planes included."""
    torch.manual_seed(0)
    enc = PlaneEncoding(*args)
    with torch.no_grad():
        for p in enc.planes:
            p.uniform_(0.5, 1.5)
    return enc


def test_a_plane_not_stored_channels_last_reads_the_same():
    planes = _planes([(6, 9), (9, 6)], 4, seed=1)
    plain = [p.detach().contiguous().requires_grad_() for p in planes]
    x = _coords(200, seed=2)
    torch.testing.assert_close(plane_product(x, plain, [(0, 1), (2, 3)]),
                               grid_sample_product(x, planes, [(0, 1), (2, 3)]), rtol=RTOL, atol=ATOL)


def test_coordinates_with_a_gradient_take_grid_sample():
    enc = PlaneEncoding(8, 5, (1, 2), 4)
    x = (torch.rand(50, 4) * 2 - 1).requires_grad_()
    assert not uses_fused_lookup(x, enc.views())
    with pytest.raises(ValueError, match="grid_sample"):
        plane_product(x, enc.views()[:6], enc.plane_pairs[:6])
    enc(x).sum().backward()  # the grid_sample path: the coordinates get their gradient
    assert x.grad is not None and float(x.grad.abs().sum()) > 0


def test_encoding_uses_the_fused_path_and_matches_grid_sample():
    enc = _varied_encoding(16, 5, (1, 2), 8)
    assert all(p.is_contiguous(memory_format=torch.channels_last) for p in enc.views())
    x = _coords(500, seed=4)
    fast = enc(x)
    fast_g = torch.autograd.grad(fast.square().sum(), list(enc.planes))
    ref = torch.cat([grid_sample_product(x, enc.views()[s * 6:(s + 1) * 6], enc.pairs)
                     for s in range(2)], -1)
    ref_g = torch.autograd.grad(ref.square().sum(), list(enc.planes))
    torch.testing.assert_close(fast, ref, rtol=RTOL, atol=ATOL)
    for g, w in zip(fast_g, ref_g, strict=True):
        torch.testing.assert_close(g, w, rtol=RTOL, atol=ATOL * float(w.abs().max()))


def test_a_state_dict_of_plain_planes_loads_into_channels_last_ones():
    """Checkpoints written before the planes were channels_last hold plain (1, F, H, W) tensors:
    same keys and shapes; loading copies them into the channels_last parameters."""
    torch.manual_seed(0)
    old = {k: v.contiguous() for k, v in PlaneEncoding(8, 5, (1, 2), 4).state_dict().items()}
    assert not all(v.is_contiguous(memory_format=torch.channels_last) for v in old.values())
    enc = PlaneEncoding(8, 5, (1, 2), 4)
    enc.load_state_dict(old)
    assert all(p.is_contiguous(memory_format=torch.channels_last) for p in enc.views())
    for k, v in enc.state_dict().items():
        torch.testing.assert_close(v, old[k], rtol=0, atol=0)


def test_planes_are_stored_so_fused_adam_updates_them_without_copies():
    """Planes kept as (1, F, H, W) ``channels_last`` parameters made torch's fused Adam copy each
    into a contiguous tensor and back every step (issue 40).
    Stored (1, H, W, F), the parameters and their gradients are contiguous, and one Adam step
    gives the very numbers the old layout gave."""
    enc = _varied_encoding(8, 5, (1, 2), 4)
    x = torch.rand(300, 4) * 2 - 1
    (enc(x).square().sum() + sum(enc.regularizers().values())).backward()
    assert all(p.is_contiguous() and p.grad.is_contiguous() for p in enc.planes)
    old = [v.detach().clone(memory_format=torch.channels_last).requires_grad_() for v in enc.views()]
    for o, p in zip(old, enc.planes, strict=True):
        o.grad = p.grad.permute(0, 3, 1, 2).contiguous(memory_format=torch.channels_last)
    for params in (list(enc.parameters()), old):
        torch.optim.Adam(params, lr=1e-2, eps=1e-15, fused=True).step()
    for o, v in zip(old, enc.views(), strict=True):
        torch.testing.assert_close(v, o, rtol=0, atol=0)
    assert all(tuple(v.shape) == tuple(o.shape) for v, o in zip(enc.state_dict().values(), old,
                                                                strict=True))


@pytest.mark.parametrize("rows", [True, False])
def test_plane_tv_matches_a_float64_reference_and_the_torch_path(rows):
    """The compiled plane TV against float64 autograd of its definition (the mean of squared
    first differences along the columns, and the rows with ``rows``) and against the torch path
    it replaces on the CPU (``squared_difference_mean``): its gradient takes the same float32
    operations in the same order, so a training run's numbers do not move."""
    plane = _planes([(7, 11)], 5, seed=3)[0].detach()
    fast = plane.clone(memory_format=torch.channels_last).requires_grad_()
    value = plane_tv(fast, rows)
    value.backward()
    ref = plane.double().requires_grad_()
    want = ref.diff(dim=-1).square().mean() + (ref.diff(dim=-2).square().mean() if rows else 0.0)
    want.backward()
    assert value.dtype == torch.float32
    assert float(value) == pytest.approx(float(want), rel=1e-6)
    torch.testing.assert_close(fast.grad.double(), ref.grad, rtol=1e-5, atol=1e-7)
    assert fast.grad.is_contiguous(memory_format=torch.channels_last)
    torch_path = plane.clone(memory_format=torch.channels_last).requires_grad_()
    (squared_difference_mean(torch_path, -1)
     + (squared_difference_mean(torch_path, -2) if rows else 0.0)).backward()
    torch.testing.assert_close(fast.grad, torch_path.grad, rtol=0, atol=0)


def test_plane_tv_of_a_constant_plane_is_zero_and_off_the_cpu_path_refused():
    flat = torch.full((1, 3, 4, 6), 0.7).contiguous(memory_format=torch.channels_last)
    flat.requires_grad_()
    value = plane_tv(flat, True)
    value.backward()
    assert float(value) == 0.0 and not bool(flat.grad.any())
    with pytest.raises(ValueError, match="float32 CPU plane"):
        plane_tv(flat.detach().double(), True)


def test_the_encodings_tv_is_the_sum_of_its_planes_tv():
    enc = _varied_encoding(8, 5, (1, 2), 4)
    want = sum(squared_difference_mean(p, -1) + (squared_difference_mean(p, -2) if b != 3 else 0.0)
               for p, (_, b) in zip(enc.views(), enc.plane_pairs, strict=True))
    assert float(enc.regularizers()["tv"]) == pytest.approx(float(want), rel=1e-6)

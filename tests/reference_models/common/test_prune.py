"""``RenderConfig.prune_weight``: the field skipped at final samples the proposal gives no
weight, held to the readable reference (the whole field looked up, those densities set to 0)."""

from dataclasses import replace

import pytest
import torch

import reference_models.common.model as model_mod
from reference_models.common.encodings import PlaneEncoding
from reference_models.common.model import DynamicRadianceModel, RayBatch, RenderConfig, sample_mask
from reference_models.common.sampling import outer_mass

RTOL, ATOL = 1e-5, 1e-6


def _model(prune: float) -> DynamicRadianceModel:
    torch.manual_seed(0)
    cfg = RenderConfig(proposal_samples=(32,), final_samples=16, proposal_resolution=(16,), hidden=16,
                       prune_weight=prune)
    net = DynamicRadianceModel(PlaneEncoding(16, 4, (1, 2), 8), torch.tensor([[-2.0] * 3, [2.0] * 3]),
                               4, cfg)
    with torch.no_grad():  # a peaked proposal: a dense slab around x = 0, empty elsewhere
        for p in net.proposals[0].views():
            if p.shape[-1] == 16 and p.shape[-2] == 16:
                p[..., :, 6:10] += 3.0
        net.proposal_heads[0].bias.fill_(-6.0)
        net.proposal_heads[0].weight.fill_(1.0)
    return net


def _rays(n: int = 64) -> RayBatch:
    g = torch.Generator().manual_seed(1)
    o = torch.tensor([-5.0, 0.0, 0.0]) + 0.5 * torch.randn(n, 3, generator=g)
    d = torch.nn.functional.normalize(torch.tensor([1.0, 0.0, 0.0]) + 0.1 * torch.randn(n, 3, generator=g), dim=-1)
    return RayBatch(o, d, torch.rand(n, generator=g))


def _reference(net: DynamicRadianceModel, rays: RayBatch, training: bool) -> torch.Tensor:
    """The pruned rendering the long way: every sample looked up, pruned densities zeroed."""
    pruned, full = net.config, replace(net.config, prune_weight=0.0)
    original = net.density_and_color
    masks = []

    def zeroed(coords, dirs, bf16=False):  # noqa: ANN001, ANN202
        dens, color = original(coords, dirs, bf16)
        return dens * masks[-1].view(-1), color

    rendered = []
    orig_resample = model_mod.resample_edges

    def resample(edges, w, n, jitter, **kw):  # noqa: ANN001, ANN202
        out = orig_resample(edges, w, n, jitter, **kw)
        masks.append(sample_mask(out, edges, w, pruned.prune_weight))
        return out

    model_mod.resample_edges, net.density_and_color, net.config = resample, zeroed, full
    try:
        rendered.append(net.render(rays, training=training, generator=torch.Generator().manual_seed(2)))
    finally:
        model_mod.resample_edges, net.config = orig_resample, pruned
        del net.density_and_color
    return rendered[0], masks[-1]


@pytest.mark.parametrize("training", [False, True])
def test_pruned_rendering_matches_the_zeroed_reference(training):
    net = _model(1e-4)
    rays = _rays()
    fast = net.render(rays, training=training, generator=torch.Generator().manual_seed(2))
    net.config = replace(net.config, prune_weight=1e-4)
    ref, mask = _reference(net, rays, training)
    assert 0 < mask.sum() < mask.numel()  # the peaked proposal prunes some, not all
    torch.testing.assert_close(fast.rgb, ref.rgb, rtol=RTOL, atol=ATOL)
    torch.testing.assert_close(fast.depth, ref.depth, rtol=RTOL, atol=ATOL)
    if training:
        for k in fast.losses:
            torch.testing.assert_close(fast.losses[k], ref.losses[k], rtol=RTOL, atol=ATOL)


def test_pruned_gradients_match_the_reference():
    net = _model(1e-4)
    rays = _rays()
    out = net.render(rays, training=True, generator=torch.Generator().manual_seed(2))
    fast = torch.autograd.grad(out.rgb.square().sum(), list(net.encoding.parameters()))
    ref, _ = _reference(net, rays, True)
    slow = torch.autograd.grad(ref.rgb.square().sum(), list(net.encoding.parameters()))
    for a, b in zip(fast, slow, strict=True):
        torch.testing.assert_close(a, b, rtol=RTOL, atol=ATOL)


def test_outer_mass_bounds_and_sums():
    g = torch.Generator().manual_seed(3)
    pe = torch.rand(5, 9, generator=g).sort(-1).values
    pe[:, 0], pe[:, -1] = 0.0, 1.0
    pw = torch.rand(5, 8, generator=g)
    e = torch.linspace(0, 1, 5).expand(5, 5).contiguous()
    m = outer_mass(e, pe, pw)
    # each final bin's outer mass covers at least the proposal mass strictly inside it, at most all
    assert (m >= -1e-6).all() and (m <= pw.sum(-1, keepdim=True) + 1e-6).all()
    assert (m.sum(-1) >= pw.sum(-1) - 1e-5).all()  # the bins cover [0, 1]: nothing is lost

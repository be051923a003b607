"""Rays against the scene generator's cameras; contraction; sampling and losses against slow
references (loops, brute force)."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_models.common.rays import contract, pixel_rays, spacing_to_distance
from reference_models.common.sampling import (
    distortion_loss,
    interlevel_loss,
    render_weights,
    resample_edges,
    stratified_edges,
)
from reference_models.scenes import Camera, look_at


def test_pixel_rays_match_the_generator_cameras():
    cam = Camera.from_fov("c", 12, 7, 70.0, look_at((3.0, -2.0, 1.5), (0.0, 0.5, 1.0)))
    dirs, _ = cam.ray_grid(1)  # the generator's own rays through pixel centres
    rows, cols = torch.meshgrid(torch.arange(7), torch.arange(12), indexing="ij")
    n = rows.numel()
    c2w = torch.tensor(cam.c2w, dtype=torch.float32).expand(n, 4, 4)
    k = torch.tensor([cam.fx, cam.fy, cam.cx, cam.cy], dtype=torch.float32).expand(n, 4)
    o, d = pixel_rays(c2w, k, rows.reshape(-1), cols.reshape(-1))
    np.testing.assert_allclose(d.numpy(), dirs.reshape(-1, 3), atol=1e-6)
    np.testing.assert_allclose(o.numpy(), np.broadcast_to(cam.centre, (n, 3)), atol=1e-6)


def test_contract_inside_is_affine_outside_is_bounded():
    box = torch.tensor([[-2.0, -1.0, 0.0], [2.0, 1.0, 4.0]])
    inside = torch.tensor([[0.0, 0.0, 2.0], [2.0, 1.0, 4.0], [-1.0, 0.5, 1.0]])
    np.testing.assert_allclose(contract(inside, box).numpy(), [[0, 0, 0], [0.5, 0.5, 0.5], [-0.25, 0.25, -0.25]])
    far = torch.tensor([[1e6, 0.0, 2.0], [0.0, -1e6, 2.0], [4.0, 0.0, 2.0]])
    out = contract(far, box).numpy()
    np.testing.assert_allclose(out[:2], [[1, 0, 0], [0, -1, 0]], atol=1e-5)
    np.testing.assert_allclose(out[2], [0.75, 0, 0])  # |p| = 2 -> (2 - 1/2) / 2


def test_spacing_is_monotone_and_hits_the_ends():
    s = torch.linspace(0, 1, 101)
    t = spacing_to_distance(s, 0.1, 10.0, 1000.0)
    assert torch.all(t[1:] > t[:-1])
    np.testing.assert_allclose([t[0], t[50], t[-1]], [0.1, 10.0, 1000.0], rtol=1e-5)


def _weights_loop(density, deltas):
    out = np.zeros_like(density)
    for r in range(density.shape[0]):
        trans = 1.0
        for i in range(density.shape[1]):
            alpha = 1 - np.exp(-density[r, i] * deltas[r, i])
            out[r, i] = trans * alpha
            trans *= 1 - alpha
    return out


def test_render_weights_match_a_loop(rng):
    density = rng.uniform(0, 3, (4, 9))
    deltas = rng.uniform(0.01, 0.5, (4, 9))
    got = render_weights(torch.tensor(density), torch.tensor(deltas)).numpy()
    np.testing.assert_allclose(got, _weights_loop(density, deltas), rtol=1e-10, atol=1e-12)


def test_resampling_follows_the_weights():
    edges = stratified_edges(2, 10, jitter=False)
    w = torch.zeros(2, 10)
    w[:, 3] = 1.0
    new = resample_edges(edges, w, 40, jitter=False, pad=0.0)
    assert torch.all(new[:, 1:] >= new[:, :-1])
    inside = ((new >= 0.3 - 1e-6) & (new <= 0.4 + 1e-6)).float().mean()
    assert inside > 0.9
    jit = resample_edges(edges, w, 40, jitter=True, generator=torch.Generator().manual_seed(0))
    assert jit.min() >= 0 and jit.max() <= 1


def test_interlevel_loss_zero_when_the_proposal_bounds_the_weights(rng):
    edges = stratified_edges(3, 8, jitter=False)
    w = torch.tensor(rng.dirichlet(np.ones(8), 3))
    assert float(interlevel_loss(edges, w, edges, w)) == pytest.approx(0.0, abs=1e-12)
    assert float(interlevel_loss(edges, w, edges, torch.zeros_like(w))) > 0.1


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 12), st.integers(0, 10_000))
def test_distortion_loss_matches_brute_force(n, seed):
    r = np.random.default_rng(seed)
    edges = np.sort(r.uniform(0, 1, (2, n + 1)), axis=-1)
    w = r.uniform(0, 1, (2, n))
    mid, width = 0.5 * (edges[:, 1:] + edges[:, :-1]), np.diff(edges, axis=-1)
    brute = [(w[k][:, None] * w[k][None] * np.abs(mid[k][:, None] - mid[k][None])).sum()
             + (w[k] ** 2 * width[k]).sum() / 3 for k in range(2)]
    got = float(distortion_loss(torch.tensor(edges), torch.tensor(w)))
    assert got == pytest.approx(np.mean(brute), rel=1e-9, abs=1e-12)

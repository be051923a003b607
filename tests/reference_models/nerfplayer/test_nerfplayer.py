"""NeRFPlayer end to end on the tiny scene, and the temporal hash grid against a slow reference."""

import numpy as np
import torch

from reference_models.nerfplayer import SPEC, NeRFPlayerConfig, TemporalHashEncoding
from tests.reference_models.common.tiny import check_tiny_run


def test_tiny_run_beats_a_constant_colour_and_scores(tiny_data, tmp_path):
    out = check_tiny_run(SPEC, tiny_data, tmp_path / "run")
    print(f"\nnerfplayer tiny: eval {out['log'][-1]['eval_psnr']:.2f} dB vs constant "
          f"{out['baseline']:.2f} dB")


def _reference(enc: TemporalHashEncoding, x: np.ndarray) -> np.ndarray:
    """One point at a time, with loops: trilinear over corners, window blend in time."""
    cfg, table = enc.cfg, enc.table.detach().numpy()
    out = []
    for level in range(cfg.levels):
        res, rows, off = int(enc.resolution[level]), int(enc.rows[level]), int(enc.offsets[level])
        p = np.clip((x[:3] + 1) / 2, 0, 1) * res
        base = np.minimum(np.floor(p).astype(np.int64), res - 1)
        frac = p - base
        s = np.clip((x[3] + 1) / 2, 0, 1) * (enc.knots - 1)
        k = min(int(np.floor(s)), enc.knots - 2)
        a = s - k
        feat = np.zeros(cfg.features)
        for cx in (0, 1):
            for cy in (0, 1):
                for cz in (0, 1):
                    c = base + (cx, cy, cz)
                    w = np.prod(np.where((cx, cy, cz), frac, 1 - frac))
                    if (res + 1) ** 3 <= 2 ** cfg.log2_table:
                        row = c[0] + (res + 1) * (c[1] + (res + 1) * c[2])
                    else:
                        row = (c[0] ^ (c[1] * 2654435761) ^ (c[2] * 805459861)) % rows
                    entry = table[off + row]
                    feat += w * ((1 - a) * entry[k:k + cfg.features] + a * entry[k + 1:k + 1 + cfg.features])
        out.append(feat)
    return np.concatenate(out)


def test_matches_a_slow_reference(rng):
    cfg = NeRFPlayerConfig(levels=3, features=2, log2_table=9, base_resolution=4, max_resolution=16)
    torch.manual_seed(0)
    enc = TemporalHashEncoding(cfg, n_frames=5)
    with torch.no_grad():
        enc.table.normal_()
    assert enc.dense.tolist() == [True, False, False]  # 5^3 fits 2^9 rows, 9^3 does not
    x = rng.uniform(-1, 1, (20, 4))
    x[0, 3], x[1, 3] = -1.0, 1.0  # the first and last frame
    got = enc(torch.tensor(x, dtype=torch.float32)).detach().numpy()
    want = np.stack([_reference(enc, xi) for xi in x])
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)


def test_piecewise_linear_in_time_with_knots_on_frames():
    enc = TemporalHashEncoding(NeRFPlayerConfig(levels=2, base_resolution=2, max_resolution=4), 5)
    with torch.no_grad():
        enc.table.normal_()
        t = torch.linspace(-1, 1, 33)
        f = enc(torch.cat([torch.full((33, 3), 0.3), t[:, None]], -1))
    second = f[2:] - 2 * f[1:-1] + f[:-2]
    knots = {8, 16, 24}  # t index of frames 1..3 (frames at every 8th sample)
    bends = {i + 1 for i in range(31) if second[i].abs().max() > 1e-4}
    assert bends <= knots and bends  # linear between frames, bends only on them
    assert enc.channels == 2 + 5 - 1


def test_window_regulariser_and_size():
    enc = TemporalHashEncoding(NeRFPlayerConfig(levels=2, log2_table=8, base_resolution=2,
                                                max_resolution=8), 4)
    with torch.no_grad():
        enc.table.fill_(1.0)
        enc(torch.zeros(5, 4))
        assert float(enc.regularizers()["window_l1"]) == 0.0  # constant in time: no penalty
    assert enc.table.shape == (27 + 256, 2 + 4 - 1)  # level 0 dense (3^3), level 1 hashed


def test_one_time_lookup_equals_the_training_lookup(rng):
    """Rendering a view (one time, no gradient) blends the table once; same features."""
    cfg = NeRFPlayerConfig(levels=3, features=2, log2_table=9, base_resolution=4, max_resolution=16)
    enc = TemporalHashEncoding(cfg, n_frames=5)
    with torch.no_grad():
        enc.table.normal_()
    x = torch.tensor(rng.uniform(-1, 1, (50, 4)), dtype=torch.float32)
    for t in (-1.0, 0.1, 1.0):
        x[:, 3] = t
        with torch.no_grad():
            fast = enc(x)
        slow = enc(x).detach()  # with gradients: the per-point window path
        np.testing.assert_allclose(fast.numpy(), slow.numpy(), rtol=1e-6, atol=1e-6)

"""The ``seed`` presets: the seed study's budget and model sizes (built on the meta device, no
memory), and the same structure at a tiny scale training a couple of steps on the CPU."""

from dataclasses import replace

import torch

from reference_models.common.seed import SEED_RENDER, SEED_TRAIN
from reference_models.common.train import load_run, render_run, train
from reference_models.kplanes import SPEC as KPLANES
from reference_models.nerfplayer import SPEC as NERFPLAYER
from reference_models.study import MODELS, PRESETS, _check_device

SCENE = {"n_frames": 24, "box": [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]}


def _meta_encoding(spec):
    with torch.device("meta"):
        return spec.build_encoding(spec.presets["seed"][0], SCENE)


def test_the_budget_is_the_seed_studys():
    for spec in (KPLANES, NERFPLAYER):
        _, render, cfg = spec.presets["seed"]
        assert render == SEED_RENDER and cfg == SEED_TRAIN
    assert (SEED_TRAIN.iters, SEED_TRAIN.batch_rays, SEED_TRAIN.lr) == (30_000, 4096, 1e-2)
    assert SEED_RENDER.proposal_samples == (256, 128) and SEED_RENDER.final_samples == 48
    assert SEED_RENDER.proposal_resolution == (128, 256)
    study = PRESETS["seed"]
    assert study.iters is None and all(study.size_of(m) == "seed" for m in MODELS)
    assert all(study.overrides_of(m) == {} for m in MODELS)  # the model presets' budget


def test_kplanes_seed_planes_run_from_2_6_to_2_11_cells():
    enc = _meta_encoding(KPLANES)
    space = [tuple(p.shape[-2:]) for p, (a, b) in zip(enc.views(), enc.plane_pairs, strict=True)
             if b != 3]
    assert sorted({s[0] for s in space}) == [2 ** k for k in range(6, 12)]
    assert all(p.shape[1] == 16 for p in enc.views()) and enc.out_dim == 16 * 6
    assert round(sum(p.numel() for p in enc.parameters()) / 1e6) == 273


def test_nerfplayer_seed_has_2_20_rows_of_64_channels():
    """Levels of 16 to 2,048 cells: the six coarsest (16, 22, 30, 42, 58, 80 cells) are dense
    (17^3 + ... + 81^3 = 863,198 corners), the ten finer hashed into 2^20 rows each."""
    enc = _meta_encoding(NERFPLAYER)
    assert enc.channels == 64 and enc.out_dim == 16 * 2
    assert tuple(enc.table.shape) == (10 * 2 ** 20 + 863_198, 64)
    assert round(sum(p.numel() for p in enc.parameters()) / 1e6) == 726


def test_the_seed_preset_needs_no_cpu_clock(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert _check_device("auto", PRESETS["seed"], MODELS) == "cuda"


def test_the_seed_structure_trains_and_renders_at_a_tiny_scale(tiny_data, tmp_path):
    """Every seed setting but the field's cell counts (and the rays per step): six K-Planes
    scales, 16 NeRFPlayer levels of 64 channels, two proposal levels of 256 + 128 samples."""
    scaled = {"kplanes": replace(KPLANES.presets["seed"][0], resolution=2, max_resolution=64),
              "nerfplayer": replace(NERFPLAYER.presets["seed"][0], log2_table=10,
                                    base_resolution=4, max_resolution=64)}
    for spec in (KPLANES, NERFPLAYER):
        small = replace(spec, presets={"seed-scaled": (scaled[spec.name], SEED_RENDER,
                                                       SEED_TRAIN)})
        rec = train(small, tiny_data, tmp_path / spec.name, size="seed-scaled", iters=2,
                    sampling="isg", progress=False,
                    overrides={"batch_rays": 32, "eval_views": 1, "warmup": 1})
        assert rec["step"] == 2 and torch.isfinite(torch.tensor(rec["loss"]))
        cfg, model, _ = load_run(tmp_path / spec.name, small)
        assert cfg["render_config"]["proposal_samples"] == [256, 128]
        assert len(model.proposals) == 2
        assert len(render_run(small, tmp_path / spec.name, progress=False, every=8)) == 1

"""The shared training loop: checkpoints resume exactly, logs, CLI errors (exit 2)."""

import json

import pytest
import torch

import reference_models.common.train as train_mod
from dynaeval.errors import InputError
from reference_models.common.cli import main
from reference_models.common.train import load_run, render_run, train
from reference_models.kplanes import SPEC
from reference_models.nerfplayer import SPEC as NERFPLAYER

FAST = {"log_every": 2, "checkpoint_every": 3, "batch_rays": 64}


def test_resume_continues_exactly(tiny_data, tmp_path, monkeypatch):
    train(SPEC, tiny_data, tmp_path / "straight", size="tiny", iters=6, progress=False, overrides=FAST)
    real_save = train_mod._atomic_save

    def crash_after_first_checkpoint(obj, path):
        real_save(obj, path)
        raise KeyboardInterrupt

    monkeypatch.setattr(train_mod, "_atomic_save", crash_after_first_checkpoint)
    with pytest.raises(KeyboardInterrupt):
        train(SPEC, tiny_data, tmp_path / "resumed", size="tiny", iters=6, progress=False, overrides=FAST)
    monkeypatch.setattr(train_mod, "_atomic_save", real_save)
    assert torch.load(tmp_path / "resumed" / "checkpoint.pt", weights_only=False)["step"] == 3
    train(SPEC, tiny_data, tmp_path / "resumed", resume=True, progress=False)
    _, a, ca = load_run(tmp_path / "straight", SPEC)
    _, b, cb = load_run(tmp_path / "resumed", SPEC)
    assert ca["step"] == cb["step"] == 6
    for (name, pa), pb in zip(a.state_dict().items(), b.state_dict().values(), strict=True):
        torch.testing.assert_close(pa, pb, rtol=0, atol=0, msg=name)
    log = [json.loads(x) for x in (tmp_path / "resumed" / "log.jsonl").read_text().splitlines()]
    assert [r["step"] for r in log] == [2, 4, 6]
    assert log[-1]["train_seconds"] > log[0]["train_seconds"] and "eval_psnr" in log[-1]
    cfg = json.loads((tmp_path / "resumed" / "config.json").read_text())
    assert cfg["model"] == "kplanes" and cfg["train_config"]["batch_rays"] == 64


def test_errors(tiny_data, tmp_path):
    run = tmp_path / "run"
    train(SPEC, tiny_data, run, size="tiny", iters=1, progress=False, overrides={"batch_rays": 16})
    with pytest.raises(InputError, match="already holds a checkpoint; pass --resume"):
        train(SPEC, tiny_data, run, size="tiny", iters=1, progress=False)
    with pytest.raises(InputError, match="trained with model 'kplanes', not 'nerfplayer'"):
        render_run(NERFPLAYER, run)
    with pytest.raises(InputError, match="not a training run"):
        render_run(SPEC, tmp_path)
    with pytest.raises(InputError, match="every must be >= 1"):
        render_run(SPEC, run, every=0)
    # a checkpoint of the planes' old layout: its weights load, its Adam state is refused clearly
    ckpt = torch.load(run / "checkpoint.pt", weights_only=False)
    ckpt["optimizer"]["state"][0]["exp_avg"] = ckpt["optimizer"]["state"][0]["exp_avg"].permute(0, 3, 1, 2)
    torch.save(ckpt, run / "checkpoint.pt")
    with pytest.raises(InputError, match="optimiser state is not shaped like the model"):
        train(SPEC, tiny_data, run, resume=True, progress=False)
    written = render_run(SPEC, run, progress=False, every=3)
    assert [p.name for p in written] == ["0000.png", "0003.png", "0006.png"]
    with pytest.raises(InputError, match="unknown size 'huge'"):
        train(SPEC, tiny_data, tmp_path / "x", size="huge")
    with pytest.raises(InputError, match="iters must be >= 1"):
        train(SPEC, tiny_data, tmp_path / "x", size="tiny", iters=0)
    with pytest.raises(InputError, match="sampling must be one of"):
        train(SPEC, tiny_data, tmp_path / "x", size="tiny", sampling="random")


def test_cli_exit_codes(tiny_data, tmp_path, capsys):
    assert main(SPEC, ["render", str(tmp_path), "--quiet"]) == 2
    assert "not a training run" in capsys.readouterr().err
    assert main(SPEC, ["train", str(tmp_path / "nope"), "--out", str(tmp_path / "r"), "--quiet"]) == 2
    assert "dataset folder does not exist" in capsys.readouterr().err


def test_time_budget_stops_and_anneals(tiny_data, tmp_path):
    rec = train(SPEC, tiny_data, tmp_path / "r", size="tiny", iters=1000, progress=False,
                overrides={"minutes": 1e-9, "batch_rays": 16})
    assert rec["step"] == 1 and "eval_psnr" in rec  # over budget after the first step
    rec = train(SPEC, tiny_data, tmp_path / "c", size="tiny", iters=1000, progress=False,
                overrides={"minutes": 1e-9, "batch_rays": 16, "clock": "cpu"})
    assert rec["step"] == 1 and 0 < rec["train_cpu_seconds"]
    with pytest.raises(InputError, match="clock must be 'wall' or 'cpu'"):
        train(SPEC, tiny_data, tmp_path / "d", size="tiny", overrides={"clock": "gpu"})


def test_schedule_warms_up_then_decays_with_steps_or_time():
    cfg = train_mod.TrainConfig(iters=100, warmup=10, minutes=2.0)
    assert train_mod._lr_factor(0, 0.0, cfg) == pytest.approx(0.1)
    assert train_mod._lr_factor(10, train_mod._progress(10, 0.0, cfg), cfg) == pytest.approx(1.0)
    assert train_mod._progress(20, 90.0, cfg) == pytest.approx(0.75)  # time is further along
    assert train_mod._progress(50, 1e9, cfg) == 1.0
    assert train_mod._lr_factor(99, 1.0, cfg) == pytest.approx(0.0, abs=1e-12)


def test_nothing_to_render_without_eval_views(tmp_path):
    import cv2
    import numpy as np

    from reference_models.common.baseline import write_constant_baseline

    frames = []
    for i in range(2):
        cv2.imwrite(str(tmp_path / f"f{i}.png"), np.full((6, 8, 3), 40 * i, np.uint8))
        c2w = np.eye(4)
        c2w[0, 3] = i
        frames.append({"file_path": f"f{i}.png", "transform_matrix": c2w.tolist(), "time": float(i)})
    (tmp_path / "transforms.json").write_text(json.dumps({"fl_x": 8.0, "frames": frames}))
    train(SPEC, tmp_path, tmp_path / "run", size="tiny", iters=1, progress=False,
          overrides={"batch_rays": 8})
    with pytest.raises(InputError, match="names no evaluation views"):
        render_run(SPEC, tmp_path / "run")
    with pytest.raises(InputError, match="names no evaluation views"):
        write_constant_baseline(tmp_path, tmp_path / "base")


def test_bad_model_settings():
    from reference_models.common.encodings import PlaneEncoding
    from reference_models.common.model import DynamicRadianceModel, RenderConfig

    with pytest.raises(ValueError, match="planes must be one of"):
        PlaneEncoding(4, 3, (1,), 2, planes="diagonal")
    with pytest.raises(ValueError, match="one proposal resolution per proposal level"):
        DynamicRadianceModel(PlaneEncoding(4, 3, (1,), 2), torch.tensor([[-1.0] * 3, [1.0] * 3]), 3,
                             RenderConfig(proposal_samples=(8, 4), proposal_resolution=(8,)))


def test_static_warmup_keeps_time_planes_at_one_then_uses_them(tiny_data, tmp_path):
    warm = {**FAST, "static_warmup": 0.5, "log_every": 1}
    train(SPEC, tiny_data, tmp_path / "r", size="tiny", iters=6, sampling="isg", progress=False,
          overrides=warm)
    log = [json.loads(x) for x in (tmp_path / "r" / "log.jsonl").read_text().splitlines()]
    assert [r["static"] for r in log] == [True] * 3 + [False] * 3
    assert [r["sampling"] for r in log] == ["uniform"] * 3 + ["isg"] * 3
    train(SPEC, tiny_data, tmp_path / "w", size="tiny", iters=3, progress=False, overrides=warm | {
        "static_warmup": 0.99})
    _, model, _ = load_run(tmp_path / "w", SPEC)
    times = [p for p, (_, b) in zip(model.encoding.views(), model.encoding.plane_pairs, strict=True)
             if b == 3]
    assert times and all(bool((p == 1.0).all()) for p in times)  # untouched: exactly one
    with pytest.raises(InputError, match="static_warmup needs a field with a static part"):
        train(NERFPLAYER, tiny_data, tmp_path / "n", size="tiny", iters=1, overrides=warm)
    with pytest.raises(InputError, match=r"static_warmup must be in \[0, 1\]"):
        train(SPEC, tiny_data, tmp_path / "n", size="tiny", iters=1, overrides={"static_warmup": 1.5})


def test_proposals_train_on_the_first_rays_only_and_place_every_ray_s_samples(tiny_data):
    from reference_models.common.model import RayBatch

    torch.manual_seed(0)
    model = _tiny_model(tiny_data)
    rays = RayBatch(torch.zeros(8, 3), torch.nn.functional.normalize(torch.randn(8, 3), dim=-1),
                    torch.rand(8))
    rgb = {}
    for n in (None, 3, 0):
        model.zero_grad(set_to_none=True)
        out = model.render(rays, training=True, generator=torch.Generator().manual_seed(1),
                           proposal_rays=n)
        assert ("interlevel" in out.losses) == (n != 0) and "distortion" in out.losses
        (out.rgb.sum() + sum(out.losses.values())).backward()
        got = [p.grad is not None and bool(p.grad.abs().sum() > 0) for p in model.proposals.parameters()]
        assert got and all(g == (n != 0) for g in got)
        assert all(p.grad is not None for p in model.density_net.parameters())
        rgb[n] = out.rgb.detach()
    # the same samples: the proposals' forward does not depend on autograd
    torch.testing.assert_close(rgb[3], rgb[None], rtol=0, atol=1e-6)
    torch.testing.assert_close(rgb[0], rgb[None], rtol=0, atol=1e-6)


def _tiny_model(tiny_data, spec=SPEC):
    from reference_models.common.data import load_dataset
    from reference_models.common.train import build_model, scene_info

    model_cfg, render_cfg, _ = spec.presets["tiny"]
    return build_model(spec, model_cfg, render_cfg, scene_info(load_dataset(tiny_data)))


def test_regularisers_every_k_steps_at_k_times_the_weight(tiny_data, tmp_path, monkeypatch):
    from reference_models.common.model import DynamicRadianceModel

    seen = []
    tv = torch.tensor(1.0, requires_grad=True)

    def fake(self):
        seen.append(True)
        return {"tv": tv}

    monkeypatch.setattr(DynamicRadianceModel, "regularizers", fake)
    over = {**FAST, "log_every": 1, "regularize_every": 3, "tv": 0.5}
    train(SPEC, tiny_data, tmp_path / "r", size="tiny", iters=7, progress=False, overrides=over)
    assert len(seen) == 3  # steps 0, 3, 6
    assert tv.grad is not None and float(tv.grad) == pytest.approx(3 * 3 * 0.5)  # 3 steps x 3 x weight
    with pytest.raises(InputError, match="regularize_every and proposal_rays_every must be >= 1"):
        train(SPEC, tiny_data, tmp_path / "x", size="tiny", iters=1, overrides={"proposal_rays_every": 0})


def test_bfloat16_mlps_stay_close_to_float32(tiny_data):
    from reference_models.common.model import cpu_has_bfloat16

    torch.manual_seed(0)
    model = _tiny_model(tiny_data)
    coords = torch.rand(500, 4) * 2 - 1
    dirs = torch.nn.functional.normalize(torch.randn(500, 3), dim=-1)
    d32, c32 = model.density_and_color(coords, dirs)
    d16, c16 = model.density_and_color(coords, dirs, bfloat16_mlps=True)
    assert d16.dtype == c16.dtype == torch.float32
    # bfloat16 keeps 8 bits of mantissa: ~0.4 % per rounding, a few roundings deep
    torch.testing.assert_close(d16, d32, rtol=0.03, atol=1e-3)
    torch.testing.assert_close(c16, c32, rtol=0.0, atol=0.01)
    if cpu_has_bfloat16():
        assert not torch.equal(c16, c32)  # the bfloat16 path really ran
    else:
        assert torch.equal(c16, c32)  # no native bfloat16: float32


def test_the_bar_follows_what_ends_the_run(tiny_data, tmp_path, capsys):
    """With a time budget the bar counts the budget's seconds (a 30-minute run of at most 100,000
    steps showed 6.5 hours left); without one, steps."""
    from tqdm import tqdm

    timed = train_mod.TrainConfig(iters=100_000, minutes=0.5, clock="cpu")
    bar = train_mod._progress_bar(tqdm, timed, 0, 0.0, show=True)
    assert (bar.total, bar.unit) == (30, "cpu-s")
    train_mod._advance(bar, timed, 10, 15.0)
    assert bar.n == 15  # half the budget used after 10 of 100,000 steps
    stepped = train_mod.TrainConfig(iters=80)
    bar.close()
    bar = train_mod._progress_bar(tqdm, stepped, 5, 99.0, show=True)
    train_mod._advance(bar, stepped, 40, 99.0)
    assert (bar.total, bar.n, bar.unit) == (80, 40, "it")
    bar.close()
    capsys.readouterr()
    train(SPEC, tiny_data, tmp_path / "r", size="tiny", iters=1000, progress=True,
          overrides={"minutes": 1e-9, "batch_rays": 16, "clock": "cpu"})
    assert "cpu-s" in capsys.readouterr().err


@pytest.mark.parametrize("spec", [SPEC, NERFPLAYER], ids=["kplanes", "nerfplayer"])
def test_in_place_relu_changes_no_value_or_gradient(tiny_data, spec):
    """The decoder MLPs' ReLUs write over their Linear's output (a render 2.38 -> 1.74 CPU s a
    view): densities, colours and every parameter's gradient equal the out-of-place network's."""
    torch.manual_seed(0)
    model = _tiny_model(tiny_data, spec)
    relus = [m for m in model.modules() if isinstance(m, torch.nn.ReLU)]
    assert relus and all(m.inplace for m in relus)
    coords = torch.rand(300, 4) * 2 - 1
    dirs = torch.nn.functional.normalize(torch.randn(300, 3), dim=-1)

    def run(inplace: bool) -> list[torch.Tensor]:
        for m in relus:
            m.inplace = inplace
        model.zero_grad()
        density, color = model.density_and_color(coords, dirs)
        (density.sum() + color.square().sum()).backward()
        return [density.detach(), color.detach()] + [p.grad.clone() for p in model.parameters()
                                                     if p.grad is not None]

    for a, b in zip(run(True), run(False), strict=True):
        assert torch.equal(a, b)

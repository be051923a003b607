"""The pre-trained empty stadium: trained once on the clip's model, the start of every run."""

import json

import pytest
import torch

from dynaeval.errors import InputError
from reference_models.common import train as train_module
from reference_models.common.stadium import train_stadium
from reference_models.common.train import load_run, train
from reference_models.kplanes import SPEC
from reference_models.scenes import render_scene

SIZE = "tiny-dynbox-fine"


@pytest.fixture(scope="module")
def stadium(tiny_data, tmp_path_factory):
    root = tmp_path_factory.mktemp("stadium")
    empty = root / "empty"
    render_scene("single-player-closeup", empty, size="tiny", seed=0, frames=1,
                 hide=("person", "ball"))
    run = root / "run"
    train_stadium(SPEC, tiny_data, empty, run, size=SIZE, iters=12, progress=False)
    return empty, run


def test_the_stadium_is_the_clips_model_with_its_time_planes_untouched(tiny_data, stadium):
    _, run = stadium
    cfg = json.loads((run / "config.json").read_text())
    clip = train(SPEC, tiny_data, run.parent / "clip-cfg", size=SIZE, iters=1, progress=False)
    assert clip  # the clip run's config: same scene (box, 8 frames, moving box)
    assert cfg["scene"] == json.loads((run.parent / "clip-cfg" / "config.json").read_text())["scene"]
    assert cfg["scene"]["n_frames"] == 8 and cfg["train_config"]["static_warmup"] == 1.0
    _, model, _ = load_run(run, SPEC)
    factor = model.encoding.time.planes  # every plane of the moving box's factor starts at 1
    assert all(torch.equal(p, torch.ones_like(p)) for p in factor)
    static = model.encoding.static.planes
    fresh = load_run(run.parent / "clip-cfg", SPEC)[1].encoding.static.planes
    assert not all(torch.equal(a, b) for a, b in zip(static, fresh, strict=True))


def _by_hand(monkeypatch, weights, optimizer=None):
    """Build every model with ``weights`` and (when given) every optimiser from ``optimizer``,
    the stadium's Adam state with the parameters it never moved (second moment all zero) left
    out, as a user would do by hand."""
    build, make = train_module.build_model, train_module.make_optimizer

    def build_by_hand(*args, **kwargs):
        model = build(*args, **kwargs)
        model.load_state_dict(weights)
        return model

    def make_by_hand(model, cfg):
        optim = make(model, cfg)
        if optimizer is not None:
            state = {i: s for i, s in optimizer["state"].items() if s["exp_avg_sq"].any()}
            optim.load_state_dict({"state": state, "param_groups": optimizer["param_groups"]})
        return optim

    monkeypatch.setattr(train_module, "build_model", build_by_hand)
    monkeypatch.setattr(train_module, "make_optimizer", make_by_hand)


def _same_checkpoints(a, b):
    a = torch.load(a / "checkpoint.pt", weights_only=False)
    b = torch.load(b / "checkpoint.pt", weights_only=False)
    assert a["model"].keys() == b["model"].keys()
    assert all(torch.equal(a["model"][k], b["model"][k]) for k in a["model"])
    sa, sb = a["optimizer"]["state"], b["optimizer"]["state"]
    assert sa.keys() == sb.keys()
    assert all(torch.equal(sa[i][k], sb[i][k]) for i in sa for k in sa[i])


@pytest.mark.parametrize("carry", [True, False], ids=["weights-and-adam", "weights-only"])
def test_a_run_started_from_the_stadium_equals_one_given_its_state_by_hand(
        tiny_data, stadium, tmp_path, monkeypatch, carry):
    _, run = stadium
    over = {"init_optimizer": carry}
    train(SPEC, tiny_data, tmp_path / "a", size=SIZE, iters=6, sampling="isg", progress=False,
          init=run, overrides=over)
    saved = torch.load(run / "checkpoint.pt", weights_only=False)
    _by_hand(monkeypatch, saved["model"], saved["optimizer"] if carry else None)
    train(SPEC, tiny_data, tmp_path / "b", size=SIZE, iters=6, sampling="isg", progress=False,
          overrides=over)
    _same_checkpoints(tmp_path / "a", tmp_path / "b")
    init = json.loads((tmp_path / "a" / "config.json").read_text())["init"]
    assert init["run"] == str(run.resolve()) and init["step"] == 12
    assert len(init["checkpoint_sha256"]) == 64 and init["train_cpu_seconds"] > 0
    assert init["optimizer"] is carry


def test_the_first_step_continues_the_stadiums_adam_state(tiny_data, stadium, tmp_path):
    """The static planes' Adam steps count on from the stadium's (12 steps: a fresh optimiser
    would say 1); the planes the stadium never moved (the moving box's factor, the proposals'
    time planes) start fresh."""
    _, run = stadium
    train(SPEC, tiny_data, tmp_path / "r", size=SIZE, iters=1, sampling="isg", progress=False,
          init=run, overrides={"init_optimizer": True})
    cfg, model, ckpt = load_run(tmp_path / "r", SPEC)
    names = [n for n, _ in model.named_parameters()]
    stadium_state = torch.load(run / "checkpoint.pt", weights_only=False)["optimizer"]["state"]
    steps = {n: float(ckpt["optimizer"]["state"][i]["step"]) for i, n in enumerate(names)}
    assert steps["encoding.static.planes.0"] == float(stadium_state[0]["step"]) + 1 == 13
    fresh = cfg["init"]["optimizer_fresh"]
    assert cfg["init"]["optimizer"] is True and cfg["train_config"]["init_optimizer"] is True
    assert [n for n in names if n.startswith("encoding.time.")] == \
        [n for n in fresh if n.startswith("encoding.time.")] != []
    assert not any(n.startswith("encoding.static.") for n in fresh)
    assert all(steps[n] == 1 for n in fresh)


def test_a_stadium_without_adam_state_is_refused(tiny_data, stadium, tmp_path):
    import shutil

    from reference_models.common.cli import main

    _, run = stadium
    bare = tmp_path / "bare"
    shutil.copytree(run, bare)
    ckpt = torch.load(bare / "checkpoint.pt", weights_only=False)
    del ckpt["optimizer"]
    torch.save(ckpt, bare / "checkpoint.pt")
    with pytest.raises(InputError, match="holds none") as err:
        train(SPEC, tiny_data, tmp_path / "r", size=SIZE, iters=1, progress=False, init=bare,
              overrides={"init_optimizer": True})
    assert "checkpoint.pt" in str(err.value)
    args = ["train", str(tiny_data), "--out", str(tmp_path / "c"), "--size", SIZE, "--iters", "1",
            "--init", str(bare), "--quiet"]
    assert main(SPEC, [*args, "--carry-optimizer"]) == 2
    assert main(SPEC, args) == 0  # the weights only, the default
    assert json.loads((tmp_path / "c" / "config.json").read_text())["init"]["optimizer"] is False
    assert main(SPEC, ["train", str(tiny_data), "--out", str(tmp_path / "d"), "--size", SIZE,
                       "--carry-optimizer", "--quiet"]) == 2


def test_a_stadium_of_another_size_is_refused(tiny_data, stadium, tmp_path):
    _, run = stadium
    with pytest.raises(InputError, match="its size differs"):
        train(SPEC, tiny_data, tmp_path / "r", size="tiny-dynbox", iters=1, progress=False,
              init=run)


def test_a_stadium_filmed_by_other_cameras_is_refused(tiny_data, tmp_path):
    other = tmp_path / "other"
    render_scene("single-player-closeup", other, size="tiny", seed=1, frames=1,
                 hide=("person", "ball"))
    with pytest.raises(InputError, match="not placed like the clip's"):
        train_stadium(SPEC, tiny_data, other, tmp_path / "r", size=SIZE, iters=1, progress=False)


def test_a_model_without_a_static_part_has_no_stadium(tiny_data, stadium, tmp_path):
    from reference_models.nerfplayer import SPEC as NERFPLAYER

    empty, _ = stadium
    with pytest.raises(InputError, match="static_warmup needs a field with a static part"):
        train_stadium(NERFPLAYER, tiny_data, empty, tmp_path / "r", size="tiny", iters=1,
                      progress=False)


def test_the_cli_pre_trains_and_starts_from_a_stadium(tiny_data, stadium, tmp_path):
    from reference_models.common.cli import main

    empty, _ = stadium
    assert main(SPEC, ["stadium", str(tiny_data), str(empty), "--out", str(tmp_path / "s"),
                       "--size", "tiny", "--iters", "3", "--quiet"]) == 0
    assert main(SPEC, ["train", str(tiny_data), "--out", str(tmp_path / "r"), "--size", "tiny",
                       "--iters", "3", "--init", str(tmp_path / "s"), "--quiet"]) == 0
    assert main(SPEC, ["train", str(tiny_data), "--out", str(tmp_path / "r2"), "--size", "tiny",
                       "--iters", "3", "--init", str(tmp_path / "nothing"), "--quiet"]) == 2

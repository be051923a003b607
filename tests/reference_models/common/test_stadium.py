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


def test_a_run_started_from_the_stadium_equals_one_given_its_weights_by_hand(
        tiny_data, stadium, tmp_path, monkeypatch):
    _, run = stadium
    train(SPEC, tiny_data, tmp_path / "a", size=SIZE, iters=6, sampling="isg", progress=False,
          init=run)
    weights = torch.load(run / "checkpoint.pt", weights_only=False)["model"]
    build = train_module.build_model

    def by_hand(*args, **kwargs):
        model = build(*args, **kwargs)
        model.load_state_dict(weights)
        return model

    monkeypatch.setattr(train_module, "build_model", by_hand)
    train(SPEC, tiny_data, tmp_path / "b", size=SIZE, iters=6, sampling="isg", progress=False)
    a = torch.load(tmp_path / "a" / "checkpoint.pt", weights_only=False)["model"]
    b = torch.load(tmp_path / "b" / "checkpoint.pt", weights_only=False)["model"]
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    init = json.loads((tmp_path / "a" / "config.json").read_text())["init"]
    assert init["run"] == str(run.resolve()) and init["step"] == 12
    assert len(init["checkpoint_sha256"]) == 64 and init["train_cpu_seconds"] > 0


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

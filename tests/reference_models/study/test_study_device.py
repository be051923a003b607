"""The study's --device: checked before any work, recorded per run and in the report."""

from __future__ import annotations

import json

import pytest
import torch

from dynaeval.errors import InputError
from reference_models.study import PRESETS, main, run_study

NO_GPU = not torch.cuda.is_available()


@pytest.mark.skipif(not NO_GPU, reason="needs a machine without CUDA")
def test_cuda_without_a_gpu_is_exit_2_before_any_work(tmp_path, capsys):
    with pytest.raises(InputError, match=r"device 'cuda' asked for but torch.cuda.is_available"):
        run_study(tmp_path / "s", "tiny", device="cuda")
    assert main(["--preset", "tiny", "--out", str(tmp_path / "s"), "--device", "cuda", "-q"]) == 2
    assert "use --device cpu (or auto)" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()  # nothing rendered or trained


def test_an_unknown_device_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="device must be one of cpu, cuda, auto, got 'tpu'"):
        run_study(tmp_path / "s", "tiny", device="tpu")


def test_a_cpu_seconds_budget_on_cuda_is_refused_before_any_work(tmp_path, monkeypatch):
    """small-30min budgets CPU seconds; on a GPU that is no measure of training (a stand-in
    says CUDA is there: the check must come before anything touches the GPU)."""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    with pytest.raises(InputError, match="--clock cpu budgets process CPU seconds"):
        run_study(tmp_path / "s", "small-30min", device="auto")
    assert not (tmp_path / "s").exists()
    assert PRESETS["small-30min"].overrides_of("kplanes")["clock"] == "cpu"  # what is refused


def test_the_device_is_recorded_per_run_and_in_the_report(tmp_path):
    torch.set_num_threads(1)
    study, docs = tmp_path / "s", tmp_path / "docs" / "v.md"
    assert main(["--preset", "tiny", "--out", str(study), "--scenes", "single-player-closeup",
                 "--models", "kplanes", "--sampling", "uniform", "--device", "cpu", "-q",
                 "--docs", str(docs)]) == 0
    run = study / "runs" / "single-player-closeup" / "kplanes-uniform"
    train = json.loads((run / "train.json").read_text())
    assert (train["device"], train["device_name"]) == ("cpu", "cpu")
    assert json.loads((run / "render.json").read_text())["device"] == "cpu"
    assert json.loads((run / "config.json").read_text())["device"] == "cpu"
    text = docs.read_text()
    assert "Trained on: cpu (1 run)" in text
    row = next(line for line in text.splitlines() if line.startswith("| kplanes-uniform |"))
    assert row.endswith(" | cpu |")


def test_a_run_recorded_before_the_device_option_reads_as_cpu():
    from reference_models.study_report import _train_min_cell, train_device

    old = {"wall_s": 90.0, "train_cpu_seconds": 60.0, "train_seconds": 80.0}
    assert train_device(old) == "cpu" and _train_min_cell(old) == "1.0"
    gpu = {**old, "device": "cuda", "device_name": "NVIDIA GeForce RTX 3090"}
    assert train_device(gpu) == "NVIDIA GeForce RTX 3090" and _train_min_cell(gpu) == "1.3 wall"

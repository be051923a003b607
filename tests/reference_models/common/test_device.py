"""--device cpu|cuda|auto: the same numbers on the CPU, clear errors before any work, and (on a
machine with a GPU) a tiny run trained on CUDA that renders on either device."""

import json

import pytest
import torch

from dynaeval.errors import InputError
from reference_models.common.cli import main
from reference_models.common.device import check_clock, resolve_device
from reference_models.common.train import load_run, render_run, train
from reference_models.kplanes import SPEC
from reference_models.nerfplayer import SPEC as NERFPLAYER

FAST = {"log_every": 2, "checkpoint_every": 100, "batch_rays": 64}
HAS_CUDA = torch.cuda.is_available()
TIMES = ("it_per_s", "train_seconds", "train_cpu_seconds")


def _log(run):
    return [{k: v for k, v in json.loads(line).items() if k not in TIMES}
            for line in (run / "log.jsonl").read_text().splitlines()]


def _same_runs(a, b, spec):
    _, ma, ca = load_run(a, spec)
    _, mb, cb = load_run(b, spec)
    assert ca["step"] == cb["step"]
    for (name, pa), pb in zip(ma.state_dict().items(), mb.state_dict().values(), strict=True):
        torch.testing.assert_close(pa, pb, rtol=0, atol=0, msg=name)
    assert _log(a) == _log(b)


@pytest.mark.parametrize("spec", [SPEC, NERFPLAYER], ids=["kplanes", "nerfplayer"])
def test_device_cpu_gives_the_same_numbers_as_without_it(spec, tiny_data, tmp_path):
    train(spec, tiny_data, tmp_path / "plain", size="tiny", iters=4, sampling="isg",
          progress=False, overrides=FAST)
    rec = train(spec, tiny_data, tmp_path / "cpu", size="tiny", iters=4, sampling="isg",
                progress=False, overrides=FAST, device="cpu")
    assert (rec["device"], rec["device_name"]) == ("cpu", "cpu")
    cfg = json.loads((tmp_path / "cpu" / "config.json").read_text())
    assert (cfg["device"], cfg["device_name"]) == ("cpu", "cpu")
    _same_runs(tmp_path / "plain", tmp_path / "cpu", spec)
    plain = render_run(spec, tmp_path / "plain", progress=False, every=4)
    cpu = render_run(spec, tmp_path / "cpu", progress=False, every=4, device="cpu")
    assert [p.read_bytes() for p in plain] == [p.read_bytes() for p in cpu]


@pytest.mark.skipif(HAS_CUDA, reason="auto picks cuda on this machine")
def test_auto_without_a_gpu_is_the_cpu(tiny_data, tmp_path):
    assert resolve_device("auto") == "cpu"
    train(SPEC, tiny_data, tmp_path / "cpu", size="tiny", iters=3, progress=False, overrides=FAST)
    assert main(SPEC, ["train", str(tiny_data), "--out", str(tmp_path / "auto"), "--size", "tiny",
                       "--iters", "3", "--batch-rays", "64", "--device", "auto", "--quiet"]) == 0
    # the CLI's other defaults (log_every, checkpoint_every) differ from FAST: compare weights
    _, a, _ = load_run(tmp_path / "cpu", SPEC)
    _, b, _ = load_run(tmp_path / "auto", SPEC)
    for (name, pa), pb in zip(a.state_dict().items(), b.state_dict().values(), strict=True):
        torch.testing.assert_close(pa, pb, rtol=0, atol=0, msg=name)
    assert json.loads((tmp_path / "auto" / "config.json").read_text())["device"] == "cpu"


@pytest.mark.skipif(HAS_CUDA, reason="needs a machine without CUDA")
def test_cuda_without_a_gpu_is_exit_2_before_any_work(tiny_data, tmp_path, capsys):
    with pytest.raises(InputError, match=r"device 'cuda' asked for but torch.cuda.is_available\(\) "
                                         r"is False .*use --device cpu \(or auto\)"):
        train(SPEC, tiny_data, tmp_path / "r", size="tiny", iters=1, device="cuda")
    assert not (tmp_path / "r").exists()
    assert main(SPEC, ["train", str(tiny_data), "--out", str(tmp_path / "r"), "--size", "tiny",
                       "--device", "cuda", "--quiet"]) == 2
    assert "device 'cuda' asked for" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
    train(SPEC, tiny_data, tmp_path / "ok", size="tiny", iters=1, progress=False, overrides=FAST)
    with pytest.raises(InputError, match="device 'cuda' asked for"):
        render_run(SPEC, tmp_path / "ok", device="cuda")
    assert main(SPEC, ["render", str(tmp_path / "ok"), "--device", "cuda", "--quiet"]) == 2
    assert "install a CUDA build of torch" in capsys.readouterr().err
    assert not (tmp_path / "ok" / "pred").exists()


def test_an_unknown_device_and_a_cpu_clock_on_cuda_are_input_errors(tiny_data, tmp_path,
                                                                    monkeypatch):
    with pytest.raises(InputError, match="device must be one of cpu, cuda, auto, got 'cuda:0'"):
        train(SPEC, tiny_data, tmp_path / "r", size="tiny", device="cuda:0")
    with pytest.raises(InputError, match="--clock cpu budgets process CPU seconds"):
        check_clock("cuda", "cpu", 30.0)
    check_clock("cuda", "cpu", None)  # no budget: the clock counts nothing
    check_clock("cuda", "wall", 30.0)
    check_clock("cpu", "cpu", 30.0)
    # a stand-in CUDA: the budget is refused before the model is built or anything is written
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    with pytest.raises(InputError, match="use --clock wall"):
        train(SPEC, tiny_data, tmp_path / "r", size="tiny", device="cuda",
              overrides={"minutes": 1.0, "clock": "cpu"})
    assert not (tmp_path / "r").exists()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
@pytest.mark.parametrize("spec", [SPEC, NERFPLAYER], ids=["kplanes", "nerfplayer"])
def test_a_tiny_run_trains_on_cuda_and_renders_on_either_device(spec, tiny_data, tmp_path):
    rec = train(spec, tiny_data, tmp_path / "gpu", size="tiny", iters=6, sampling="isg",
                progress=False, overrides={**FAST, "checkpoint_every": 3}, device="cuda")
    assert rec["device"] == "cuda" and rec["device_name"] == torch.cuda.get_device_name(0)
    cfg, model, _ = load_run(tmp_path / "gpu", spec, device="cuda")
    assert cfg["device"] == "cuda"
    assert {p.device.type for p in model.parameters()} == {"cuda"}
    assert {b.device.type for b in model.buffers()} == {"cuda"}
    # resumed on the CPU from the CUDA checkpoint, then on CUDA again
    train(spec, tiny_data, tmp_path / "gpu", iters=8, resume=True, progress=False, device="cpu")
    train(spec, tiny_data, tmp_path / "gpu", iters=10, resume=True, progress=False, device="cuda")
    gpu = render_run(spec, tmp_path / "gpu", progress=False, every=4, device="cuda")
    gpu_png = [p.read_bytes() for p in gpu]
    cpu = render_run(spec, tmp_path / "gpu", progress=False, every=4, device="cpu")
    import cv2
    import numpy as np

    for png, path in zip(gpu_png, cpu, strict=True):
        a = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR).astype(int)
        b = cv2.imread(str(path)).astype(int)
        assert np.abs(a - b).max() <= 2  # float rounding differs between the devices
    # the same rays on both devices (the sampler stays on the CPU with its own generator): the
    # first session's losses match a CPU run's up to float rounding
    train(spec, tiny_data, tmp_path / "cpu", size="tiny", iters=6, sampling="isg",
          progress=False, overrides={**FAST, "checkpoint_every": 3})
    log_cpu, log_gpu = _log(tmp_path / "cpu"), _log(tmp_path / "gpu")[:3]
    assert [r["step"] for r in log_gpu] == [r["step"] for r in log_cpu] == [2, 4, 6]
    for rc, rg in zip(log_cpu, log_gpu, strict=True):
        assert rc["loss"] == pytest.approx(rg["loss"], rel=1e-2)

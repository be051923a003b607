"""The command line's metric choice: a metric asked for by name that cannot run, and options of
metrics that are not computed, are usage errors (exit 2) before any frame is read (issue 32,
items 4 and 12)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from dynaeval.cli import main

_BLOCKED_RUN = """
import importlib.abc, sys

class Blocked(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ImportError(f"No module named {{name!r}} (blocked by the test)")
        return None

sys.meta_path.insert(0, Blocked())
from dynaeval.cli import main
sys.exit(main({argv!r}))
"""


def _run_without(blocked: tuple[str, ...], argv: list[str]) -> subprocess.CompletedProcess:
    """``dynaeval ARGV`` in a fresh interpreter where the modules ``blocked`` cannot be imported
    (as on a machine without that extra)."""
    code = _BLOCKED_RUN.format(blocked=blocked, argv=[str(a) for a in argv])
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)


@pytest.fixture
def broken_gt(tmp_path, scene):
    """``(pred, gt)`` whose ground truth holds a corrupt frame: a run that reads frames fails on
    it, so a message about anything else was given before any frame was read."""
    pred, gt = scene
    (gt / "cam01" / "0002.png").write_bytes(b"\x89PNG broken")
    return pred, gt


@pytest.mark.parametrize("flags, message", [
    (["--flip", "--no-lpips"], "FLIP was asked for but cannot run here: FLIP needs NVIDIA's "
                               "flip-evaluator package, which is not installed: pip install "
                               "'dynaeval[video]'; or score without FLIP (drop --flip"),
    (["--metrics", "psnr", "flip"], "FLIP was asked for but cannot run here"),
])
def test_flip_asked_for_without_its_package_is_exit_2_before_the_work(tmp_path, broken_gt,
                                                                      flags, message):
    pred, gt = broken_gt
    out = tmp_path / "r.json"
    proc = _run_without(("flip_evaluator",), ["score", pred, gt, *flags, "-q", "--focus",
                                              "none", "-o", out])
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert "cannot decode" not in proc.stderr and not out.exists()


def test_jod_asked_for_without_its_package_is_exit_2(broken_gt):
    pred, gt = broken_gt
    proc = _run_without(("pycvvdp", "pyfvvdp"), ["score", pred, gt, "--jod", "--no-lpips", "-q",
                                                 "--metric-option", "jod.model=fvvdp"])
    assert proc.returncode == 2, proc.stderr
    assert ("JOD (FovVideoVDP) needs the pyfvvdp package, which is not installed: pip install "
            "'dynaeval[fvvdp]'; or score without JOD (drop --jod") in proc.stderr


@pytest.mark.parametrize("flags", [["--metrics", "psnr", "lpips"], ["--lpips-net", "vgg"]])
def test_lpips_named_without_torch_is_exit_2(broken_gt, flags):
    pred, gt = broken_gt
    proc = _run_without(("torch", "torchvision", "lpips"), ["score", pred, gt, *flags, "-q",
                                                            "--focus", "none"])
    assert proc.returncode == 2, proc.stderr
    assert ("LPIPS was asked for but cannot run here: LPIPS needs the torch, torchvision and "
            "lpips packages (torch, torchvision, lpips not installed): pip install "
            "'dynaeval[lpips]'; or score without LPIPS (--no-lpips") in proc.stderr


def test_lpips_by_default_without_torch_goes_on_with_one_message(scene):
    """LPIPS runs by default: not asked for by name, so without torch the run goes on and says
    so once (the README's promise)."""
    pred, gt = scene
    proc = _run_without(("torch", "torchvision", "lpips"), ["score", pred, gt, "-q", "--focus",
                                                            "none", "--no-temporal"])
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("LPIPS not computed") == 1, proc.stderr
    assert "dynaeval[lpips]" in proc.stderr


def test_lpips_net_named_without_its_weights_is_exit_2(tmp_path, broken_gt, capsys, monkeypatch):
    pytest.importorskip("torch")
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "empty-torch-home"))
    pred, gt = broken_gt
    assert main(["score", str(pred), str(gt), "--lpips-net", "alex", "-q", "--focus",
                 "none"]) == 2
    err = capsys.readouterr().err
    assert "LPIPS was asked for but cannot run here: LPIPS (alex) needs torchvision's " \
           "pretrained alex backbone, which is not on this machine: place" in err
    assert "cannot decode" not in err


@pytest.mark.parametrize("flags, message", [
    (["--metric-option", "jod.model=fvvdp"],
     "--metric-option jod.model=fvvdp is an option of JOD, which is not computed: add --jod (or "
     "jod to --metrics), or drop --metric-option"),
    (["--metric-option", "flip.pixels_per_degree=40"],
     "--metric-option flip.pixels_per_degree=40 is an option of FLIP, which is not computed: add "
     "--flip"),
    (["--metrics", "psnr", "--metric-option", "jod.display=standard_4k"],
     "--metric-option jod.display=standard_4k is an option of JOD, which is not computed"),
    (["--flip-every", "3"], "--flip-every is an option of FLIP, which is not computed: add --flip"),
])
def test_an_option_of_a_metric_not_computed_is_exit_2_naming_both_flags(broken_gt, capsys,
                                                                        flags, message):
    """One rule for every metric's options, from the registry (issue 32, item 12: jod options
    without --jod were accepted and unused, while --flip-every without --flip was refused)."""
    pred, gt = broken_gt
    assert main(["score", str(pred), str(gt), "-q", "--focus", "none", *flags]) == 2
    err = capsys.readouterr().err
    assert message in err and "cannot decode" not in err


def test_library_refuses_options_of_a_metric_not_computed():
    from dynaeval.errors import InputError
    from dynaeval.run.config import ScoreConfig

    with pytest.raises(InputError, match=r"metric_options\['jod'\] sets options of JOD, which is "
                       r"not computed: add 'jod' to metrics \(CLI: add --jod\), or drop the "
                       "options"):
        ScoreConfig(metric_options={"jod": {"model": "fvvdp"}})
    assert ScoreConfig(metrics=("psnr", "flip"), metric_options={"flip": {"every": 2}}) \
        .metric_options == {"flip": {"every": 2}}


def test_lpips_without_its_weights_gives_its_advice_once(tmp_path, monkeypatch, capsys):
    """Issue 43 item 5: a requested LPIPS without its backbone weights repeated its advice
    ("or score without LPIPS (--no-lpips); or score without LPIPS (--no-lpips; ...)")."""
    pytest.importorskip("lpips")
    from dynaeval.cli import main, sample_dir

    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "empty"))
    s = sample_dir()
    assert main(["score", str(s / "pred"), str(s / "gt"), "--metrics", "psnr", "lpips", "-q",
                 "-o", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("score without LPIPS") == 1 and err.count("--no-lpips") == 1, err

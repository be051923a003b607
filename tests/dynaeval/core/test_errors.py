"""dynaeval.core.errors: the did-you-mean hint of an unknown name (issue 41, as pyiqa does)."""

from __future__ import annotations

import pytest

import dynaeval
from dynaeval.core.errors import did_you_mean
from dynaeval.errors import InputError
from dynaeval.metrics.protocols import get_protocol
from dynaeval.metrics.registry import spec


def test_the_closest_name_is_suggested_and_none_when_nothing_is_close():
    assert did_you_mean("ssmi", ["psnr", "ssim", "lpips"]) == " (did you mean 'ssim'?)"
    assert did_you_mean("zzzz", ["psnr", "ssim"]) == ""
    assert did_you_mean(3, ["psnr"]) == ""


def test_an_unknown_metric_or_protocol_name_gets_the_hint():
    with pytest.raises(InputError,
                       match=r"unknown metric\(s\) \['ssmi'\] \(did you mean 'ssim'\?\)"):
        dynaeval.ScoreConfig(metrics=("psnr", "ssmi"))
    with pytest.raises(InputError, match=r"got 'nerfbaseline' \(did you mean 'nerfbaselines'\?\)"):
        get_protocol("nerfbaseline")
    with pytest.raises(KeyError,
                       match=r"unknown metric 'focused_ssmi' \(did you mean 'focused_ssim'\?\)"):
        spec("focused_ssmi")
    with pytest.raises(InputError, match=r"got 'nerfstudi' \(did you mean 'nerfstudio'\?\)"):
        dynaeval.ScoreConfig(protocol="nerfstudi")


def test_the_cli_suggests_the_closest_choice(capsys):
    """An invalid choice on the command line gets the hint too (exit 2, as before)."""
    from dynaeval.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["score", "pred", "gt", "--metrics", "lpip"])
    assert exit_.value.code == 2
    assert "invalid choice: 'lpip'" in (err := capsys.readouterr().err)
    assert err.rstrip().endswith("(did you mean 'lpips'?)")
    with pytest.raises(SystemExit):
        main(["scor"])
    assert "(did you mean 'score'?)" in capsys.readouterr().err

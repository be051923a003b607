"""The size/speed benchmark runs on the tiny scene and reports what it says it does."""

import pytest

from reference_models.common.bench import main, measure


def test_measure_tiny(tiny_data):
    row = measure(str(tiny_data), "nerfplayer", "tiny", steps=1)
    assert row["rays"] == 256 and row["samples"] == "32+16"
    assert 0 < row["encoding_params_M"] < row["params_M"] and row["step_cpu_s"] > 0


def test_unknown_size(tiny_data, capsys):
    assert main([str(tiny_data), "--size", "huge", "--steps", "1"]) == 2
    assert "unknown size 'huge'" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([str(tiny_data), "--model", "nerf"])

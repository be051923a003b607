"""``ScoreConfig``: every setting type-checked once, where the CLI, the library and the suite all
build their settings; a wrong type is an ``InputError`` naming the key and the value, never a
``TypeError`` deep in the run nor a value silently read as another (issue 42 item 6)."""

from __future__ import annotations

from dataclasses import fields

import pytest

from dynaeval.errors import InputError
from dynaeval.run.config import ScoreConfig
from dynaeval.run.suite import FIXED_FIELDS, settings_config

WRONG_TYPES = {
    "method": [5, True, "", "  "],
    "scene": [["a"], ""],
    "metrics": [5, None, "psnr", ["psnr", 5]],
    "metric_options": [5, ["flip"]],
    "fps": ["30", True, None],
    "lpips_net": [5],
    "lpips_backend": [None],
    "data_range": ["1.0"],
    "quantize": [5, ["none"]],
    "background": [None],
    "allow_missing": ["false", 0],
    "focus": [5, ["motion"]],
    "presence": ["yes"],
    "temporal": ["no", None],
    "flow": [5, ["dis"]],
    "workers": ["2", 2.0],
    "device": [5, "cuda:x"],
    "progress": ["no"],
    "cache_mb": [1.5, "1"],
    "shard": [5, True, 2.5],
    "protocol": [["dynaeval"], 5],
    "iteration": ["3"],
    "split": [5],
    "masks": [5],
    "frames_are_video": [0, 1, "yes"],
    "prepared": [5],
}
"""Per ``ScoreConfig`` field, values of a wrong type (or form)."""


def test_every_setting_is_covered_here():
    assert set(WRONG_TYPES) == {f.name for f in fields(ScoreConfig)}


@pytest.mark.parametrize(("key", "value"), [(k, v) for k, vs in WRONG_TYPES.items() for v in vs])
def test_a_wrong_type_is_refused_naming_the_key_and_the_value(key, value):
    """Before: ``metrics=5``, ``shard=5``, ``protocol=["dynaeval"]`` were TypeError tracebacks,
    ``frames_are_video=0`` and ``device="cuda:x"`` were taken, ``fps="30"``'s message did not
    name the key, ``method=""`` fell back to the prediction folder's name silently."""
    kw = {"progress": False, key: value} if key != "progress" else {key: value}
    with pytest.raises(InputError) as err:
        ScoreConfig(**kw)
    message = str(err.value)
    assert key in message and repr(value) in message and "must" in message, message
    if key in FIXED_FIELDS:  # the suite's own: refused in [settings]
        return
    with pytest.raises(InputError, match=r"^SUITE.toml: \[settings\]: " + key):
        settings_config({key: value}, "SUITE.toml")  # the suite's settings: the same check


@pytest.mark.parametrize(("options", "shown"), [
    ({"flip": {"pixels_per_degree": True}}, "flip.pixels_per_degree must be a number, got True (bool)"),
    ({"flip": {"every": 2.5}}, "flip.every must be a positive integer, got 2.5 (float)"),
    ({"jod": {"min_window": 64.5}}, "jod.min_window must be an integer, got 64.5 (float)"),
    ({"jod": {"model": 5}}, "jod.model must be a string, got 5 (int)"),
])
def test_a_metric_option_of_the_wrong_type_is_refused_not_converted(options, shown):
    """Before: ``pixels_per_degree = true`` became 1.0 and ``min_window = 64.5`` became 64,
    silently; ``model = 5`` became ``"5"``."""
    with pytest.raises(InputError, match=shown.replace("(", r"\(").replace(")", r"\)")):
        ScoreConfig(metrics=("psnr", *options), metric_options=options, progress=False)


def test_option_text_from_the_command_line_is_still_read():
    """``--metric-option flip.every=3`` gives the text ``"3"``: converted to the declared type."""
    from dynaeval.run.config import _check_metric_options

    assert _check_metric_options({"flip": {"every": "3", "pixels_per_degree": "40"}},
                                 ("psnr", "flip")) == {"flip": {"every": 3, "pixels_per_degree": 40.0}}


def test_the_command_line_refuses_a_wrong_type_with_exit_2_before_any_work(tmp_path, capsys,
                                                                            monkeypatch):
    """Through the CLI: ``--method ''`` (was scored under the prediction folder's name) and a
    SUITE.toml's ``metrics = 5`` (a TypeError before) are exit 2 naming the key, nothing scored."""
    from dynaeval.cli import main
    from tests.dynaeval.helpers import three_camera_scene

    def boom(*args, **kwargs):
        raise AssertionError("the work started before the settings were checked")

    monkeypatch.setattr("dynaeval.run.evaluate.score", boom)
    monkeypatch.setattr("dynaeval.run.suite.run_suite", boom)
    pred, gt = three_camera_scene(tmp_path)
    assert main(["score", str(pred), str(gt), "-q", "--method", ""]) == 2
    assert "method must be a name (a non-empty string) or None, got ''" in capsys.readouterr().err
    toml = tmp_path / "SUITE.toml"
    toml.write_text(f'output = "{tmp_path / "out"}"\n[settings]\nmetrics = 5\n'
                    f'[scenes]\ns = "{gt}"\n[methods]\nm = {{s = "{pred}"}}\n')
    assert main(["suite", str(toml), "-q"]) == 2
    err = capsys.readouterr().err
    assert "SUITE.toml: [settings]: metrics must be a sequence of metric names, got 5" in err, err

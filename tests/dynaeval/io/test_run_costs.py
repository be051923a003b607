"""``dynaeval.io.run_costs``: the training time and memory NeRFBaselines writes beside its
renders (``info.json``, format checked against its source), read as written or left blank,
never guessed (issue 42 item 9)."""

from __future__ import annotations

import json

import pytest

from dynaeval.io.run_costs import RUN_COSTS, read_run_costs
from dynaeval.report.leaderboard import COSTS


def nb_info(folder, **fields):
    """A NeRFBaselines predictions folder: ``info.json`` (the fields of ``io.new_nb_info`` it
    writes, ``fields`` over them) beside ``color/`` and ``gt-color/``; returns ``color/``."""
    info = {"method": "nerfacto", "nb_version": "1.2.4", "num_iterations": 30000,
            "total_train_time": 1830.5,
            "resources_utilization": {"memory": 9012, "gpu_memory": 6144, "gpu_name": "NVIDIA A100"},
            "datetime": "2025-11-08T10:00:00", "config_overrides": {}, "applied_presets": None,
            "dataset_metadata": {"name": "blender", "scene": "lego"},
            "evaluation_protocol": "default", "hparams": {},
            "render_version": "1.2.4", "render_datetime": "2025-11-08T11:00:00",
            "render_dataset_metadata": {"name": "blender"}, **fields}
    (folder / "color").mkdir(parents=True, exist_ok=True)
    (folder / "gt-color").mkdir(exist_ok=True)
    (folder / "info.json").write_text(json.dumps(info, indent=2))
    return folder / "color"


def test_nerfbaselines_training_time_and_gpu_memory_are_read_from_color_or_its_folder(tmp_path):
    color = nb_info(tmp_path / "predictions-30000")
    for given in (color, color.parent):
        got = read_run_costs(given)
        assert got.costs == pytest.approx({"train_minutes": 1830.5 / 60, "memory_gb": 6.0})
        assert got.source == str(tmp_path / "predictions-30000" / "info.json") and got.note is None
    assert set(RUN_COSTS) <= set(COSTS)


@pytest.mark.parametrize(("fields", "costs", "note"), [
    ({"total_train_time": None, "resources_utilization": None}, {}, None),  # not measured
    ({"resources_utilization": {"memory": 100}}, {"train_minutes": 1830.5 / 60}, None),  # no GPU
    ({"total_train_time": "30m"}, {"memory_gb": 6.0}, "total_train_time is '30m', not a number"),
    ({"total_train_time": -1}, {"memory_gb": 6.0}, "total_train_time is -1, not a number >= 0"),
])
def test_an_absent_figure_is_blank_and_a_bad_one_is_said(tmp_path, fields, costs, note):
    got = read_run_costs(nb_info(tmp_path, **fields))
    assert got.costs == pytest.approx(costs)
    assert (got.note is None) if note is None else (note in got.note and "left blank" in got.note)


def test_other_info_files_give_nothing_and_a_broken_one_is_said(tmp_path):
    assert read_run_costs(tmp_path).costs == {}  # no info.json
    (tmp_path / "info.json").write_text('{"total_train_time": 60}')  # not NeRFBaselines'
    assert read_run_costs(tmp_path) == read_run_costs(tmp_path / "none")
    (tmp_path / "info.json").write_text('{"nb_version": "1", "total_train_time": NaN}')
    got = read_run_costs(tmp_path)
    assert got.costs == {} and "NaN" in got.note and "not read" in got.note

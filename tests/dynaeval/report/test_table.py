"""Plain-text tables: the run's title line."""

from __future__ import annotations

import pytest

from dynaeval.report.table import run_title, summary_table


@pytest.mark.parametrize(("method", "scene", "layout", "title"), [
    ("kplanes", "stadium", None, "kplanes on stadium"),
    ("garden", "garden", {"name": "3dgs", "split": "test"}, "garden (3dgs render folder)"),
    ("cam00", "cam00", None, "cam00"),
    ("kplanes", "stadium", {"name": "nerfstudio"}, "kplanes on stadium (nerfstudio render folder)"),
])
def test_run_title_names_a_render_folder_once(method, scene, layout, title):
    inputs = {"cameras": ["."]} | ({"layout": layout} if layout else {})
    assert run_title({"method": method, "scene": scene, "inputs": inputs}) == title


def test_summary_table_first_line_is_the_title():
    """``dynaeval score RUN`` printed "garden on garden: 3 frames, ..."."""
    results = {"method": "garden", "scene": "garden", "metrics": {}, "cameras": {".": {}},
               "summary": {"n_frames": 3}, "inputs": {"layout": {"name": "3dgs"}}}
    assert summary_table(results).splitlines()[0] == (
        "garden (3dgs render folder): 3 frames, 1 camera (means over frames)")

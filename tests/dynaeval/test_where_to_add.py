"""docs/architecture.md "Where do I add X", checked (issue 41): a toy metric (a ``MetricSpec``,
here from a plugin package), a toy focus source (a ``FocusSource`` subclass registered in
``regions.sources.SOURCE_KINDS``) and a toy input layout (one ``io.layouts.LAYOUTS`` entry) are
each added in the one place the table names, and a run scores with all three."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

from dynaeval.cli import sample_dir

from .metrics.test_plugins import _install

RUN = '''
import json, sys
import dynaeval
from dynaeval.io import layouts
from dynaeval.regions import sources
from dynaeval.regions.focus import FocusConfig


class ToyBoxes(sources.BoxesFileSource):
    """A toy kind: a boxes file under another name."""

    name = "toyboxes"
    spec = "toyboxes"


sources.SOURCE_KINDS["toyboxes"] = ToyBoxes()
layouts.LAYOUTS["toy"] = ("renders", "gt-renders")
run, boxes, out = sys.argv[1:4]
res = dynaeval.score(run, focus=FocusConfig(source="toyboxes", boxes_file=boxes, masked=False),
                     metrics=("psnr", "ssim", "toy_mae"), temporal=False, presence=False,
                     progress=False)
json.dump({"layout": res["inputs"]["layout"]["name"], "summary": res["summary"],
           "source": res["settings"]["focus"]["source"]}, open(out, "w"))
'''


def test_a_toy_metric_focus_source_and_layout_each_go_in_one_place(tmp_path):
    sample = sample_dir()
    site = _install(tmp_path / "site", "toy_mae = toy_metric_pkg:SPEC")
    run = tmp_path / "run"
    shutil.copytree(sample / "pred", run / "renders")
    shutil.copytree(sample / "gt", run / "gt-renders")
    out = tmp_path / "out.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", RUN, str(run), str(sample / "boxes.json"),
                           str(out)], capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    got = json.loads(out.read_text())
    assert got["layout"] == "toy" and got["source"] == "toyboxes"
    summary = got["summary"]
    assert summary["toy_mae"] > 0 and summary["focused_ssim"] is not None
    assert summary["focused_psnr"] is not None and "focused_toy_mae" not in summary

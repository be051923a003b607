"""HTML report: generated for the bundled sample scene, images referenced and present, offline."""

from __future__ import annotations

import re
import shutil

import pytest

from dynaeval.cli import main, sample_dir
from dynaeval.errors import InputError
from dynaeval.evaluate import ScoreConfig, score
from dynaeval.regions.focus import FocusConfig
from dynaeval.report.html import RegionRecorder, worst_frames, write_report
from tests.dynaeval.helpers import moving_square_scene

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def sample_run():
    root = sample_dir()
    recorder = RegionRecorder()
    config = ScoreConfig(
        method="sample-degraded", scene="sample", metrics=("psnr", "ssim"), temporal=False, progress=False,
        focus=FocusConfig(source="boxes", boxes_file=str(root / "boxes.json"), masked=True),
    )
    results = score(root / "pred", root / "gt", config, on_regions=recorder)
    return results, recorder


def _sources(html: str) -> list[str]:
    return re.findall(r"<img src='([^']+)'", html)


def test_report_for_sample_scene_references_only_present_local_images(tmp_path, sample_run):
    results, recorder = sample_run
    index = write_report(results, tmp_path / "rep", recorder=recorder, n_worst=3)
    html = index.read_text()
    srcs = _sources(html)
    per_frame = [m for m in results["metrics"] if m in results["frames"][0]]
    from dynaeval.report.html import missing_objects

    assert len(srcs) == len(per_frame) + 3 + len(missing_objects(results))
    for src in srcs:
        assert not src.startswith(("/", "http", "data:")) and (index.parent / src).is_file()
    on_disk = sorted(p.relative_to(index.parent).as_posix() for p in (index.parent / "img").iterdir())
    assert on_disk == sorted(srcs)  # nothing written that the page does not show
    assert "http://" not in html and "https://" not in html and "<script" not in html
    assert f"{results['summary']['psnr']:.3f}" in html  # summary table
    for cam in results["inputs"]["cameras"]:
        assert f"<td>{cam}</td>" in html  # per-camera table


def test_recorder_keeps_boxes_and_mask_outlines_of_every_frame(sample_run):
    results, recorder = sample_run
    keys = {(f["camera"], f["frame"]) for f in results["frames"]}
    assert set(recorder.boxes) == keys
    assert set(recorder.outlines) == keys
    assert all(b.dtype.name == "int64" and b.shape[1] == 4 for b in recorder.boxes.values())
    assert all(len(o) >= 1 and o[0].shape[1] == 2 for o in recorder.outlines.values())


def test_worst_frames_are_the_lowest_focused_psnr(sample_run):
    results, _ = sample_run
    metric, worst = worst_frames(results, 2)
    values = sorted(f["focused_psnr"] for f in results["frames"])
    assert metric == "focused_psnr" and [f["focused_psnr"] for f in worst] == values[:2]


def test_existing_report_is_not_overwritten_and_gone_frame_is_named(tmp_path, sample_run):
    results, recorder = sample_run
    write_report(results, tmp_path / "rep", n_worst=0)
    with pytest.raises(InputError, match="report exists; pass --overwrite"):
        write_report(results, tmp_path / "rep", n_worst=0)
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="report folder is a file"):
        write_report(results, tmp_path / "file")
    gone = dict(results, frames=[dict(f, pred=str(tmp_path / "gone.png")) for f in results["frames"]])
    with pytest.raises(InputError, match="frame listed in the results is gone"):
        write_report(gone, tmp_path / "rep2", n_worst=1)
    assert not (tmp_path / "rep2" / "index.html").exists()


def test_cli_score_report(tmp_path, capsys):
    gt, frames = moving_square_scene(tmp_path / "gt", frames=4)
    pred = tmp_path / "pred"
    shutil.copytree(gt, pred)
    (pred / "cam00" / "0001.png").write_bytes((gt / "cam01" / "0001.png").read_bytes())
    args = ["score", str(pred), str(gt), "--no-lpips", "--no-temporal", "--focus", "motion",
            "-q", "--report", str(tmp_path / "rep")]
    assert main(args) == 0
    assert "report written to" in capsys.readouterr().err
    html = (tmp_path / "rep" / "index.html").read_text()
    assert all((tmp_path / "rep" / s).is_file() for s in _sources(html))
    assert main(args) == 2  # refused before scoring
    assert "report exists" in capsys.readouterr().err


def test_new_modules_import_no_heavy_dependency():
    import subprocess
    import sys

    code = ("import sys, dynaeval.report.html, dynaeval.report.leaderboard, dynaeval.io.layouts, "
            "dynaeval.metrics.protocols, dynaeval.metrics.accumulate; "
            "print(sorted(m for m in ('torch', 'matplotlib', 'onnxruntime', 'pandas') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_report_shows_the_objects_missing_from_the_prediction(tmp_path):
    from dynaeval.cli import main, sample_dir

    out = tmp_path / "report"
    assert main(["demo", "-q", "--no-lpips", "-o", str(tmp_path / "r.json"),
                 "--report", str(out)]) == 0
    html = (out / "index.html").read_text()
    assert "Objects missing from the prediction" in html
    crops = sorted((out / "img").glob("missing_*.png"))
    # the sample's ball is erased on odd frames: those and only those are shown
    assert crops and all(f"img/{c.name}" in html for c in crops)
    assert "ball" in html.split("Objects missing")[1] and sample_dir().is_dir()

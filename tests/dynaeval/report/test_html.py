"""HTML report: generated for the bundled sample scene, one file with its images inlined, offline,
nothing cut in a 1280 px window (headless Chromium)."""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess

import pytest

from dynaeval.cli import main, sample_dir
from dynaeval.errors import InputError
from dynaeval.regions.focus import FocusConfig
from dynaeval.report.html import RegionRecorder, worst_frames, write_report
from dynaeval.run.evaluate import ScoreConfig, score
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


PNG_URI = "data:image/png;base64,"


def _is_png_uri(src: str) -> bool:
    return src.startswith(PNG_URI) and base64.b64decode(src[len(PNG_URI):])[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_is_one_file_with_its_images_inlined(tmp_path, sample_run):
    """The README calls the report self-contained: index.html alone, every image a PNG data
    URI (the old report wrote index.html + img/*.png)."""
    results, recorder = sample_run
    index = write_report(results, tmp_path / "rep", recorder=recorder, n_worst=3)
    html = index.read_text()
    srcs = _sources(html)
    per_frame = [m for m in results["metrics"] if m in results["frames"][0]]
    from dynaeval.report.html import missing_objects

    assert len(srcs) == len(per_frame) + 3 + len(missing_objects(results))
    assert all(_is_png_uri(s) for s in srcs)
    assert [p.name for p in index.parent.iterdir()] == ["index.html"]  # nothing else written
    assert index.stat().st_size < 4_000_000  # measured: 2.0 MB here, 2.6 MB for the demo
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
    assert _sources(html) and all(_is_png_uri(s) for s in _sources(html))
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


@pytest.fixture(scope="module")
def demo_report(tmp_path_factory):
    """``dynaeval demo --no-lpips --report``: every default metric of the sample (18 columns
    in the per-camera table, ``focused_flicker`` last)."""
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "-q", "--no-lpips", "-o", str(out / "r.json"),
                 "--report", str(out / "report")]) == 0
    return json.loads((out / "r.json").read_text()), out / "report" / "index.html"


def test_report_shows_the_objects_missing_from_the_prediction(demo_report):
    from dynaeval.report.html import missing_objects

    results, index = demo_report
    html = index.read_text()
    assert "Objects missing from the prediction" in html
    crops = _sources(html.split("Objects missing")[1])
    # the sample's ball is erased on odd frames: those and only those are shown
    assert crops and len(crops) == len(missing_objects(results))
    assert "ball" in html.split("Objects missing")[1] and sample_dir().is_dir()


def test_flat_folder_camera_is_named_after_its_folder(tmp_path):
    """Frames directly in the folders: the results call the camera "." (its relative path);
    the report names it after the ground-truth folder, in the table, curves and captions."""
    from dynaeval.report.html import camera_label

    gt, _ = moving_square_scene(tmp_path / "gt", cameras=("cam05",), frames=4)
    pred, _ = moving_square_scene(tmp_path / "pred", cameras=("cam05",), frames=4, seed=1)
    cfg = ScoreConfig(metrics=("psnr",), temporal=False, progress=False,
                      focus=FocusConfig(source="none", masked=False))
    results = score(pred / "cam05", gt / "cam05", cfg)
    assert results["inputs"]["cameras"] == ["."]  # the results keep their name
    html = write_report(results, tmp_path / "rep", n_worst=1).read_text()
    assert "<td>cam05</td>" in html and "<td>.</td>" not in html
    assert re.search(r"alt='camera cam05 frame 000\d'", html) and "camera ." not in html
    from dynaeval.report.html import curve_figure

    legend = curve_figure(results, "psnr").axes[0].get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["cam05"]
    layout = dict(results, inputs=dict(results["inputs"], layout={"name": "3dgs"}))
    assert camera_label(layout, ".") == "all" and camera_label(layout, "cam01") == "cam01"


def test_render_folder_title_is_the_model_once(tmp_path, sample_run):
    """``dynaeval score RUN`` names method and scene after the render folder: the title was
    "garden on garden"."""
    results, _ = sample_run
    run = dict(results, method="garden", scene="garden",
               inputs=dict(results["inputs"], layout={"name": "3dgs", "split": "test"}))
    html = write_report(run, tmp_path / "rep", n_worst=0).read_text()
    assert "<h1>dynaeval: garden (3dgs render folder)</h1>" in html
    assert "<title>dynaeval: garden (3dgs render folder)</title>" in html
    assert "garden on garden" not in html
    assert "<h1>dynaeval: sample-degraded on sample</h1>" in write_report(
        results, tmp_path / "rep2", n_worst=0).read_text()


@pytest.mark.parametrize("n_frames", [2, 3, 5])
def test_curves_have_integer_frame_ticks(sample_run, n_frames):
    """A few frames gave ticks at 0.25, 0.5, ... of a frame index."""
    from dynaeval.report.html import curve_figure

    results, _ = sample_run
    short = dict(results, frames=[f for f in results["frames"] if f["index"] < n_frames])
    fig = curve_figure(short, "psnr")
    fig.canvas.draw()
    lo, hi = fig.axes[0].get_xlim()
    ticks = [t for t in fig.axes[0].get_xticks() if lo <= t <= hi]
    assert len(ticks) >= 2 and all(float(t).is_integer() for t in ticks), ticks


def _chromium() -> str | None:
    return next(filter(None, (shutil.which(n) for n in ("chromium", "chromium-browser"))), None)


MEASURE = """<script>
window.addEventListener('load', () => {
  const out = document.createElement('pre');
  out.id = 'measured';
  out.textContent = JSON.stringify({
    window: window.innerWidth, viewport: document.documentElement.clientWidth,
    page: document.documentElement.scrollWidth,
    tables: [...document.querySelectorAll('table')].map(t => ({
      right: t.getBoundingClientRect().right, width: t.scrollWidth,
      box: t.parentElement.clientWidth, box_right: t.parentElement.getBoundingClientRect().right,
      heading: t.rows[0].cells[t.rows[0].cells.length - 1].textContent}))});
  document.body.appendChild(out);
});
</script>"""
"""Written into a copy of the report (the report itself has no script): the widths Chromium
laid out, as JSON in a ``<pre id='measured'>`` that ``--dump-dom`` prints."""


def _measure_in_chromium(index, tmp_path, width: int = 1280) -> dict:
    copy = tmp_path / "measured.html"
    copy.write_text(index.read_text().replace("</body>", MEASURE + "</body>"))
    cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
           f"--window-size={width},900", "--dump-dom", copy.as_uri()]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    found = re.search(r"<pre id=\"measured\">(.*?)</pre>", out.stdout, re.S)
    assert found, f"chromium printed no measurement (exit {out.returncode}): {out.stderr[-800:]}"
    return json.loads(found.group(1))


@pytest.mark.skipif(_chromium() is None, reason="no chromium binary on PATH (apt-get install chromium)")
def test_report_in_chromium_at_1280px_cuts_no_table(demo_report, tmp_path):
    """The demo's per-camera table was 1895 px wide in a 1280 px window: the page scrolled
    sideways and focused_flicker was cut off. Headings now break at ``_`` and a table wider
    than the window scrolls in its own box; at 1280 px every table of the demo fits whole."""
    _, index = demo_report
    m = _measure_in_chromium(index, tmp_path)
    assert m["window"] == 1280, m  # the window size was honoured: the numbers mean something
    assert m["page"] <= m["viewport"], m  # no sideways scrolling of the page
    assert m["tables"] and any(t["heading"].replace("\u200b", "") == "focused_flicker"
                               for t in m["tables"]), m
    for t in m["tables"]:
        assert t["width"] <= t["box"] and t["right"] <= m["viewport"], t  # nothing cut


@pytest.mark.skipif(_chromium() is None, reason="no chromium binary on PATH (apt-get install chromium)")
def test_report_in_a_narrow_window_scrolls_the_table_not_the_page(demo_report, tmp_path):
    """At 800 px the per-camera table cannot fit: it scrolls inside its own box (its full width
    reachable there) while the page itself never scrolls sideways."""
    _, index = demo_report
    m = _measure_in_chromium(index, tmp_path, width=800)
    assert m["window"] == 800 and m["page"] <= m["viewport"], m
    wide = [t for t in m["tables"] if t["width"] > t["box"]]
    assert wide and all(t["box_right"] <= m["viewport"] for t in m["tables"]), m

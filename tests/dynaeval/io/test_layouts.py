"""Render-folder layouts (NeRFBaselines, ns-render) read by score without renaming."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.io.layouts import detect_layout
from dynaeval.regions.focus import FocusConfig
from tests.dynaeval.helpers import textured_frame, write_frames


def _run(root, pred_name, gt_name, rng, n=3):
    gt = [textured_frame(rng, 32, 40) for _ in range(n)]
    pred = [np.clip(f.astype(int) + 6, 0, 255).astype(np.uint8) for f in gt]
    write_frames(root, pred_name, pred)
    write_frames(root, gt_name, gt)
    return root


def test_nerfbaselines_folder(tmp_path, rng):
    run = _run(tmp_path / "run", "color", "gt-color", rng)
    lay = detect_layout(run)
    assert (lay.name, lay.pred, lay.gt, lay.root, lay.sequence) == (
        "nerfbaselines", run / "color", run / "gt-color", run, False)
    assert detect_layout(run, run) == lay  # PRED == GT: the same rule


def test_ns_render_split_subfolder(tmp_path, rng):
    out = tmp_path / "renders"
    _run(out / "test", "rgb", "gt-rgb", rng)
    lay = detect_layout(out)
    assert (lay.name, lay.pred, lay.gt) == ("nerfstudio", out / "test" / "rgb", out / "test" / "gt-rgb")


def test_two_folders_are_used_as_given(tmp_path, rng):
    run = _run(tmp_path / "run", "color", "gt-color", rng)
    lay = detect_layout(run / "color", run / "gt-color")
    assert (lay.name, lay.pred, lay.gt, lay.root) == ("folders", run / "color", run / "gt-color", None)


def test_errors(tmp_path, rng):
    out = tmp_path / "renders"
    _run(out / "test", "rgb", "gt-rgb", rng)
    _run(out / "train", "rgb", "gt-rgb", rng)
    with pytest.raises(InputError, match=r"several render layouts found: test \(nerfstudio\), train \(nerfstudio\)"):
        detect_layout(out)
    with pytest.raises(InputError, match=r"holds no known render layout .*kplanes: a log folder with step<N>\.mp4"):
        detect_layout(out / "test" / "rgb")
    with pytest.raises(InputError, match="render folder not found"):
        detect_layout(tmp_path / "nope")
    ev = tmp_path / "eval"
    ev.mkdir()
    (ev / "000000-img.jpg").write_bytes(b"")
    with pytest.raises(InputError, match="ns-eval --render-output-path.*ns-render dataset"):
        detect_layout(ev)
    with pytest.raises(InputError, match="ns-eval --render-output-path"):
        detect_layout(ev, out / "test" / "gt-rgb")


def test_cli_scores_a_render_folder_with_one_argument(tmp_path, rng, capsys):
    run = _run(tmp_path / "myrun", "color", "gt-color", rng)
    out = tmp_path / "r.json"
    assert main(["score", str(run), "--no-lpips", "--no-temporal", "--focus", "none",
                 "--no-masked", "-q", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "nerfbaselines render folder" in err
    two = tmp_path / "r2.json"
    assert main(["score", str(run / "color"), str(run / "gt-color"), "--no-lpips", "--no-temporal",
                 "--focus", "none", "--no-masked", "-q", "-o", str(two)]) == 0
    import json

    a, b = json.loads(out.read_text()), json.loads(two.read_text())
    assert a["summary"]["psnr"] == b["summary"]["psnr"] and a["summary"]["n_frames"] == 3
    assert a["method"] == a["scene"] == "myrun"
    assert main(["score", str(tmp_path / "nothing"), "--no-lpips", "-q"]) == 2
    assert "render folder not found" in capsys.readouterr().err


def test_same_ordinary_folder_twice_is_scored_as_given(tmp_path):
    from dynaeval.io.layouts import detect_layout

    (tmp_path / "gt" / "cam00").mkdir(parents=True)
    layout = detect_layout(tmp_path / "gt", tmp_path / "gt")
    assert layout.name == "folders" and layout.pred == layout.gt == tmp_path / "gt"


def test_library_reads_a_render_folder_like_the_cli(tmp_path, rng):
    """``dynaeval.score(RUN)`` finds the layout itself (no CLI needed), names the run after the
    folder, records the layout and warns, as a Python warning too, that its separate test views
    are scored per frame only (issue 32: they were scored as a sequence)."""
    import dynaeval
    from dynaeval.run.evaluate import DynaevalWarning

    run = _run(tmp_path / "myrun", "color", "gt-color", rng)
    with pytest.warns(DynaevalWarning, match="frames are separate test views, not a video"):
        res = dynaeval.score(run, metrics=("psnr", "ssim"), progress=False)
    assert res["method"] == res["scene"] == "myrun"
    assert res["inputs"]["layout"] == {"name": "nerfbaselines", "root": str(run)}
    assert res["inputs"]["pred"] == str(run / "color")
    plain = dynaeval.score(run / "color", run / "gt-color", metrics=("psnr", "ssim"),
                           progress=False, temporal=False)
    assert "layout" not in plain["inputs"]
    assert plain["frames"][0]["psnr"] == res["frames"][0]["psnr"]


# ------------------------------------------------ nerfstudio raw renders (issue 32 item 11)


def _save_npy_gz(path, arr):
    import gzip

    path.parent.mkdir(parents=True, exist_ok=True)
    with gzip.open(path, "wb") as f:  # as nerfstudio's DatasetRender writes raw-* outputs
        np.save(f, arr)


def _raw_ns_render(out, rng, n=3, h=32, w=40):
    """OUT/test/raw-rgb/ + raw-gt-rgb/ of float32 (H, W, 3) frames in [0, 1]; (pred, gt)."""
    gt = [rng.random((h, w, 3), dtype=np.float32) for _ in range(n)]
    pred = [np.clip(g + rng.normal(0, 0.05, g.shape), 0, 1).astype(np.float32) for g in gt]
    for i, (p, g) in enumerate(zip(pred, gt, strict=True)):
        _save_npy_gz(out / "test" / "raw-rgb" / f"frame_{i:05d}.npy.gz", p)
        _save_npy_gz(out / "test" / "raw-gt-rgb" / f"frame_{i:05d}.npy.gz", g)
    return pred, gt


def test_nerfstudio_raw_float_renders_are_scored_end_to_end(tmp_path, rng, capsys):
    """Issue 32 item 11: ``ns-render dataset --rendered-output-names raw-rgb raw-gt-rgb`` writes
    gzip'd float32 arrays, which were refused ("no known render layout"). Read as stored: the
    CLI's and the library's PSNR equal ``psnr`` of the arrays themselves."""
    import json

    import dynaeval
    from dynaeval.metrics import psnr

    out = tmp_path / "renders"
    pred, gt = _raw_ns_render(out, rng)
    lay = detect_layout(out)
    assert (lay.name, lay.pred, lay.sequence) == ("nerfstudio-raw", out / "test" / "raw-rgb", False)
    res = tmp_path / "r.json"
    assert main(["score", str(out), "--no-lpips", "--focus", "none", "-q", "-o", str(res)]) == 0
    assert "nerfstudio-raw render folder" in capsys.readouterr().err
    doc = json.loads(res.read_text())
    want = [psnr(p, g) for p, g in zip(pred, gt, strict=True)]
    assert [r["psnr"] for r in doc["frames"]] == pytest.approx(want, rel=1e-12)
    assert [r["frame"] for r in doc["frames"]] == ["frame_00000", "frame_00001", "frame_00002"]
    lib = dynaeval.score(out, metrics=("psnr", "ssim"), progress=False,
                         focus=FocusConfig(source="none"))
    assert [r["psnr"] for r in lib["frames"]] == [r["psnr"] for r in doc["frames"]]


def test_nerfstudio_raw_beside_8_bit_renders_scores_the_float_ones_and_says_so(tmp_path, rng):
    out = tmp_path / "renders"
    _raw_ns_render(out, rng)
    _run(out / "test", "rgb", "gt-rgb", rng)
    lay = detect_layout(out)
    assert lay.name == "nerfstudio-raw" and "the float ones are scored" in lay.notes[0]


def test_nerfstudio_raw_out_of_range_or_broken_file_is_exit_2_naming_it(tmp_path, rng, capsys):
    out = tmp_path / "renders"
    _raw_ns_render(out, rng)
    bad = out / "test" / "raw-rgb" / "frame_00001.npy.gz"
    _save_npy_gz(bad, np.full((32, 40, 3), 1.7, np.float32))  # linear HDR above 1
    args = ["score", str(out), "--no-lpips", "--focus", "none", "--no-masked", "-q"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "frame_00001.npy.gz" in err and "float pixel values must be in [0, 1]" in err
    bad.write_bytes(b"not gzip")
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "frame_00001.npy.gz" in err and "cannot read this .npy.gz frame" in err
    _save_npy_gz(bad, np.zeros((3, 32, 40), np.float32))
    assert main(args) == 2
    assert "arr.transpose(1, 2, 0)" in capsys.readouterr().err

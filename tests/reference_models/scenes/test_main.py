"""Command line: renders, and exits 2 with a clear message on bad input."""

import json
import subprocess
import sys

import pytest

from reference_models.scenes.__main__ import main


def test_renders_a_small_override(tmp_path, capsys):
    out = tmp_path / "o"
    code = main(["render", "single-player-broadcast", str(out), "--size", "tiny", "--frames", "2",
                 "--width", "32", "--height", "18", "--spp", "1", "--seed", "3", "--hide", "ball"])
    assert code == 0
    meta = json.loads((out / "metadata.json").read_text())
    assert (meta["width"], meta["height"], meta["frames"], meta["seed"], meta["spp"]) == (32, 18, 2, 3, 1)
    assert meta["hide"] == ["ball"]
    assert "rendered single-player-broadcast" in capsys.readouterr().err


@pytest.mark.parametrize(("args", "match"), [
    (["render", "beach", "OUT"], "unknown preset 'beach'"),
    (["render", "players-stadium", "OUT", "--size", "huge"], "unknown size 'huge'"),
    (["render", "players-stadium", "OUT", "--spp", "2"], "spp must be a square number"),
])
def test_bad_input_exits_2_with_message(tmp_path, capsys, args, match):
    args = [str(tmp_path / "o") if a == "OUT" else a for a in args]
    assert main(args) == 2
    assert match in capsys.readouterr().err


def test_non_empty_output_exits_2_unless_overwrite(tmp_path, capsys):
    (tmp_path / "old.txt").write_text("x")
    base = ["render", "single-player-closeup", str(tmp_path), "--size", "tiny", "--frames", "1", "--spp", "1"]
    assert main(base) == 2
    assert "output folder is not empty" in capsys.readouterr().err
    assert main(base + ["--overwrite"]) == 0


def test_module_entry_point_exit_code(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "reference_models.scenes", "render", "nope",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "error: unknown preset 'nope'" in proc.stderr


def test_camera_subset_and_unknown_camera(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["render", "players-stadium", str(out), "--size", "tiny", "--frames", "2", "--spp", "1",
                 "--cameras", "eval00,cam01"]) == 0
    tf = json.loads((out / "transforms.json").read_text())
    assert tf["train_cameras"] == ["cam01"] and tf["eval_cameras"] == ["eval00"]
    assert sorted(p.name for p in (out / "images").iterdir()) == ["cam01", "eval00"]
    assert main(["render", "players-stadium", str(tmp_path / "p"), "--size", "tiny",
                 "--cameras", "cam77"]) == 2
    assert "no camera 'cam77'" in capsys.readouterr().err

"""A full disk, a read-only place or an interrupt while the outputs are written (issue 34, item 2):
exit 2 naming the path and "no space left", nothing partial left behind, an existing result
untouched. Every output of every command: ``score -o`` / ``--report`` / ``--3dgs-json``,
``prepare -o``, ``detect -o``, ``leaderboard -o``, ``merge -o``.

The disk fills in two ways: an injected ENOSPC (always runs: ``os.fsync`` of the staged file
fails as on a full disk, and ``numpy.save`` of a prepared array), and a real 200 kB tmpfs where the
machine lets the test mount one (root with CAP_SYS_ADMIN; skipped elsewhere, saying so).
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from dynaeval.cli import main

NO_SPACE = "no space left on the device"


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.fixture
def full_disk(monkeypatch):
    """Every staged output file fails as on a full disk, after ``after`` successful ones."""
    calls = {"left": 0}
    real = os.fsync

    def fsync(fd):
        if calls["left"] > 0:
            calls["left"] -= 1
            return real(fd)
        _enospc()

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(np, "save", _enospc)
    return calls


def _left(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _score_argv(scene, out: Path):
    pred, gt = scene
    return ["score", pred, gt, "--no-lpips", "-q", "-o", out / "r.json", "--report",
            out / "rep"]


@pytest.mark.parametrize("after", [0, 1])
def test_score_on_a_full_disk_leaves_neither_results_nor_report(tmp_path, scene, full_disk,
                                                               capsys, after):
    """``after=1``: the results file is on disk when the report fails: it is removed too (it
    was written although the run failed)."""
    out = tmp_path / "out"
    full_disk["left"] = after
    code, _, err = run(capsys, *_score_argv(scene, out))
    assert code == 2, err
    assert NO_SPACE in err and "Traceback" not in err
    assert ("rep/index.html: cannot write the report" if after else "r.json: cannot write the "
            "results file") in err
    assert not out.exists()  # no file, no temporary file, no report folder


def test_a_full_disk_leaves_an_existing_result_untouched(tmp_path, scene, full_disk, capsys):
    out = tmp_path / "out"
    (out / "rep").mkdir(parents=True)
    (out / "r.json").write_text("old results")
    (out / "rep" / "index.html").write_text("old report")
    full_disk["left"] = 1  # the new results file is staged, the report is not
    code, _, err = run(capsys, *_score_argv(scene, out), "--overwrite")
    assert code == 2 and NO_SPACE in err, err
    assert (out / "r.json").read_text() == "old results"
    assert (out / "rep" / "index.html").read_text() == "old report"
    assert _left(out) == ["r.json", "rep", "rep/index.html"]


def test_an_interrupt_while_the_report_renders_leaves_nothing(tmp_path, scene, capsys,
                                                              monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("dynaeval.report.html._curves", interrupted)
    out = tmp_path / "out"
    code, _, err = run(capsys, *_score_argv(scene, out))
    assert code == 130 and "interrupted" in err
    assert not out.exists()


def test_gs_json_files_on_a_full_disk(tmp_path, scene, full_disk, capsys):
    pred, gt = (p / "cam00" for p in scene)  # one camera: 3DGS files key frames by file name
    full_disk["left"] = 2  # results file and 3DGS results.json staged, per_view.json not
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "-o", tmp_path / "o" /
                       "r.json", "--3dgs-json", tmp_path / "o" / "gs")
    assert code == 2 and "per_view.json: cannot write the 3DGS results file" in err, err
    assert NO_SPACE in err and not (tmp_path / "o").exists()


def _results_file(tmp_path, scene, capsys, *extra):
    pred, gt = scene
    path = tmp_path / "in" / "r.json"
    assert run(capsys, "score", pred, gt, "--no-lpips", "-q", "-o", path, *extra)[0] == 0
    return path


@pytest.mark.parametrize("command", ["prepare", "detect", "leaderboard", "merge"])
def test_every_command_on_a_full_disk(tmp_path, scene, full_disk, capsys, command):
    full_disk["left"] = 10**9  # the inputs are written first
    results = _results_file(tmp_path, scene, capsys, "--shard", "1/1") if command == "merge" \
        else _results_file(tmp_path, scene, capsys)
    full_disk["left"] = 0
    out = tmp_path / "out" / "x"
    argv = {"prepare": ["prepare", scene[1], "-o", out, "-q"],
            "detect": ["detect", scene[1], "--source", "motion", "-q", "-o", out],
            "leaderboard": ["leaderboard", results, "-o", out.with_suffix(".md")],
            "merge": ["merge", results, "-o", out.with_suffix(".json")]}[command]
    code, _, err = run(capsys, *argv)
    assert code == 2, err
    assert NO_SPACE in err and "nothing was written" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.fixture
def tiny_tmpfs(tmp_path):
    """A real 200 kB file system (root only; skipped where mounting is not allowed)."""
    mount = shutil.which("mount")
    if os.geteuid() != 0 or mount is None:
        pytest.skip("mounting a 200 kB tmpfs needs root and mount(8)")
    where = tmp_path / "tiny"
    where.mkdir()
    made = subprocess.run([mount, "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(where)],
                          capture_output=True, text=True)
    if made.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.strip()}")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=False)


def test_a_real_full_tmpfs(tiny_tmpfs, tmp_path, scene, capsys):
    """The report (~100 kB of inlined images) and the results do not both fit in 200 kB with
    a filler file: exit 2, and the file system holds only the filler again."""
    (tiny_tmpfs / "filler").write_bytes(b"\0" * 150_000)
    code, _, err = run(capsys, *_score_argv(scene, tiny_tmpfs / "out"))
    assert code == 2 and NO_SPACE in err, err
    code, _, err = run(capsys, "prepare", scene[1], "-o", tiny_tmpfs / "prep", "-q")
    assert code == 2 and NO_SPACE in err, err
    assert _left(tiny_tmpfs) == ["filler"]
    json.dumps(err)  # printable

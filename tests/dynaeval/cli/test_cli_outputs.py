"""Every output path is checked before a frame is read; inputs are never written over; option
conflicts are usage errors (issue 16 items 5, 11, 16)."""

from __future__ import annotations

import json
import os

import pytest

from dynaeval.cli import build_parser, config_from_args, main


@pytest.fixture
def no_work(monkeypatch):
    """Any scoring, detection or merging fails the test: the refusal must come before."""
    def boom(*args, **kwargs):
        raise AssertionError("the work started before the output was checked")

    monkeypatch.setattr("dynaeval.run.evaluate.score", boom)
    monkeypatch.setattr("dynaeval.regions.focus.detect_ground_truth", boom)
    monkeypatch.setattr("dynaeval.report.merge.merge_results", boom)
    monkeypatch.setattr("dynaeval.report.leaderboard.build_leaderboard", boom)


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _bad_output(tmp_path, case):
    (tmp_path / "folder").mkdir(exist_ok=True)
    (tmp_path / "plain.txt").write_text("x")
    return {"folder": tmp_path / "folder", "proc": "/proc/x.json",
            "under_file": tmp_path / "plain.txt" / "new" / "r.json"}[case]


@pytest.mark.parametrize("command", ["score", "merge", "detect", "leaderboard"])
@pytest.mark.parametrize("case,message", [
    ("folder", "folder: the {what} must be a file, but this is a folder"),
    ("proc", "/proc: cannot write the {what} in this folder"),
    ("under_file", "plain.txt: the {what} would be under this file, which is not a folder"),
])
def test_bad_output_refused_before_any_work(tmp_path, scene, no_work, capsys, command, case,
                                            message):
    if case == "proc" and not os.path.isdir("/proc/self"):
        pytest.skip("needs Linux /proc")
    pred, gt = scene
    out = _bad_output(tmp_path, case)
    (tmp_path / "a.json").write_text("{}")
    argv = {"score": ["score", pred, gt, "--no-lpips", "-q"],
            "merge": ["merge", tmp_path / "a.json"],
            "detect": ["detect", gt, "--source", "motion", "-q"],
            "leaderboard": ["leaderboard", tmp_path / "a.json"]}[command]
    what = {"score": "results file", "merge": "results file", "detect": "boxes file",
            "leaderboard": "leaderboard file"}[command]
    code, _, err = run(capsys, *argv, "-o", out, "--overwrite")
    assert code == 2, err
    assert message.format(what=what) in err and "Traceback" not in err


def test_report_that_is_a_file_refused_before_scoring(tmp_path, scene, no_work, capsys):
    pred, gt = scene
    (tmp_path / "rep").write_text("x")
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "-o", tmp_path / "r.json",
                       "--report", tmp_path / "rep")
    assert code == 2
    assert "rep: the report folder must be a folder, but this is a file" in err
    assert not (tmp_path / "r.json").exists()


def test_output_over_a_ground_truth_frame_refused_even_with_overwrite(tmp_path, scene, no_work,
                                                                      capsys):
    pred, gt = scene
    frame = sorted(p for p in gt.rglob("*.png"))[0]
    before = frame.read_bytes()
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "-o", frame, "--overwrite")
    assert code == 2
    assert f"{frame}: refusing to write the results file over an existing image or video" in err
    assert frame.read_bytes() == before


def test_output_over_an_input_refused(tmp_path, scene, no_work, capsys):
    pred, gt = scene
    boxes = tmp_path / "boxes.json"
    boxes.write_text("{}")
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", f"boxes:{boxes}",
                       "-o", boxes, "--overwrite")
    assert code == 2 and "boxes.json: the results file would replace an input of this run" in err
    part = tmp_path / "part.json"
    part.write_text("{}")
    code, _, err = run(capsys, "merge", part, "-o", part, "--overwrite")
    assert code == 2 and "part.json: the results file would replace an input of this run" in err
    code, _, err = run(capsys, "leaderboard", part, "-o", part, "--overwrite")
    assert code == 2 and "part.json: the leaderboard file would replace an input" in err
    assert boxes.read_text() == "{}" and part.read_text() == "{}"


@pytest.mark.parametrize("focus", ["motion", "none", "boxes:b.json"])
def test_detector_without_detector_focus_is_a_usage_error(tmp_path, scene, no_work, capsys,
                                                          focus):
    pred, gt = scene
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", focus,
                       "--detector", tmp_path / "m.onnx")
    assert code == 2
    assert f"--detector is only used with --focus detector (got --focus {focus})" in err


def test_detect_detector_with_motion_source_is_a_usage_error(tmp_path, scene, no_work, capsys):
    _, gt = scene
    code, _, err = run(capsys, "detect", gt, "--source", "motion", "--detector",
                       tmp_path / "m.onnx", "-o", tmp_path / "b.json")
    assert code == 2 and "--detector is only used with --source detector" in err
    assert not (tmp_path / "b.json").exists()


# -- --metrics (item 11, the CLI part) -----------------------------------------------------------


def _config(*argv):
    return config_from_args(build_parser().parse_args(["score", "p", "g", *argv]))


def test_metrics_sets_the_metrics_exactly(random_lpips):
    from dynaeval.metrics.registry import selectable_specs

    assert _config("--metrics", "ssim", "psnr").metrics == ("psnr", "ssim")  # registry order
    assert _config("--metrics", "psnr").metrics == ("psnr",)
    every = tuple(s.name for s in selectable_specs())
    assert "jod" in every and "flip" in every
    assert _config("--metrics", *every).metrics == every  # opt-in metrics too
    assert _config().metrics == tuple(s.name for s in selectable_specs() if s.default)
    assert _config("--jod").metrics == (*_config().metrics, "jod")


@pytest.mark.parametrize("flag", ["--no-lpips", "--no-ssim"])
def test_metrics_conflicts_with_no_name(tmp_path, scene, no_work, capsys, flag):
    pred, gt = scene
    code, _, err = run(capsys, "score", pred, gt, "--metrics", "psnr", flag)
    assert code == 2
    assert f"--metrics sets the metrics exactly and cannot be combined with {flag}" in err


def test_metrics_unknown_name_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["score", "p", "g", "--metrics", "psnr", "nope"])
    assert exc.value.code == 2
    assert "invalid choice: 'nope'" in capsys.readouterr().err


def test_metrics_psnr_only_scores_psnr(tmp_path, scene, capsys):
    pred, gt = scene
    out = tmp_path / "r.json"
    code, _, err = run(capsys, "score", pred, gt, "--metrics", "psnr", "-q", "--focus", "motion",
                       "--no-temporal", "--no-presence", "-o", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert set(doc["summary"]) == {"n_frames", "psnr", "focused_psnr", "masked_psnr"}


def test_every_output_creates_its_missing_folders(tmp_path, scene, capsys):
    """One rule for every output option (issue 32, item 8: score -o, --3dgs-json and
    leaderboard -o refused a missing folder while --report and detect -o created it)."""
    pred, gt = scene
    new = tmp_path / "new"
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--no-temporal",
                       "--focus", "none", "-o", new / "a" / "r.json", "--shard", "1/1",
                       "--report", new / "c" / "report")
    assert code == 0, err
    assert json.loads((new / "a" / "r.json").read_text())["summary"]["n_frames"] == 8
    code, _, err = run(capsys, "score", pred / "cam00", gt / "cam00", "--no-lpips", "-q",
                       "--no-temporal", "--focus", "none", "--3dgs-json", new / "b" / "gs")
    assert code == 0, err
    assert (new / "b" / "gs" / "results.json").is_file()
    assert (new / "b" / "gs" / "per_view.json").is_file()
    assert (new / "c" / "report" / "index.html").is_file()
    results = new / "a" / "r.json"
    for argv, made in ((["leaderboard", results, "-o", new / "d" / "b.md"], new / "d" / "b.md"),
                       (["merge", results, "-o", new / "e" / "m.json"], new / "e" / "m.json"),
                       (["detect", gt, "--source", "motion", "-q", "-o", new / "f" / "boxes.json"],
                        new / "f" / "boxes.json"),
                       (["prepare", gt, "--focus", "none", "--no-temporal", "-q", "-o",
                         new / "g" / "prep"], new / "g" / "prep" / "manifest.json")):
        code, _, err = run(capsys, *argv)
        assert code == 0, (argv[0], err)
        assert made.is_file(), argv[0]


def test_a_failed_run_leaves_no_new_folder(tmp_path, scene, capsys):
    pred, gt = scene
    (pred / "cam01" / "0002.png").write_bytes(b"\x89PNG broken")
    code, _, err = run(capsys, "score", pred, gt, "--no-lpips", "-q", "--focus", "none",
                       "-o", tmp_path / "new" / "r.json", "--3dgs-json", tmp_path / "gs")
    assert code == 2 and "0002.png" in err
    assert not (tmp_path / "new").exists() and not (tmp_path / "gs").exists()


def test_prepare_output_under_a_file_is_exit_2_before_the_work(tmp_path, scene, capsys):
    _, gt = scene
    (tmp_path / "plain.txt").write_text("x")
    code, _, err = run(capsys, "prepare", gt, "-q", "-o", tmp_path / "plain.txt" / "prep")
    assert code == 2
    assert "plain.txt: the prepared folder would be under this file, which is not a folder" in err


def test_control_characters_in_names_are_shown_not_run_on_the_console(tmp_path, scene, capsys):
    """Issue 42: a method name (or a file name) with an escape sequence reached the terminal as
    is: it could recolour, retitle or clear it, and a carriage return overwrote the line. The
    console shows such characters as escapes; the results file keeps the name, and a
    leaderboard's CSV or JSON on a redirected stdout is data, written as it is."""
    pred, gt = scene
    name = "evil\x1b]0;pwned\x07\rm\x85"
    code, out, err = run(capsys, "score", pred, gt, "--metrics", "psnr", "-q", "--focus", "none",
                         "--no-temporal", "--method", name, "-o", tmp_path / "r.json")
    assert code == 0, err
    assert "evil\\x1b]0;pwned\\x07\\x0dm\\x85 on " in out
    assert not any(ch in out + err for ch in "\x1b\x07\r\x85")
    assert json.loads((tmp_path / "r.json").read_text())["method"] == name
    code, out, err = run(capsys, "score", tmp_path / "no\x1b[2Jsuch", gt, "-q")
    assert code == 2 and "no\\x1b[2Jsuch" in err and "\x1b" not in err
    for fmt in ("csv", "json"):  # stdout is not a terminal here: the data as it is
        code, out, err = run(capsys, "leaderboard", tmp_path / "r.json", "--format", fmt)
        assert code == 0, err
        assert (name if fmt == "csv" else name[-2:]) in out  # JSON escapes C0 itself

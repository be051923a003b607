"""Leaderboards: combining results across methods and scenes, refusals, intervals, output."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.report import RunRecord, build_results, write_json_atomic
from dynaeval.report.leaderboard import (
    ALL_SCENES,
    BootstrapConfig,
    build_leaderboard,
    render,
    schema_path,
    settings_differences,
)

SETTINGS = {"data_range": 1.0, "quantize": "none", "ssim": {"win_size": 11},
            "lpips": {"enabled": True, "net": "alex", "device": "cpu"},
            "focus": {"source": "boxes", "boxes_file": {"path": "a/boxes.json", "sha256": "ab"}}}


def _write(path, method, scene, psnr, ssim=None, settings=None):
    rows = [{"camera": "c", "frame": str(i), "index": i, "pred": "p", "gt": "g", "psnr": v,
             **({"ssim": ssim[i]} if ssim is not None else {})} for i, v in enumerate(psnr)]
    names = ["psnr"] + (["ssim"] if ssim is not None else [])
    doc = build_results(RunRecord(rows=rows, metric_names=names,
                        method=method, scene=scene, pred_dir="p", gt_dir="g",
                        settings=json.loads(json.dumps(settings or SETTINGS)), unscored_cameras=[],
                        skipped=[], warnings=[], timing={"total_s": 1.0}, version="0"))
    write_json_atomic(path, doc)
    return str(path)


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(1)
    out = {}
    for m, offset in (("A", 0.0), ("B", 2.0)):
        for s, base in (("s1", 20.0), ("s2", 30.0)):
            vals = list(base + offset + rng.normal(0, 1, 12))
            out[(m, s)] = _write(tmp_path / f"{m}_{s}.json", m, s, vals, ssim=list(rng.uniform(0.5, 0.9, 12)))
    return out


def _row(board, method, scene):
    return next(r for r in board["rows"] if r["method"] == method and r["scene"] == scene)


def test_means_per_scene_and_overall_across_methods_and_scenes(files):
    board = build_leaderboard(list(files.values()))
    assert board["methods"] == ["A", "B"] and board["scenes"] == ["s1", "s2"]
    for (m, s), path in files.items():
        frames = json.load(open(path))["frames"]
        assert _row(board, m, s)["values"]["psnr"]["mean"] == pytest.approx(
            np.mean([f["psnr"] for f in frames]), rel=1e-12)
    for m in ("A", "B"):
        overall = _row(board, m, ALL_SCENES)["values"]["psnr"]
        per_scene = [_row(board, m, s)["values"]["psnr"]["mean"] for s in ("s1", "s2")]
        assert overall["mean"] == pytest.approx(np.mean(per_scene), rel=1e-12)  # scenes weigh equally
        assert overall["ci_low"] < overall["mean"] < overall["ci_high"]
    assert board["notes"] == []


def test_interval_matches_an_independent_bootstrap_and_normal_approximation(tmp_path):
    vals = list(np.random.default_rng(3).normal(25.0, 2.0, 400))
    path = _write(tmp_path / "r.json", "m", "s", vals)
    cfg = BootstrapConfig(n_boot=1000, seed=0)
    e = _row(build_leaderboard([path], bootstrap=cfg), "m", "s")["values"]["psnr"]
    # independent loop-based bootstrap with another generator: same interval within MC noise
    rng = np.random.default_rng(12345)
    means = [np.mean(rng.choice(vals, size=len(vals), replace=True)) for _ in range(2000)]
    lo, hi = np.percentile(means, [2.5, 97.5])
    half = 1.96 * np.std(vals) / np.sqrt(len(vals))
    assert e["ci_low"] == pytest.approx(lo, abs=0.25 * half)
    assert e["ci_high"] == pytest.approx(hi, abs=0.25 * half)
    assert e["ci_high"] - e["ci_low"] == pytest.approx(2 * half, rel=0.15)


def test_constant_values_give_a_zero_width_interval(tmp_path):
    e = _row(build_leaderboard([_write(tmp_path / "r.json", "m", "s", [21.5] * 5)]),
             "m", "s")["values"]["psnr"]
    assert e["ci_low"] == e["mean"] == e["ci_high"] == 21.5


def test_intervals_are_seeded_and_independent_of_file_order(files):
    paths = list(files.values())
    a = build_leaderboard(paths)
    b = build_leaderboard(paths[::-1])
    assert _row(a, "B", "s2") == _row(b, "B", "s2")
    assert _row(a, "A", ALL_SCENES) == _row(b, "A", ALL_SCENES)
    c = build_leaderboard(paths, bootstrap=BootstrapConfig(seed=1))
    assert _row(c, "A", "s1")["values"]["psnr"] != _row(a, "A", "s1")["values"]["psnr"]


def test_refuses_incompatible_settings_naming_field_and_files(tmp_path, files):
    other = json.loads(json.dumps(SETTINGS))
    other["ssim"]["win_size"] = 7
    bad = _write(tmp_path / "bad.json", "C", "s1", [20.0, 21.0], settings=other)
    first = files[("A", "s1")]
    with pytest.raises(InputError, match=r"'ssim.win_size' is 11 in .*A_s1.json but 7 in .*bad.json"):
        build_leaderboard([first, bad])
    board = build_leaderboard([first, bad], force=True)
    assert board["forced"] == [{"field": "ssim.win_size", "file_a": first, "value_a": 11,
                                "file_b": bad, "value_b": 7}]
    assert "ssim.win_size" in render(board, "md")


@pytest.mark.parametrize("field,value", [("quantize", "round"), ("lpips.net", "vgg"),
                                         ("focus.boxes_file.sha256", "cd"), ("data_range", 255.0)])
def test_each_number_changing_setting_is_compared(tmp_path, field, value):
    other = json.loads(json.dumps(SETTINGS))
    d = other
    *parents, leaf = field.split(".")
    for p in parents:
        d = d[p]
    d[leaf] = value
    a = _write(tmp_path / "a.json", "A", "s", [20.0])
    b = _write(tmp_path / "b.json", "B", "s", [21.0], settings=other)
    with pytest.raises(InputError, match=f"'{field}'"):
        build_leaderboard([a, b])


def test_paths_devices_and_missing_lpips_are_not_incompatibilities():
    other = json.loads(json.dumps(SETTINGS))
    other["lpips"].update(enabled=False, device="cuda", unavailable="no weights")
    other["focus"]["boxes_file"]["path"] = "elsewhere/boxes.json"
    other["allow_missing"] = True
    assert settings_differences(SETTINGS, other) == []


def test_sections_of_metrics_that_ran_in_one_file_only_are_not_compared():
    with_temporal = dict(json.loads(json.dumps(SETTINGS)), temporal={"flow": {"method": "dis"}})
    assert settings_differences(with_temporal, SETTINGS) == []  # --no-temporal run
    no_lpips = json.loads(json.dumps(SETTINGS))
    no_lpips["lpips"].update(enabled=False, net="vgg")
    assert settings_differences(SETTINGS, no_lpips) == []  # vgg never ran: nothing to differ
    vgg = json.loads(json.dumps(SETTINGS))
    vgg["lpips"]["net"] = "vgg"
    other_flow = dict(json.loads(json.dumps(SETTINGS)), temporal={"flow": {"method": "tvl1"}})
    assert settings_differences(SETTINGS, vgg) == [("lpips.net", "alex", "vgg")]
    assert settings_differences(with_temporal, other_flow) == [("temporal.flow.method", "dis", "tvl1")]


def test_duplicate_method_scene_pair_is_an_error(tmp_path, files):
    dup = _write(tmp_path / "dup.json", "A", "s1", [1.0])
    with pytest.raises(InputError, match=r"method 'A' on scene 's1' appears twice: in .*A_s1.json and .*dup.json"):
        build_leaderboard([files[("A", "s1")], dup])


def test_other_errors(tmp_path, files):
    with pytest.raises(InputError, match="at least one results file"):
        build_leaderboard([])
    with pytest.raises(InputError, match="metrics not in any results file: lpips"):
        build_leaderboard(list(files.values()), metrics=["lpips"])
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"schema": "dynaeval/results/v0"}))
    with pytest.raises(InputError, match="results schema 'dynaeval/results/v0' is not one this dynaeval reads"):
        build_leaderboard([str(old)])
    with pytest.raises(InputError, match="format must be one of"):
        render(build_leaderboard([files[("A", "s1")]]), "xls")
    with pytest.raises(InputError, match="n_boot >= 1"):
        build_leaderboard([files[("A", "s1")]], bootstrap=BootstrapConfig(n_boot=0))


def test_methods_with_different_scene_sets_are_flagged(files):
    board = build_leaderboard([files[("A", "s1")], files[("A", "s2")], files[("B", "s1")]])
    assert "different scenes" in board["notes"][0]


def test_null_summary_gives_null_mean_without_interval(tmp_path):
    e = _row(build_leaderboard([_write(tmp_path / "r.json", "m", "s", [None, None])]),
             "m", "s")["values"]["psnr"]
    assert e == {"mean": None, "ci_low": None, "ci_high": None, "n": 0}


def test_cli_formats_grouping_and_atomic_output(tmp_path, files, capsys):
    paths = list(files.values())
    assert main(["leaderboard", *paths, "--by", "scene"]) == 0
    md = capsys.readouterr().out
    lines = [ln for ln in md.splitlines() if ln.startswith("| ")]
    assert [ln.split(" | ")[1] for ln in lines[1:]] == ["s1", "s1", "s2", "s2", ALL_SCENES, ALL_SCENES]
    out = tmp_path / "board.csv"
    assert main(["leaderboard", *paths, "--format", "csv", "-o", str(out)]) == 0
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert len(rows) == 6 * 2 and {r["metric"] for r in rows} == {"psnr", "ssim"}
    assert main(["leaderboard", *paths, "--format", "json", "-o", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["leaderboard", *paths, "--format", "json", "-o", str(out), "--overwrite"]) == 0
    assert json.loads(out.read_text())["schema"] == "dynaeval/leaderboard/v1"
    html = tmp_path / "board.html"
    assert main(["leaderboard", *paths, "--format", "html", "-o", str(html)]) == 0
    text = html.read_text()
    assert text.count("<tr") == 7 and "http" not in text
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temp left


def test_cli_refusal_exit_2_and_force(tmp_path, files, capsys):
    other = json.loads(json.dumps(SETTINGS))
    other["quantize"] = "truncate"
    bad = _write(tmp_path / "bad.json", "C", "s1", [20.0], settings=other)
    assert main(["leaderboard", files[("A", "s1")], bad]) == 2
    assert "'quantize'" in capsys.readouterr().err
    assert main(["leaderboard", files[("A", "s1")], bad, "--force"]) == 0
    assert "differing setting 'quantize'" in capsys.readouterr().err


def test_forced_csv_keeps_the_differing_settings_in_a_column_pandas_reads(tmp_path, files,
                                                                         capsys):
    """``--force --format csv`` carries the list md and json keep (issue 32, item 9: it was
    dropped), as a ``settings_differ`` column that pandas.read_csv reads without options."""
    pd = pytest.importorskip("pandas")
    other = json.loads(json.dumps(SETTINGS))
    other["quantize"] = "truncate"
    other["ssim"]["win_size"] = 7
    bad = _write(tmp_path / "bad.json", "C", "s1", [20.0], settings=other)
    out = tmp_path / "board.csv"
    assert main(["leaderboard", files[("A", "s1")], bad, "--force", "--format", "csv",
                 "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert len(table) == 4 * 2 and set(table["metric"]) == {"psnr", "ssim"}
    assert set(table["settings_differ"]) == {"quantize; ssim.win_size"}
    assert table["mean"].dtype.kind == "f"  # the numbers still parse as numbers
    agree = tmp_path / "agree.csv"
    assert main(["leaderboard", *files.values(), "--format", "csv", "-o", str(agree)]) == 0
    assert {r["settings_differ"] for r in csv.DictReader(io.StringIO(agree.read_text()))} == {""}


def test_leaderboard_validates_against_shipped_schema(files, tmp_path):
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(schema_path().read_text())
    other = json.loads(json.dumps(SETTINGS))
    other["quantize"] = "round"
    forced = _write(tmp_path / "f.json", "C", "s1", [20.0, 21.0], settings=other)
    board = json.loads(render(build_leaderboard([*files.values(), forced], force=True), "json"))
    jsonschema.validate(board, schema)
    board["rows"][0]["values"]["psnr"]["mean"] = "20"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(board, schema)



def test_boxes_files_are_compared_within_a_scene_only():
    from dynaeval.report.leaderboard import _check

    def doc(method, scene, sha):
        return {"method": method, "scene": scene,
                "settings": {"focus": {"source": "boxes", "boxes_file": {"sha256": sha}}}}

    ok = [doc("a", "s1", "x"), doc("b", "s1", "x"), doc("a", "s2", "y"), doc("b", "s2", "y")]
    assert _check(ok, ["1", "2", "3", "4"], force=False) == []
    bad = [doc("a", "s1", "x"), doc("a", "s2", "y"), doc("b", "s2", "z")]
    with pytest.raises(InputError, match=r"'focus.boxes_file.sha256' is 'y' in 2 but 'z' in 3"):
        _check(bad, ["1", "2", "3"], force=False)


def test_no_masked_run_beside_a_full_run_is_comparable(tmp_path, capsys):
    """Issue 16 item 14: focus.motion exists only where the masks were computed; a --no-masked
    run was refused ('focus.motion.kind' is 'isg' in ... but None in ...)."""
    full = json.loads(json.dumps(SETTINGS))
    full["focus"]["motion"] = {"kind": "isg", "min_frames": 3}
    assert settings_differences(full, SETTINGS) == []
    assert settings_differences(SETTINGS, full) == []
    other_kind = json.loads(json.dumps(full))
    other_kind["focus"]["motion"]["kind"] = "ist"  # both ran masks: still compared
    assert settings_differences(full, other_kind) == [("focus.motion.kind", "isg", "ist")]
    presence_off = dict(json.loads(json.dumps(SETTINGS)), presence={"enabled": False, "margin": 2})
    presence_on = dict(json.loads(json.dumps(SETTINGS)), presence={"enabled": True, "margin": 1})
    assert settings_differences(presence_on, presence_off) == []
    a = _write(tmp_path / "a.json", "A", "s", [30.0, 31.0], settings=full)
    b = _write(tmp_path / "b.json", "B", "s", [29.0, 30.0])
    assert main(["leaderboard", a, b]) == 0
    assert "| A | s |" in capsys.readouterr().out


def test_names_with_pipes_newlines_or_formulas_cannot_move_numbers_or_run(tmp_path):
    """Issue 42 item 7: a `|` or a newline in a name put numbers under the wrong headings of
    the Markdown leaderboard; a CSV cell starting with = + - @ is run by spreadsheets."""
    paths = [_write(tmp_path / "a.json", "we|ird\nname", "s", [20.0, 21.0]),
             _write(tmp_path / "b.json", "=HYPERLINK(\"x\")", "-s", [22.0, 23.0])]
    board = build_leaderboard(paths)
    md = render(board, "md").split("\n\n")[0].splitlines()
    assert len(md) == 2 + 2 + 2  # header, rule, 2 methods x (scene + all scenes); no broken row
    for line in md:
        cells = [c for c in line.strip().strip("|").replace("\\|", "").split("|")]
        assert len(cells) == 5  # method, scene, rank, frames, psnr: no cell moved
    assert any("we\\|ird name" in line for line in md)
    rows = list(csv.reader(io.StringIO(render(board, "csv"))))
    assert {r[0] for r in rows[1:]} == {"we|ird\nname", "'=HYPERLINK(\"x\")"}
    assert {r[1] for r in rows[1:]} >= {"'-s"}
    assert all(not r[5] or float(r[5]) for r in rows[1:])  # numbers stay numbers


def test_rows_are_ranked_by_the_sort_metric_and_the_best_marked(tmp_path):
    """Issue 42 item 8: rows followed input order, with no sort option and no best marked."""
    paths = [_write(tmp_path / "c.json", "C", "s", [20.0, 20.2, 19.8], ssim=[0.9, 0.9, 0.9]),
             _write(tmp_path / "a.json", "A", "s", [26.0, 26.2, 25.8], ssim=[0.5, 0.5, 0.5]),
             _write(tmp_path / "b.json", "B", "s", [26.1, 26.0, 26.2], ssim=[0.7, 0.7, 0.7])]
    board = build_leaderboard(paths)
    assert board["ranking"]["metric"] == "psnr"
    assert {r["method"]: r["rank"] for r in board["rows"] if r["scene"] == "s"} == \
        {"B": 1, "A": 2, "C": 3}
    best = board["ranking"]["best"]["s"]
    assert best["psnr"] == {"methods": ["B"], "next": "A", "next_within_interval": True}
    assert best["ssim"]["methods"] == ["C"] and best["ssim"]["next_within_interval"] is False
    md = render(board, "md")
    assert [line.split("|")[1].strip() for line in md.splitlines()[2:5]] == ["B", "B", "A"]
    assert "**26.10**≈" in md and "**0.9000**" in md
    by_ssim = build_leaderboard(paths, sort="ssim")
    assert [r["method"] for r in by_ssim["rows"] if r["scene"] == "s" and r["rank"] == 1] == ["C"]
    with pytest.raises(InputError, match=r"cannot sort by 'ssm'.*did you mean 'ssim'"):
        build_leaderboard(paths, sort="ssm")
    rows = list(csv.DictReader(io.StringIO(render(board, "csv"))))
    assert {(r["method"], r["metric"]): r["best"] for r in rows if r["scene"] == "s"}[("B", "psnr")] == "tie"

"""``dynaeval suite``: a SUITE.toml or the ROOT/<method>/<scene> convention, every pair scored
against its scene's prepared ground truth with the numbers of a plain ``score``, skipped when
scored before with the same settings and inputs, a failing pair reported while the rest
finish, bad input refused before any work (exit 2)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from dynaeval.cli import main, sample_dir
from dynaeval.errors import InputError
from dynaeval.report.leaderboard import schema_path
from dynaeval.run.config import ScoreConfig
from dynaeval.run.evaluate import score
from dynaeval.run.suite import folder_suite, load_suite, read_toml, run_suite, settings_config

METRICS = ["psnr", "ssim"]
NUMBERS = ("frames", "cameras", "summary", "counts", "metrics", "method", "scene")


def _boxes() -> str:
    return str(sample_dir() / "boxes.json")


def _settings_toml() -> str:
    return f'[settings]\nmetrics = {json.dumps(METRICS)}\nfocus = "boxes:{_boxes()}"\n'


def _noisy(src: Path, dst: Path, seed: int) -> None:
    """``src``'s frames with uniform noise of +-(4 + 4 seed) grey levels, as ``dst``."""
    import cv2

    rng = np.random.default_rng(seed)
    for f in sorted(src.rglob("*.png")):
        im = cv2.imread(str(f)).astype(int)
        out = np.clip(im + rng.integers(-4 - 4 * seed, 5 + 4 * seed, im.shape), 0, 255)
        target = dst / f.relative_to(src)
        target.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(target), out.astype(np.uint8))


@pytest.fixture
def tree(tmp_path):
    """ROOT/<m1,m2,m3>/sample and GT/sample: the bundled sample's ground truth, its degraded
    predictions (m1) and two noisy copies of the ground truth."""
    root, gt = tmp_path / "root", tmp_path / "gt"
    shutil.copytree(sample_dir() / "gt", gt / "sample")
    shutil.copytree(sample_dir() / "pred", root / "m1" / "sample")
    _noisy(gt / "sample", root / "m2" / "sample", 1)
    _noisy(gt / "sample", root / "m3" / "sample", 2)
    (tmp_path / "settings.toml").write_text(_settings_toml())
    return tmp_path


def _config():
    return settings_config({"metrics": METRICS, "focus": f"boxes:{_boxes()}"}, "test")


def _numbers(path: Path) -> dict:
    doc = json.loads(path.read_text())
    out = {k: doc[k] for k in NUMBERS}
    out["settings"] = {k: v for k, v in doc["settings"].items() if k != "prepared"}
    return out


def test_folder_suite_equals_plain_score_and_writes_board_and_page(tree):
    suite = folder_suite(tree / "root", tree / "gt", tree / "out", _config())
    assert [(p.method, p.scene) for p in suite.pairs] == [("m1", "sample"), ("m2", "sample"),
                                                          ("m3", "sample")]
    outcome = run_suite(suite, progress=False)
    assert outcome.scored == ["sample__m1", "sample__m2", "sample__m3"] and not outcome.failed
    assert outcome.prepared == ["sample"]
    for method in ("m1", "m2", "m3"):
        got = _numbers(tree / "out" / "results" / f"sample__{method}.json")
        plain = json.loads(json.dumps(dict(score(
            tree / "root" / method / "sample", tree / "gt" / "sample", progress=False,
            metrics=tuple(METRICS), focus=f"boxes:{_boxes()}", method=method, scene="sample"))))
        assert got == {**{k: plain[k] for k in NUMBERS},
                       "settings": {k: v for k, v in plain["settings"].items() if k != "prepared"}}
        assert json.loads((tree / "out" / "results" / f"sample__{method}.json").read_text())[
            "settings"]["prepared"]["path"] == str(tree / "out" / "prepared" / "sample")
    board = json.loads((tree / "out" / "leaderboard.json").read_text())
    assert board["methods"] == ["m1", "m2", "m3"] and board["scenes"] == ["sample"]
    assert "| m2 | sample |" in (tree / "out" / "leaderboard.md").read_text()
    assert (tree / "out" / "leaderboard.csv").read_text().startswith("method,scene,")
    page = (tree / "out" / "index.html").read_text()
    assert page.count("<img src='data:image/png;base64,") == 1  # one scene: one row of tiles
    assert "left to right: ground truth, m1 (focused_psnr" in page and "m3 (focused_psnr" in page


def test_toml_suite_is_the_folder_suite(tree):
    (tree / "suite.toml").write_text(
        'output = "out"\n' + _settings_toml()
        + '[scenes]\nsample = "gt/sample"\n'
          '[methods]\nm1 = "root/m1/{scene}"\nm2 = {sample = "root/m2/sample"}\n')
    suite = load_suite(tree / "suite.toml")
    assert [(p.method, p.scene, p.pred) for p in suite.pairs] == [
        ("m1", "sample", str((tree / "root/m1/sample").resolve())),
        ("m2", "sample", str((tree / "root/m2/sample").resolve()))]
    assert suite.out == tree / "out" and suite.config == _config()
    assert main(["suite", str(tree / "suite.toml"), "-q"]) == 0
    assert sorted(p.name for p in (tree / "out" / "results").glob("*.json")) == [
        "sample__m1.json", "sample__m2.json"]


def test_rerun_scores_only_what_is_missing_or_changed(tree, capsys):
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
            "--settings", str(tree / "settings.toml"), "-q"]
    assert main(args) == 0
    results = tree / "out" / "results"
    before = {p.name: p.stat().st_mtime_ns for p in results.glob("*.json")}
    capsys.readouterr()
    assert main(args) == 0
    assert "0 pair(s) scored, 3 already scored (skipped), 0 failed; 0 scene(s) prepared" in \
        capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in results.glob("*.json")} == before
    (results / "sample__m1.json").unlink()  # a lost result
    _noisy(tree / "gt" / "sample", tree / "root" / "m3" / "sample", 5)  # changed predictions
    suite = folder_suite(tree / "root", tree / "gt", tree / "out", _config())
    outcome = run_suite(suite, progress=False)
    assert outcome.scored == ["sample__m1", "sample__m3"] and outcome.skipped == ["sample__m2"]
    assert outcome.prepared == []  # the ground truth did not change: its folder is reused
    assert (results / "sample__m2.json").stat().st_mtime_ns == before["sample__m2.json"]
    # another number-changing setting: every pair and the ground truth again
    other = settings_config({"metrics": METRICS, "focus": "motion"}, "test")
    outcome = run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", other),
                        progress=False)
    assert len(outcome.scored) == 3 and outcome.prepared == ["sample"]
    # a setting that never changes a number (workers) scores nothing again
    same = settings_config({"metrics": METRICS, "focus": "motion", "workers": 2}, "test")
    assert run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", same),
                     progress=False).scored == []


def test_a_failing_pair_is_reported_and_the_rest_finish(tree, capsys):
    bad = tree / "root" / "m2" / "sample" / "cam07" / "0003.png"
    bad.write_bytes(b"not a png")
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
            "--settings", str(tree / "settings.toml"), "-q"]
    assert main(args) == 1
    out, err = capsys.readouterr()
    assert "2 pair(s) scored, 0 already scored (skipped), 1 failed" in out
    assert "failed: sample__m2: InputError:" in err and "0003.png" in err
    board = json.loads((tree / "out" / "leaderboard.json").read_text())
    assert board["methods"] == ["m1", "m3"]
    _noisy(tree / "gt" / "sample", tree / "root" / "m2" / "sample", 1)  # repaired
    suite = folder_suite(tree / "root", tree / "gt", tree / "out", _config())
    outcome = run_suite(suite, progress=False)
    assert outcome.scored == ["sample__m2"] and not outcome.failed
    assert json.loads((tree / "out" / "leaderboard.json").read_text())["methods"] == [
        "m1", "m2", "m3"]


def _toml(tree: Path, text: str) -> Path:
    path = tree / "suite.toml"
    path.write_text(text)
    return path


GOOD = '[scenes]\nsample = "gt/sample"\n[methods]\nm1 = "root/m1/{scene}"\n'


@pytest.mark.parametrize(("text", "match"), [
    ("colour = 1\noutput = 'o'\n" + GOOD, "unknown key 'colour'"),
    ("output = 'o'\n" + GOOD + "m2 = 1\n", r"\[methods\] m2 must be a folder path"),
    ("output = 'o'\n[settings]\nmetric = ['psnr']\n" + GOOD, r"\[settings\] metric: not a setting"),
    ("output = 'o'\n[settings]\nmethod = 'x'\n" + GOOD, r"\[settings\] method: set by the suite"),
    ("output = 'o'\n[settings]\nworkers = 0\n" + GOOD, r"\[settings\]: workers must be"),
    ("output = 'o'\n[scenes]\n", r"\[scenes\] is missing or empty"),
    ("output = 'o'\n[scenes]\nsample = 'gt/nope'\n[methods]\nm1 = 'x'\n",
     r"\[scenes\] sample: no such folder .*gt/nope"),
    ("output = 'o'\n[scenes]\nsample = 'gt/sample'\n", r"\[methods\] is missing or empty"),
    ("output = 'o'\n[scenes]\nsample = 'gt/sample'\n[methods]\nm9 = 'root/m9/{scene}'\n",
     r"\[methods\] m9 \(scene sample\): no such folder"),
    ("output = 'o'\n[scenes]\nsample = 'gt/sample'\nb = 'gt/sample'\n[methods]\nm1 = 'root/m1'\n",
     r"m1 = 'root/m1' has no \{scene\}"),
    ("output = 'o'\n[scenes]\nsample = 'gt/sample'\n[methods]\nm1 = {other = 'root/m1/sample'}\n",
     r"scene 'other' is not in \[scenes\]"),
    ("output = 'o'\n[scenes]\n'a b' = 'gt/sample'\n[methods]\nm1 = 'x'\n", r"\[scenes\] 'a b': names"),
    (GOOD, "no output folder"),
    ("output = 'o'\n[scenes\n", "not valid TOML"),
])
def test_bad_suite_files_are_refused_naming_the_key(tree, capsys, text, match):
    path = _toml(tree, text)
    with pytest.raises(InputError, match=match):
        load_suite(path)
    assert main(["suite", str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and not (tree / "o").exists()


def test_bad_folder_forms_are_refused(tree, capsys):
    (tree / "root" / "m1" / "lost").mkdir()
    with pytest.raises(InputError, match="no ground truth for scene 'lost'"):
        folder_suite(tree / "root", tree / "gt", tree / "out")
    shutil.rmtree(tree / "root" / "m1" / "lost")
    with pytest.raises(InputError, match="GT is not a folder"):
        folder_suite(tree / "root", tree / "nope", tree / "out")
    (tree / "empty").mkdir()
    with pytest.raises(InputError, match="no ROOT/<method>/<scene> folder"):
        folder_suite(tree / "empty", tree / "gt", tree / "out")
    (tree / "file").write_text("x")
    with pytest.raises(InputError, match="suite output folder"):
        folder_suite(tree / "root", tree / "gt", tree / "file" / "out")
    assert main(["suite", str(tree / "root"), "-q"]) == 2
    assert "the folder form needs --gt GT and -o OUT" in capsys.readouterr().err
    _toml(tree, "output = 'o'\n" + GOOD)
    assert main(["suite", str(tree / "suite.toml"), "--gt", str(tree / "gt"), "-q"]) == 2
    assert "--gt is for the folder form" in capsys.readouterr().err
    (tree / "bad.toml").write_text("[settings]\nfocus = 'nowhere'\n")
    assert main(["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
                 "--settings", str(tree / "bad.toml"), "-q"]) == 2
    assert "bad.toml: [settings]:" in capsys.readouterr().err
    assert not (tree / "out").exists()


def test_a_scene_whose_ground_truth_fails_fails_its_pairs_only(tree, capsys):
    shutil.copytree(tree / "gt" / "sample", tree / "gt" / "broken")
    shutil.copytree(tree / "root" / "m1" / "sample", tree / "root" / "m1" / "broken")
    (tree / "gt" / "broken" / "eval00" / "0002.png").write_bytes(b"\x89PNG broken")
    suite = folder_suite(tree / "root", tree / "gt", tree / "out", _config())
    outcome = run_suite(suite, progress=False)
    assert outcome.scored == ["sample__m1", "sample__m2", "sample__m3"]
    assert list(outcome.failed) == ["broken", "broken__m1"]
    assert "0002.png" in outcome.failed["broken"]
    assert outcome.failed["broken__m1"].startswith("ground truth not prepared: InputError:")
    assert json.loads((tree / "out" / "leaderboard.json").read_text())["scenes"] == ["sample"]


def test_without_a_toml_parser_the_suite_file_is_refused(tree, monkeypatch):
    """Python 3.10 without tomli: exit 2 saying what to install (not an ImportError)."""
    import sys

    (tree / "suite.toml").write_text("output = 'o'\n" + GOOD)
    monkeypatch.setitem(sys.modules, "tomllib", None)
    monkeypatch.setitem(sys.modules, "tomli", None)
    with pytest.raises(InputError, match="needs Python >= 3.11 or the tomli package: pip install"):
        load_suite(tree / "suite.toml")


def test_the_page_shows_a_perfect_method_too(tree):
    """A method equal to the ground truth (infinite PSNR, null in the results) is shown on the
    same frame as the others, not left without a frame."""
    shutil.rmtree(tree / "root" / "m3")
    shutil.copytree(tree / "gt" / "sample", tree / "root" / "m3" / "sample")
    run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", _config()), progress=False)
    page = (tree / "out" / "index.html").read_text()
    assert page.count("<img src='data:image/png;base64,") == 1
    assert "m3 (focused_psnr n/a)" in page and "m1 (focused_psnr 2" in page


def test_an_interrupted_suite_keeps_what_it_scored_and_a_rerun_finishes(tree, monkeypatch, capsys):
    import dynaeval.run.suite as suite_module

    real, calls = suite_module.score_task, []

    def interrupted_at_the_second(*args):
        calls.append(args[0].name)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(suite_module, "score_task", interrupted_at_the_second)
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
            "--settings", str(tree / "settings.toml"), "-q"]
    assert main(args) == 130
    assert "interrupted; the pairs scored so far are kept" in capsys.readouterr().err
    assert sorted(p.name for p in (tree / "out" / "results").iterdir()) == [
        "sample__m1.json", "sample__m1.key"]
    monkeypatch.setattr(suite_module, "score_task", real)
    outcome = run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", _config()),
                        progress=False)
    assert outcome.skipped == ["sample__m1"] and outcome.scored == ["sample__m2", "sample__m3"]
    assert outcome.prepared == []


def test_a_second_suite_into_the_same_out_is_exit_2_and_writes_nothing(tree, capsys):
    """Two suites into one OUT would score the same pairs twice and write over each other's
    files: while one holds OUT (its lock file), another is refused before any work."""
    from dynaeval.io.lock import hold_folder

    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
            "--settings", str(tree / "settings.toml"), "-q"]
    (tree / "out").mkdir()
    with hold_folder(tree / "out"):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert f"suite output folder {tree / 'out'} is in use by another dynaeval run" in err
        assert not list((tree / "out" / "results").iterdir())
        assert not list((tree / "out" / "prepared").iterdir())
    assert main(args) == 0
    assert not (tree / "out" / ".dynaeval.lock").exists()


def test_on_an_executor_a_scene_is_scored_while_another_is_still_being_prepared(tree, monkeypatch):
    """On a pool (or Dask) a scene's pairs start as soon as its own ground truth is prepared,
    not after every scene's: scene ``slow``'s prepare waits (bounded) until every pair of
    ``sample`` has been scored, which happens only if those pairs did not wait for it."""
    import concurrent.futures
    import threading

    import dynaeval.run.suite as suite_module

    shutil.copytree(tree / "gt" / "sample", tree / "gt" / "slow")
    for m in ("m1", "m2", "m3"):
        shutil.copytree(tree / "root" / m / "sample", tree / "root" / m / "slow")
    sample_scored, seen = threading.Event(), []
    real = suite_module.prepare_task

    def prepare_task(gt, out, config):
        if Path(gt).name == "slow":
            seen.append(sample_scored.wait(timeout=30))
        return real(gt, out, config)

    def on_result(name):
        if sum(n.startswith("sample__") for n in [*done, name]) == 3:
            sample_scored.set()
        done.append(name)

    done: list[str] = []
    monkeypatch.setattr(suite_module, "prepare_task", prepare_task)
    suite = folder_suite(tree / "root", tree / "gt", tree / "out", _config())
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        outcome = run_suite(suite, pool, progress=False, on_result=on_result)
    assert seen == [True]
    assert not outcome.failed and len(outcome.scored) == 6
    assert outcome.scored == [p.name for p in suite.pairs]  # reported in the suite's order
    monkeypatch.setattr(suite_module, "prepare_task", real)
    inline = run_suite(folder_suite(tree / "root", tree / "gt", tree / "inline", _config()),
                       progress=False)
    assert inline.scored == outcome.scored
    for name in outcome.scored:  # the same numbers as one task after another
        assert (_numbers(tree / "out" / "results" / f"{name}.json")
                == _numbers(tree / "inline" / "results" / f"{name}.json"))


def test_a_scene_prepared_in_an_older_format_is_prepared_again(tree, monkeypatch):
    """The prepared format is in a scene's prepare key: a folder a previous dynaeval wrote in
    its older format (format 3, before the ground-truth pair terms) is prepared again instead of
    failing every pair that has to be scored against it."""
    from dynaeval.io.prepared import FORMAT_VERSION, manifest_id
    from dynaeval.run import suite as module

    with monkeypatch.context() as m:  # the key and the folder of the previous format
        m.setattr(module, "FORMAT_VERSION", FORMAT_VERSION - 1)
        run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", _config()),
                  progress=False)
    path = tree / "out" / "prepared" / "sample" / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["format_version"] = FORMAT_VERSION - 1
    manifest["id"] = manifest_id(manifest)
    path.write_text(json.dumps(manifest))
    (tree / "out" / "results" / "sample__m1.json").unlink()
    outcome = run_suite(folder_suite(tree / "root", tree / "gt", tree / "out", _config()),
                        progress=False)
    assert outcome.prepared == ["sample"] and not outcome.failed
    assert outcome.scored == ["sample__m1"]
    assert json.loads(path.read_text())["format_version"] == FORMAT_VERSION


def test_two_pairs_that_would_write_one_results_file_are_refused_before_any_work(tree, capsys):
    """Issue 42 item 2: scene 'a' + method 'x__m' and scene 'a__x' + method 'm' wrote one file."""
    path = _toml(tree, "output = 'o'\n[scenes]\na = 'gt/sample'\na__x = 'gt/sample'\n"
                       "[methods]\nx__m = {a = 'root/m1/sample'}\nm = {a__x = 'root/m2/sample'}\n")
    with pytest.raises(InputError, match=r"would both write results/a__x__m\.json"):
        load_suite(path)
    assert main(["suite", str(path), "-q"]) == 2
    assert "would both write" in capsys.readouterr().err and not (tree / "o").exists()


def test_an_output_folder_of_the_users_own_files_needs_overwrite(tree, capsys):
    """Issue 42 item 3: `suite -o DIR` replaced the user's own index.html and leaderboard.md."""
    out = tree / "mine"
    out.mkdir()
    (out / "index.html").write_text("my page")
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(out), "--settings",
            str(tree / "settings.toml"), "-q"]
    assert main(args) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "index.html").read_text() == "my page" and sorted(os.listdir(out)) == ["index.html"]
    assert main([*args, "--overwrite"]) == 0
    assert (out / ".dynaeval-suite").is_file()
    assert main(args) == 0  # the suite's own folder now: a rerun needs no --overwrite
    capsys.readouterr()


def test_an_output_folder_inside_an_input_is_refused_before_any_work(tree, capsys):
    """Issue 42 item 5: an OUT inside a ground truth or prediction folder was hashed into the
    skip keys (every rerun redid everything); OUT = ROOT read OUT/prepared as a method."""
    for out in (tree / "gt" / "sample" / "out", tree / "root" / "m1" / "sample" / "out",
                tree / "root"):
        with pytest.raises(InputError, match="inside an input of the suite"):
            folder_suite(tree / "root", tree / "gt", out)
        assert main(["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(out),
                     "-q"]) == 2
        assert "inside an input" in capsys.readouterr().err
    assert not (tree / "gt" / "sample" / "out").exists()
    assert main(["suite", str(tree / "nonexist.toml"), "-q"]) == 2
    assert "nonexist.toml: no such file or folder" in capsys.readouterr().err



def test_the_suite_repairs_what_it_owns(tree, capsys):
    """Issue 42 item 4: a truncated OUT/results/*.json (key file intact) made every later run
    exit 2; a damaged OUT/prepared/<scene> file failed the scene on every rerun; a kill during
    prepare left a .tmp folder forever. Each is named on the console and redone or removed."""
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out"),
            "--settings", str(tree / "settings.toml"), "-q"]
    assert main(args) == 0
    capsys.readouterr()
    out = tree / "out"
    before = _numbers(out / "results" / "sample__m2.json")
    text = (out / "results" / "sample__m2.json").read_text()
    (out / "results" / "sample__m2.json").write_text(text[: len(text) // 2])
    manifest = json.loads((out / "prepared" / "sample" / "manifest.json").read_text())
    damaged = out / "prepared" / "sample" / next(iter(manifest["hashes"]))
    damaged.write_bytes(damaged.read_bytes()[:-1] + b"\0")
    (out / "prepared" / ".sample.abc123.tmp").mkdir()
    assert main(args) == 0
    said = capsys.readouterr().out
    assert "repaired: results/sample__m2.json is damaged" in said
    assert "repaired: prepared/sample is damaged" in said
    assert "repaired: prepared/.sample.abc123.tmp (left by an interrupted prepare) removed" in said
    assert not (out / "prepared" / ".sample.abc123.tmp").exists()
    assert _numbers(out / "results" / "sample__m2.json") == before
    assert main(args) == 0 and "repaired" not in capsys.readouterr().out  # all well again


def test_a_deep_toml_and_bad_scheduler_addresses_are_exit_2_not_tracebacks(tree, capsys):
    """Issue 42 item 10: a 100,000-deep TOML was a RecursionError traceback; --scheduler
    notanaddress, tcp://host:notaport and foo://... were ValueError tracebacks."""
    deep = _toml(tree, "a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(InputError, match="nested deeper than 64 levels"):
        read_toml(deep)
    assert main(["suite", str(deep), "-q"]) == 2
    assert "nested deeper" in capsys.readouterr().err
    suite = _toml(tree, "output = 'o'\n" + GOOD)
    for address in ("notanaddress", "tcp://host:notaport", "foo://x:1"):
        assert main(["suite", str(suite), "--scheduler", address, "-q"]) == 2
        err = capsys.readouterr().err
        assert address in err and "Traceback" not in err


@pytest.mark.parametrize(("setting", "match"), [
    ("allow_missing = 'false'", r"allow_missing must be true or false \(a boolean\), got 'false' \(str\)"),
    ("temporal = 'no'", r"temporal must be true or false \(a boolean\), got 'no' \(str\)"),
    ("presence = 1", r"presence must be true or false \(a boolean\), got 1 \(int\)"),
    ("focus = 'boxes:bad.json'", r"\[settings\]: .*bad\.json"),
])
def test_settings_are_type_checked_once_before_any_work(tree, capsys, setting, match):
    """Issue 42 item 6: `allow_missing = "false"` counted as true, `temporal = "no"` still
    computed temporal terms, a bad boxes file failed every task (exit 1) after the work started."""
    (tree / "bad.json").write_text("{not json")
    path = _toml(tree, f"output = 'o'\n[settings]\n{setting}\n" + GOOD)
    with pytest.raises(InputError, match=match):
        load_suite(path)
    assert main(["suite", str(path), "-q"]) == 2
    assert not (tree / "o").exists()
    capsys.readouterr()
    if "boolean" in match:
        key, value = setting.split(" = ")
        with pytest.raises(InputError, match=match):  # the library refuses it the same way
            ScoreConfig(**{key: json.loads(value.replace("'", '"'))})


def test_a_suite_of_three_methods_and_two_scenes_is_ranked_with_the_best_marked(tree, capsys):
    """Issue 42 item 8's done-when: a known quality order (m2: noise +-8 grey levels, m3: +-12,
    m1: the sample's blurred stand-in) is the leaderboard's order, the best marked, printed on
    stdout (it printed only the files' paths); ``--sort`` ranks by another metric, as
    ``dynaeval leaderboard --sort``; the suite prints the run's warnings as `score` does; its
    page's table scrolls in its own box."""
    shutil.copytree(tree / "gt" / "sample", tree / "gt" / "sample2")
    for m in ("m1", "m2", "m3"):
        shutil.copytree(tree / "root" / m / "sample", tree / "root" / m / "sample2")
    out = tree / "out"
    args = ["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(out),
            "--settings", str(tree / "settings.toml"), "-q"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    md = (out / "leaderboard.md").read_text()
    assert md in printed and printed.count("| method | scene | rank |") == 1
    md = md.splitlines()
    methods = [line.split("|")[1].strip() for line in md[2:] if line.startswith("| m")]
    assert methods == ["m2"] * 3 + ["m3"] * 3 + ["m1"] * 3  # 2 scenes + (all), best first
    assert all("**" in line.split("|")[5] for line in md[2:5])  # m2's PSNR: the best, bold
    assert main([*args, "--sort", "ssim"]) == 0  # nothing scored again: only the ranking
    printed = capsys.readouterr().out
    board = json.loads((out / "leaderboard.json").read_text())
    assert board["ranking"]["metric"] == "ssim" and "0 pair(s) scored" in printed
    by_ssim = sorted({r["method"]: r["values"]["ssim"]["mean"] for r in board["rows"]
                      if r["scene"] == "sample"}.items(), key=lambda kv: -kv[1])
    md = (out / "leaderboard.md").read_text()
    assert [m for m, _ in by_ssim] == ["m2", "m1", "m3"]  # m1 above m3, unlike by PSNR
    assert [line.split("|")[1].strip() for line in md.splitlines()
            if line.startswith("| m") and line.split("|")[2].strip() == "sample"] == \
        ["m2", "m1", "m3"]
    assert md in printed
    assert "<div class='table'><table>" in (out / "index.html").read_text()
    (tree / "default.toml").write_text(f'[settings]\nfocus = "boxes:{_boxes()}"\n')
    main(["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(tree / "out2"),
          "--settings", str(tree / "default.toml"), "-q"])
    err = capsys.readouterr().err
    lpips = [line for line in err.splitlines() if "LPIPS" in line and "warning" in line]
    if not (out.parent / "out2" / "results" / "sample__m1.json").is_file():
        pytest.fail(err)
    if "lpips" not in json.loads((tree / "out2" / "results" / "sample__m1.json").read_text())[
            "summary"]:  # no LPIPS weights on this machine: the suite says so, once
        assert len(lpips) == 1 and "(6 pair(s)" in lpips[0], err


@pytest.mark.parametrize(("sort", "message"), [
    ("psnrr", "cannot sort by 'psnrr': not a metric (did you mean 'psnr'?)"),
    ("lpips", "cannot sort by 'lpips': the suite does not compute it: 'lpips' is not among the "
              "settings' metrics"),
    ("flicker", "cannot sort by 'flicker': the suite does not compute it: the temporal terms "
                "are off"),
])
def test_a_suite_sort_metric_it_does_not_compute_is_exit_2_before_any_work(tree, capsys, sort,
                                                                             message):
    (tree / "notemporal.toml").write_text(_settings_toml() + "temporal = false\n")
    out = tree / "out"
    code = main(["suite", str(tree / "root"), "--gt", str(tree / "gt"), "-o", str(out),
                 "--settings", str(tree / "notemporal.toml"), "-q", "--sort", sort])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()  # before any work: not even the output folder


def test_costs_are_columns_and_the_page_plots_quality_against_cost(tree, capsys):
    """Issue 42 item 9: methods are compared by quality and cost; the leaderboard shows the
    costs SUITE.toml gives (blank when not given, never guessed) and the page plots quality
    against cost per scene with the Pareto front."""
    text = ("output = 'o'\n" + _settings_toml() + "[scenes]\nsample = 'gt/sample'\n[methods]\n"
            "m1 = 'root/m1/{scene}'\nm2 = 'root/m2/{scene}'\nm3 = 'root/m3/{scene}'\n"
            "[costs.m1]\ntrain_minutes = 5\nrender_fps = 30\n"
            "[costs.m2]\ntrain_minutes = 60\nmemory_gb = 7.5\n"
            "[costs.m3]\ntrain_minutes = 90\n")
    path = _toml(tree, text)
    assert main(["suite", str(path), "-q"]) == 0
    md = (tree / "o" / "leaderboard.md").read_text()
    assert "| train min | render fps | memory GB |" in md.splitlines()[0] + " |"
    row = next(line for line in md.splitlines() if line.startswith("| m2 | sample |"))
    assert [c.strip() for c in row.rstrip(" |").split("|")[-3:]] == ["60", "", "7.5"]
    board = json.loads((tree / "o" / "leaderboard.json").read_text())
    assert board["costs"] == {"m1": {"train_minutes": 5.0, "render_fps": 30.0},
                              "m2": {"train_minutes": 60.0, "memory_gb": 7.5},
                              "m3": {"train_minutes": 90.0}}
    page = (tree / "o" / "index.html").read_text()
    assert "Quality against cost" in page and "quality against cost' src='data:image/png" in page
    capsys.readouterr()
    for bad, match in (("[costs.m9]\ntrain_minutes = 1\n", r"\[costs\] m9: not a method"),
                       ("[costs.m1]\ntrain_hours = 1\n", r"\[costs.m1\] train_hours: not a cost"),
                       ("[costs.m1]\ntrain_minutes = -1\n", r"must be a number >= 0")):
        with pytest.raises(InputError, match=match):
            load_suite(_toml(tree, "output = 'o2'\n" + GOOD + bad))


def test_the_pareto_front_is_what_no_other_method_beats_on_both():
    from dynaeval.report.suite_page import pareto_front

    pts = [(5.0, 20.0), (60.0, 30.0), (90.0, 25.0), (60.0, 29.0), (1.0, 10.0)]
    assert pareto_front(pts, cheaper_is_lower=True, better_is_higher=True) == [4, 0, 1]
    assert pareto_front(pts, cheaper_is_lower=False, better_is_higher=True) == [2, 1]


def test_costs_are_read_from_a_nerfbaselines_run_folder_and_the_toml_wins(tree, capsys):
    """Issue 42 item 9: what a method's run folder already says it cost (NeRFBaselines'
    info.json beside color/) is a leaderboard column and on the page; SUITE.toml's figure wins;
    a figure nobody gives stays blank. Before, only SUITE.toml's [costs] were shown."""
    from tests.dynaeval.io.test_run_costs import nb_info

    nb = tree / "runs" / "nb"
    shutil.copytree(tree / "root" / "m2" / "sample", nb_info(nb, total_train_time=2700.0),
                    dirs_exist_ok=True)
    text = ("output = 'o'\n" + _settings_toml() + "[scenes]\nsample = 'gt/sample'\n[methods]\n"
            "m1 = 'root/m1/{scene}'\nnb = 'runs/nb/color'\nm3 = 'root/m3/{scene}'\n"
            "[costs.m3]\nrender_fps = 2\n")
    assert main(["suite", str(_toml(tree, text)), "-q"]) == 0
    capsys.readouterr()
    board = json.loads((tree / "o" / "leaderboard.json").read_text())
    costs = {(r["method"], r["scene"]): r.get("costs") for r in board["rows"]}
    assert costs[("nb", "sample")] == costs[("nb", "(all)")] == {"train_minutes": 45.0,
                                                                  "memory_gb": 6.0}
    assert costs[("m3", "sample")] == {"render_fps": 2.0} and costs[("m1", "sample")] is None
    assert board["cost_sources"] == [{"method": "nb", "scene": "sample",
                                      "file": str(nb / "info.json")}]
    md = (tree / "o" / "leaderboard.md").read_text().splitlines()
    row = next(line for line in md if line.startswith("| nb | sample |"))
    assert [c.strip() for c in row.rstrip(" |").split("|")[-3:]] == ["45", "", "6"]
    assert "<img alt='sample quality against cost'" in (tree / "o" / "index.html").read_text()
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(board, json.loads(schema_path().read_text()))
    (nb / "info.json").write_text(json.dumps({"nb_version": "1", "total_train_time": "long"}))
    text = text.replace("[costs.m3]", "[costs.nb]\ntrain_minutes = 50\n[costs.m3]")
    assert main(["suite", str(_toml(tree, text)), "-q"]) == 0
    err = capsys.readouterr().err
    assert "info.json: total_train_time is 'long', not a number >= 0: left blank" in err
    board = json.loads((tree / "o" / "leaderboard.json").read_text())
    assert next(r for r in board["rows"] if r["method"] == "nb")["costs"] == {"train_minutes": 50.0}

"""The tiny validation study end to end: train, render, score, leaderboard, report; resumable."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from dynaeval.errors import InputError
from reference_models.study import MODELS, SCENES, main, run_study


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    import torch

    torch.set_num_threads(1)
    root = tmp_path_factory.mktemp("study")
    docs = root / "docs" / "validation.md"
    # two runs at once in worker processes (what the small study uses on 2 cores)
    assert main(["--preset", "tiny", "--out", str(root / "s"), "--docs", str(docs), "-q",
                 "--jobs", "2", "--results-to", str(root / "docs" / "validation-tiny")]) == 0
    return root / "s", docs


def test_every_scene_model_and_sampling_is_scored(study):
    out, _ = study
    board = json.loads((out / "leaderboard.json").read_text())
    results = sorted(p.name for p in (out / "results").glob("*.json"))
    assert len(results) == len(SCENES) * len(MODELS) * 2
    for path in (out / "results").glob("*.json"):
        doc = json.loads(path.read_text())
        assert doc["summary"]["n_frames"] > 0
        assert doc["summary"]["focused_psnr"] is not None
        assert doc["inputs"]["unscored_cameras"]  # training cameras are not scored
        assert all(c.startswith("eval") for c in doc["inputs"]["cameras"])
    assert board["schema"] == "dynaeval/leaderboard/v1"


def test_report_is_generated_with_its_images(study):
    _, docs = study
    text = docs.read_text()
    for scene in SCENES:
        assert f"## {scene}" in text
    images = [line.split("](")[1].rstrip(")") for line in text.splitlines()
              if line.startswith("![")]
    assert images and all((docs.parent / i).is_file() for i in images)
    assert "The seed study's findings, checked" in text
    assert "From the first scene render to the last result" in text
    commit = json.loads(next((study[0] / "runs").rglob("train.json")).read_text())["code"]
    assert f"Code: `{commit['commit'][:8]}" in text  # the checkout the tests run from
    kept = docs.parent / "validation-tiny"
    assert "[validation-tiny/](validation-tiny/)" in text
    assert sorted(p.name for p in kept.glob("*.json")) == sorted(
        [f"{s}__{m}-{x}.json" for s in SCENES for m in MODELS for x in ("uniform", "isg")]
        + ["leaderboard.json"])


def test_finished_runs_are_not_redone(study):
    out, _ = study
    stamps = {p: p.stat().st_mtime_ns for p in (out / "runs").rglob("train.json")}
    run_study(out, "tiny", progress=False)
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    # a call for one piece of the study still ranks every run the folder holds
    board = run_study(out, "tiny", scenes=["single-player-closeup"], models=["kplanes"],
                      progress=False)
    assert len(board["sources"]) == len(SCENES) * len(MODELS) * 2


def test_unknown_preset_and_bad_jobs():
    with pytest.raises(InputError, match="unknown study preset 'huge'"):
        run_study(__import__("pathlib").Path("/nonexistent"), "huge")
    with pytest.raises(InputError, match="jobs must be >= 1"):
        run_study(__import__("pathlib").Path("/nonexistent"), "tiny", jobs=0)


def test_a_preset_trains_each_model_with_its_own_size_and_settings(tmp_path, monkeypatch):
    """small-30min without its stadium: K-Planes at small-dynbox-fine-fp, NeRFPlayer at small,
    both on the 30-minute CPU budget."""
    import reference_models.common.stadium  # noqa: F401  (imported before the patch: it binds train)
    import reference_models.common.train as train_mod
    from reference_models.study import PRESETS, train_and_render

    calls = []

    def fake_train(spec, data, out, size, iters, sampling, resume, progress, overrides,
                   device, init):
        calls.append((spec.name, size, iters, overrides))
        out.mkdir(parents=True, exist_ok=True)
        (out / "config.json").write_text(json.dumps({"size": size}))  # as train() writes it
        return {"step": 0}

    monkeypatch.setattr(train_mod, "train", fake_train)
    monkeypatch.setattr(train_mod, "render_run", lambda spec, run, data, progress, device: [])
    for model in MODELS:
        train_and_render(tmp_path, "single-player-closeup", model, "isg",
                         replace(PRESETS["small-30min"], stadium=None), tmp_path / "data",
                         progress=False)
    budget = {"minutes": 30.0, "clock": "cpu", "batch_rays": 2048, "importance_fraction": 0.5}
    assert calls == [("kplanes", "small-dynbox-fine-fp", 100_000, budget),
                     ("nerfplayer", "small", 100_000, budget)]
    assert PRESETS["small"].overrides_of("kplanes") == {}


def test_a_scene_without_a_moving_region_trains_the_fallback_size(tmp_path, monkeypatch):
    """small-30min's K-Planes needs a moving region; where the motion masks find none (the
    broadcast and stadium views at small size) the plain `small` is trained, and train.json
    says so."""
    import reference_models.common.train as train_mod
    from reference_models.kplanes.field import NothingMoves
    from reference_models.study import PRESETS, train_and_render

    sizes = []
    NO_STADIUM = replace(PRESETS["small-30min"], stadium=None)

    def fake_train(spec, data, out, size, iters, sampling, resume, progress, overrides,
                   device, init):
        sizes.append(size)
        if resume:  # train() continues the checkpoint's own config, whatever size is passed
            return {"step": 1}
        if size == "small-dynbox-fine-fp":
            raise NothingMoves("the motion masks of the training cameras found nothing that moves")
        out.mkdir(parents=True, exist_ok=True)
        (out / "config.json").write_text(json.dumps({"size": size}))  # as train() writes it
        return {"step": 0}

    monkeypatch.setattr(train_mod, "train", fake_train)
    monkeypatch.setattr(train_mod, "render_run", lambda spec, run, data, progress, device: [])
    run = train_and_render(tmp_path, "players-stadium", "kplanes", "isg", NO_STADIUM,
                           tmp_path / "data", progress=False)
    assert sizes == ["small-dynbox-fine-fp", "small"]
    record = json.loads((run / "train.json").read_text())
    assert record["size"] == "small" and "nothing that moves" in record["fallback"]
    # resumed after an interruption: the run's own size is recorded, not the preset's first choice
    (run / "train.json").unlink()
    (run / "checkpoint.pt").write_bytes(b"")
    record = json.loads((train_and_render(tmp_path, "players-stadium", "kplanes", "isg",
                                          NO_STADIUM, tmp_path / "data",
                                          progress=False) / "train.json").read_text())
    assert record["step"] == 1 and record["size"] == "small" and "nothing that moves" in record["fallback"]
    with pytest.raises(NothingMoves):  # a preset without a fallback does not hide the error
        sizes.clear()
        train_and_render(tmp_path, "players-stadium", "nerfplayer", "isg",
                         replace(NO_STADIUM, model_sizes={"nerfplayer": "small-dynbox-fine-fp"}),
                         tmp_path / "data", progress=False)


def _mean(values):
    kept = [v for v in values if v is not None]
    return sum(kept) / len(kept)


def test_findings_say_on_how_many_frames_importance_sampling_is_better():
    from reference_models.study_report import findings, frames_better

    def doc(method, person, ball):
        frames = [{"camera": "eval00", "frame": f"{i:04d}", "tight_psnr_person": p,
                   "tight_psnr_ball": b} for i, (p, b) in enumerate(zip(person, ball, strict=True))]
        return {"method": method, "frames": frames, "summary": {
            "tight_psnr_person": _mean(person), "tight_psnr_ball": _mean(ball)}}

    uniform = doc("kplanes-uniform", [20.0, 21.0, 22.0, 23.0], [12.0, 12.0, None, 12.0])
    isg = doc("kplanes-isg", [25.0, 20.0, 26.0, 24.0], [11.0, 11.5, 14.0, 11.0])
    assert frames_better(uniform, isg, "tight_psnr_person") == (3, 4)
    assert frames_better(uniform, isg, "tight_psnr_ball") == (0, 3)  # a frame without a ball
    line = findings({"single-player-closeup": [uniform, isg]})[0]
    assert "player holds (IS better on 3 of 4 frames)" in line
    assert "ball does not hold (IS better on 0 of 3 frames)" in line


def test_a_stadium_is_pre_trained_once_per_scene_and_every_run_starts_from_it(tmp_path,
                                                                             monkeypatch):
    """A preset with a stadium: one pre-training per scene and model (K-Planes), shared by the
    uniform and ISG runs, which record it; NeRFPlayer (no static part) starts from scratch;
    the report shows the stadium's minutes beside each run."""
    import reference_models.study as study_mod
    from reference_models.study import PRESETS

    preset = replace(PRESETS["tiny"], stadium={"iters": 8}, model_sizes={"kplanes": "tiny-dynbox-fine-fp"})
    monkeypatch.setitem(study_mod.PRESETS, "tiny-stadium", preset)
    out = tmp_path / "s"
    run_study(out, "tiny-stadium", scenes=["single-player-closeup"], progress=False)
    runs = out / "runs" / "single-player-closeup"
    assert sorted(p.name for p in runs.iterdir()) == [
        "kplanes-isg", "kplanes-stadium", "kplanes-uniform", "nerfplayer-isg", "nerfplayer-uniform"]
    stadium_cfg = json.loads((runs / "kplanes-stadium" / "config.json").read_text())
    assert stadium_cfg["train_config"]["static_warmup"] == 1.0
    assert stadium_cfg["data"].endswith("single-player-closeup-stadium")
    for sampling in ("uniform", "isg"):
        record = json.loads((runs / f"kplanes-{sampling}" / "train.json").read_text())
        assert record["stadium"]["run"] == str((runs / "kplanes-stadium").resolve())
        assert record["stadium"]["step"] == 8
        assert "stadium" not in json.loads((runs / f"nerfplayer-{sampling}" / "train.json").read_text())
    stamp = (runs / "kplanes-stadium" / "checkpoint.pt").stat().st_mtime_ns
    run_study(out, "tiny-stadium", scenes=["single-player-closeup"], progress=False)
    assert (runs / "kplanes-stadium" / "checkpoint.pt").stat().st_mtime_ns == stamp
    from reference_models.study_report import write_report

    text = write_report(out, tmp_path / "v.md", preset="tiny-stadium", command="x").read_text()
    assert "+ stadium min" in text and "`kplanes-stadium` (tiny-dynbox-fine-fp)" in text


def test_code_version_names_the_commit_and_says_when_files_differ(tmp_path):
    import subprocess

    from reference_models.common.paths import code_version
    from reference_models.study_report import code_cell

    assert code_version(tmp_path) is None  # not a git checkout: nothing to name
    git = ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git, "init", "-q"], check=True)
    (tmp_path / "reference_models").mkdir()
    (tmp_path / "reference_models" / "a.py").write_text("x = 1\n")
    (tmp_path / "notes.txt").write_text("n\n")
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-q", "-m", "c"], check=True)
    head = subprocess.run([*git, "rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    assert code_version(tmp_path) == {"commit": head, "dirty": False}
    (tmp_path / "notes.txt").write_text("other\n")  # not code: still the commit's code
    assert code_version(tmp_path)["dirty"] is False
    (tmp_path / "reference_models" / "a.py").write_text("x = 2\n")
    assert code_version(tmp_path) == {"commit": head, "dirty": True}
    assert code_cell({"code": code_version(tmp_path)}) == head[:8] + "+changes"
    assert code_cell({}) == "not recorded"

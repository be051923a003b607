"""Validation study: the toolkit against the reference models, reproducible with one command.

    python -m reference_models.study [--preset tiny|small|small-30min|seed] --out STUDY [--scenes ...]
        [--models kplanes nerfplayer] [--sampling uniform isg] [--jobs N] [--docs docs/validation.md]
        [--device cpu|cuda|auto]

For every scene x model x ray sampling it renders the scene (once per scene), trains the model,
renders the evaluation cameras, scores them with ``dynaeval.score`` against the ground truth
(focused metrics on the generator's exact boxes, masked metrics on the motion masks, temporal
terms) and combines the results into a leaderboard. Every step writes its output atomically and
is skipped when that output exists, so an interrupted study resumes where it stopped.
``--device`` says where the runs train and render (``auto``: cuda when torch sees a GPU); each
run's ``train.json`` and ``render.json`` record the device, and so does the report.

``--docs FILE`` writes the report (tables, crops, times, findings computed from the numbers).
Layout of STUDY::

    data/<scene>/                       generator output (images, boxes.json, transforms.json)
    runs/<scene>/<model>-<sampling>/    checkpoint, log.jsonl, pred/, train.json, render.json
    results/<scene>__<model>-<sampling>.json
    leaderboard.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dynaeval.errors import InputError
from dynaeval.io.atomic import write_text_atomic
from reference_models.common.paths import code_version

SCENES = ("single-player-closeup", "single-player-broadcast", "players-stadium")
MODELS = ("kplanes", "nerfplayer")
SAMPLINGS = ("uniform", "isg")


@dataclass(frozen=True)
class StudyPreset:
    """Sizes of one study preset."""

    scene_size: str
    """Generator size (``tiny`` / ``small``)."""
    model_size: str
    """Model preset (``tiny`` / ``small``)."""
    iters: int | None
    """Training steps (None: the model preset's)."""
    frames: int | None = None
    """Frames per camera (None: the generator size's)."""
    model_sizes: dict[str, str] = field(default_factory=dict)
    """Model -> its preset where it is not ``model_size``."""
    train: dict[str, Any] = field(default_factory=dict)
    """``TrainConfig`` fields set for every model (e.g. a time budget)."""
    model_train: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Model -> more ``TrainConfig`` fields for that model only."""
    fallback_sizes: dict[str, str] = field(default_factory=dict)
    """Model -> the preset trained instead where its ``model_sizes`` preset needs a moving region
    and the scene's motion masks find none (``NothingMoves``); the run's ``train.json`` says so."""
    stadium: dict[str, Any] | None = None
    """``TrainConfig`` fields of the stadium pre-training (e.g. its ``minutes``), trained once per
    scene and model on the empty stadium and the start of every run of that model on the scene
    (``reference_models.common.stadium``); None: runs start from scratch."""
    stadium_models: tuple[str, ...] = ("kplanes",)
    """Models whose runs start from a pre-trained stadium (those with a static part)."""
    description: str = ""
    """One sentence for the report: what a run of this preset trains."""

    def size_of(self, model: str) -> str:
        """The model preset a run of ``model`` trains."""
        return self.model_sizes.get(model, self.model_size)

    def overrides_of(self, model: str) -> dict[str, Any]:
        """The ``TrainConfig`` fields a run of ``model`` sets."""
        return {**self.train, **self.model_train.get(model, {})}


PRESETS = {
    "tiny": StudyPreset(scene_size="tiny", model_size="tiny", iters=150),
    "small": StudyPreset(scene_size="small", model_size="small", iters=None, frames=24,
                         description="each run trains its model's `small` preset for its "
                                     "1,500 steps of 512 rays"),
    "small-30min": StudyPreset(
        scene_size="small", model_size="small", iters=100_000, frames=24,
        model_sizes={"kplanes": "small-dynbox-fine-fp"},
        train={"minutes": 30.0, "clock": "cpu", "batch_rays": 2048, "importance_fraction": 0.5},
        fallback_sizes={"kplanes": "small"},
        stadium={"minutes": 15.0, "clock": "cpu", "batch_rays": 2048},
        description="each run trains for 30 minutes of one core's CPU time (`--clock cpu`), "
                    "2,048 rays per step, half of each batch by importance under ISG; K-Planes "
                    "is `small-dynbox-fine-fp` (world planes sized per axis by the cameras' "
                    "pixel footprint, fine planes over the moving box; plain `small`, 256 cells a "
                    "side, where the motion masks find no moving region: the broadcast and "
                    "stadium views at this size, whose eval stands no training camera sees "
                    "and where 256 cells generalise better than any footprint grid) and starts from its scene's pre-trained empty stadium "
                    "(15 CPU minutes, once per scene, shared by its uniform and ISG runs: "
                    "\"30 clip minutes + 15 stadium minutes\"), NeRFPlayer `small` from scratch "
                    "(docs/reference-models.md)"),
    "seed": StudyPreset(
        scene_size="small", model_size="seed", iters=None, frames=24,
        description="each run trains its model's `seed` preset — the seed study's field sizes "
                    "and shared proposal sampling, 30,000 steps of 4,096 rays at a learning "
                    "rate of 1e-2 (`reference_models/common/seed.py`) — sized for a GPU "
                    "(`--device cuda`), on the `small` scenes (320 x 180, 24 frames; the seed "
                    "trained on 1080p clips)"),
}
"""``seed`` reproduces the seed study's training budget and model sizes, not its 1080p data."""


def _spec(model: str):
    if model == "kplanes":
        from reference_models.kplanes import SPEC
    elif model == "nerfplayer":
        from reference_models.nerfplayer import SPEC
    else:
        raise InputError(f"unknown model {model!r}; expected one of {', '.join(MODELS)}")
    return SPEC


def _write_json(path: Path, obj: Any) -> None:
    write_text_atomic(path, json.dumps(obj, indent=1) + "\n", overwrite=True)


def _render_once(out: Path, done: tuple[str, ...], scene: str, preset: StudyPreset,
                 **kwargs: Any) -> Path:
    """Render ``scene`` at the preset's size into ``out`` (through ``out.partial``, renamed when
    complete) unless the files ``done`` are there already; ``kwargs`` go to ``render_scene``."""
    from reference_models.scenes import render_scene

    if all((out / name).is_file() for name in done):
        return out
    tmp = out.with_name(out.name + ".partial")
    if tmp.exists():
        import shutil

        shutil.rmtree(tmp)
    render_scene(scene, tmp, size=preset.scene_size, seed=0, **kwargs)
    tmp.rename(out)
    return out


def scene_data(study: Path, scene: str, preset: StudyPreset) -> Path:
    """Render ``scene`` into ``study/data/<scene>`` unless it is there already."""
    kwargs = {"frames": preset.frames} if preset.frames else {}
    return _render_once(study / "data" / scene, ("transforms.json", "boxes.json"), scene, preset,
                        **kwargs)


def stadium_data(study: Path, scene: str, preset: StudyPreset) -> Path:
    """Render ``scene``'s cameras without players and ball, one frame, into
    ``study/data/<scene>-stadium`` unless it is there already."""
    return _render_once(study / "data" / f"{scene}-stadium", ("transforms.json",), scene, preset,
                        frames=1, hide=("person", "ball"))


def _train_with_fallback(call, model: str, preset: StudyPreset, size: str) -> dict:  # noqa: ANN001
    """``call(size)``, and ``call`` of the preset's fallback size for ``model`` where ``size``
    needs a moving region the motion masks do not find (``NothingMoves``; re-raised for a model
    without a fallback)."""
    from reference_models.kplanes.field import NothingMoves

    try:
        return call(size)
    except NothingMoves:
        if model not in preset.fallback_sizes:
            raise
        return call(preset.fallback_sizes[model])


def stadium_run(study: Path, scene: str, model: str, preset: StudyPreset, data: Path,
                progress: bool, device: str = "cpu") -> Path | None:
    """Pre-train ``model``'s stadium for ``scene`` once (resumable) into
    ``study/runs/<scene>/<model>-stadium``; None when the preset pre-trains none for it."""
    if preset.stadium is None or model not in preset.stadium_models:
        return None
    from reference_models.common.stadium import train_stadium

    run = study / "runs" / scene / f"{model}-stadium"
    if (run / "train.json").is_file():
        return run
    empty = stadium_data(study, scene, preset)
    spec, t0 = _spec(model), time.perf_counter()
    kwargs = {"iters": preset.stadium.get("iters", preset.iters), "progress": progress,
              "overrides": preset.stadium,
              "resume": (run / "checkpoint.pt").is_file(), "device": device}
    record = _train_with_fallback(lambda size: train_stadium(spec, data, empty, run, size=size,
                                                             **kwargs), model, preset,
                                  preset.size_of(model))
    cfg = json.loads((run / "config.json").read_text())
    _write_json(run / "train.json", {"wall_s": time.perf_counter() - t0, "size": cfg["size"],
                                     "batch_rays": cfg["train_config"]["batch_rays"],
                                     "code": code_version(), **record})
    return run


def train_and_render(study: Path, scene: str, model: str, sampling: str, preset: StudyPreset,
                     data: Path, progress: bool, device: str = "cpu") -> Path:
    """Train and render one run on ``device`` unless done; the run folder holds ``train.json``
    and ``render.json`` (times, device) when each step finished."""
    from reference_models.common.train import render_run, train

    spec = _spec(model)
    run = study / "runs" / scene / f"{model}-{sampling}"
    if not (run / "train.json").is_file():
        resume = (run / "checkpoint.pt").is_file()
        stadium = stadium_run(study, scene, model, preset, data, progress, device)
        size = preset.size_of(model)
        if stadium is not None:  # the stadium's size: its own fallback decided it
            size = json.loads((stadium / "config.json").read_text())["size"]
        t0 = time.perf_counter()
        kwargs = {"iters": preset.iters, "sampling": sampling, "resume": resume,
                  "progress": progress, "overrides": preset.overrides_of(model) or None,
                  "init": stadium, "device": device}
        record = _train_with_fallback(  # a resumed run cannot raise: its extras are stored
            lambda size: train(spec, data if not resume else None, run, size=size, **kwargs),
            model, preset, size)
        cfg = json.loads((run / "config.json").read_text())
        size = cfg["size"]  # a resumed run's own
        note = {} if size == preset.size_of(model) else {"fallback": (
            f"{preset.size_of(model)} -> {size}: the motion masks of the training cameras found "
            "nothing that moves")}
        if "init" in cfg:
            note["stadium"] = cfg["init"]
        _write_json(run / "train.json", {"wall_s": time.perf_counter() - t0, "size": size,
                                         "code": code_version(), **note, **record})
    if not (run / "render.json").is_file():
        import shutil

        shutil.rmtree(run / "pred", ignore_errors=True)
        t0 = time.perf_counter()
        files = render_run(spec, run, data, progress=progress, device=device)
        _write_json(run / "render.json", {"wall_s": time.perf_counter() - t0,
                                          "views": len(files), "device": device})
    return run


def score_run(study: Path, scene: str, model: str, sampling: str, run: Path, data: Path,
              progress: bool) -> Path:
    """Score a run's renders against the ground truth unless already scored."""
    import dynaeval
    from dynaeval.regions.focus import FocusConfig
    from dynaeval.report import write_json_atomic

    out = study / "results" / f"{scene}__{model}-{sampling}.json"
    if out.is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    results = dynaeval.score(
        run / "pred", data / "images", method=f"{model}-{sampling}", scene=scene,
        focus=FocusConfig(source="boxes", boxes_file=str(data / "boxes.json")),
        progress=progress,
    )
    write_json_atomic(out, results, overwrite=True)
    return out


def _one_run(study: Path, scene: str, model: str, sampling: str, preset: str, progress: bool,
             threads: int | None = None, device: str = "cpu") -> Path:
    """Train, render and score one run (resumable); in a worker process when ``threads`` is set."""
    if threads is not None:
        import torch

        torch.set_num_threads(threads)
    p = PRESETS[preset]
    data = scene_data(study, scene, p)
    run = train_and_render(study, scene, model, sampling, p, data, progress, device)
    return score_run(study, scene, model, sampling, run, data, progress)


def _one_stadium(study: Path, scene: str, model: str, preset: str, threads: int,
                 device: str) -> Path | None:
    """Pre-train one stadium in a worker process (``threads`` torch threads, no progress bar)."""
    import torch

    torch.set_num_threads(threads)
    p = PRESETS[preset]
    return stadium_run(study, scene, model, p, scene_data(study, scene, p), False, device)


def _check_device(device: str, preset: StudyPreset, models) -> str:
    """The device a study trains on (``auto`` resolved), checked against every model's budget."""
    from dataclasses import asdict

    from reference_models.common.device import check_clock, resolve_device

    device = resolve_device(device)
    for model in models:
        cfg = {**asdict(_spec(model).presets[preset.size_of(model)][2]), **preset.overrides_of(model)}
        check_clock(device, cfg["clock"], cfg["minutes"])
        if preset.stadium is not None and model in preset.stadium_models:
            check_clock(device, {**cfg, **preset.stadium}["clock"], preset.stadium.get("minutes"))
    return device


def run_study(study: Path, preset: str = "tiny", scenes=SCENES, models=MODELS,
              samplings=SAMPLINGS, progress: bool = True, jobs: int = 1,
              threads: int = 1, device: str = "cpu") -> dict[str, Any]:
    """Run (or resume) the whole study on ``device`` (``cpu``, ``cuda`` or ``auto``); returns the
    leaderboard document. A device the machine lacks, or a preset's CPU-seconds budget on
    CUDA, is an InputError before any scene is rendered.

    ``jobs`` > 1 renders the scenes and then trains the runs in that many worker processes
    (``threads`` torch threads each, no progress bars); each run's numbers are those of a
    sequential study with the same settings, only its wall-clock budget is shared.
    """
    from dynaeval.report.leaderboard import build_leaderboard

    if preset not in PRESETS:
        raise InputError(f"unknown study preset {preset!r}; expected one of {', '.join(PRESETS)}")
    if jobs < 1:
        raise InputError(f"jobs must be >= 1, got {jobs}")
    p = PRESETS[preset]
    device = _check_device(device, p, models)
    study.mkdir(parents=True, exist_ok=True)
    todo = [(s, m, x) for s in scenes for m in models for x in samplings]
    if jobs == 1:
        result_files = []
        for k, (scene, model, sampling) in enumerate(todo, 1):
            print(f"[{k}/{len(todo)}] {scene} {model} {sampling}", file=sys.stderr)
            result_files.append(_one_run(study, scene, model, sampling, preset, progress,
                                         device=device))
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        ctx = multiprocessing.get_context("spawn")  # no forked torch/OpenMP state
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            for scene, future in [(s, pool.submit(scene_data, study, s, p)) for s in scenes]:
                future.result()
                print(f"scene ready: {scene}", file=sys.stderr)
            stadiums = [(s, m) for s in scenes for m in models
                        if p.stadium is not None and m in p.stadium_models]
            for (scene, model), future in [(job, pool.submit(_one_stadium, study, *job, preset,
                                                             threads, device)) for job in stadiums]:
                future.result()
                print(f"stadium ready: {scene} {model}", file=sys.stderr)
            futures = [pool.submit(_one_run, study, *job, preset, False, threads, device)
                       for job in todo]
            for k, (job, future) in enumerate(zip(todo, futures, strict=True), 1):
                future.result()
                print(f"[{k}/{len(todo)}] done: {' '.join(job)}", file=sys.stderr)
        result_files = [study / "results" / f"{s}__{m}-{x}.json" for s, m, x in todo]
    # the leaderboard of the study folder: a study built in pieces (--scenes / --models per
    # call, each run's commit in its train.json) ranks every run it holds, not the last call's
    board = build_leaderboard(sorted({*result_files, *(study / "results").glob("*.json")}))
    _write_json(study / "leaderboard.json", board)
    return board


def copy_results(study: Path, dest: Path) -> list[Path]:
    """Copy ``study/results/*.json`` and ``study/leaderboard.json`` into ``dest`` (created)."""
    import shutil

    dest.mkdir(parents=True, exist_ok=True)
    files = sorted((study / "results").glob("*.json")) + [study / "leaderboard.json"]
    out = []
    for f in files:
        if not f.is_file():
            raise InputError(f"{f} is missing: run the study first")
        out.append(Path(shutil.copy2(f, dest / f.name)))
    return out


def main(argv: list[str] | None = None) -> int:
    from reference_models.common.device import DEVICES

    parser = argparse.ArgumentParser(prog="python -m reference_models.study",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", choices=sorted(PRESETS), default="tiny")
    parser.add_argument("--out", required=True, type=Path, help="study folder (resumable)")
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    parser.add_argument("--sampling", nargs="+", default=list(SAMPLINGS),
                        choices=("uniform", "isg", "ist"))
    parser.add_argument("--docs", type=Path, help="write the study report (Markdown) here")
    parser.add_argument("--results-to", type=Path, metavar="DIR",
                        help="also copy every run's results JSON and the leaderboard here (what "
                             "the repository keeps of a study; the report links to it)")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads per run (default 1)")
    parser.add_argument("--jobs", type=int, default=1,
                        help="runs trained at once, each in its own process (default 1; 2 on a "
                             "2-core machine halves the wall time)")
    parser.add_argument("--device", choices=DEVICES, default="cpu",
                        help="where the runs train and render: cpu (default), cuda (an error "
                             "without a GPU) or auto (cuda when torch sees one)")
    parser.add_argument("-q", "--quiet", action="store_true")
    args = parser.parse_args(argv)
    import torch

    torch.set_num_threads(args.threads)
    t0 = time.perf_counter()
    try:
        run_study(args.out, args.preset, args.scenes, args.models, args.sampling,
                  progress=not args.quiet, jobs=args.jobs, threads=args.threads,
                  device=args.device)
        if args.results_to:
            copy_results(args.out, args.results_to)
        if args.docs:
            from reference_models.study_report import write_report

            write_report(args.out, args.docs, preset=args.preset, results_dir=args.results_to,
                         command=" ".join(["python -m reference_models.study", *(argv or sys.argv[1:])]))
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"study done in {time.perf_counter() - t0:.0f} s: {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

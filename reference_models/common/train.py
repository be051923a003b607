"""The one training loop of the reference models, its checkpoints, and rendering a run's
evaluation cameras to ``RUN/pred/<camera>/<frame>.png``.

A run folder holds ``config.json`` (model name and every setting), ``checkpoint.pt`` (model,
optimiser, step, training seconds, sampler state: training resumes where it stopped),
``log.jsonl`` (one JSON object per logged step: loss, batch PSNR, iterations/s, training
seconds, and the eval-camera PSNR at evaluation steps) and, after rendering, ``pred/``.
``config.json`` also says which device trained the run (``device``, ``device_name``; see
``reference_models.common.device``); a checkpoint loads on any device.

Time is *training* time, wall (``train_seconds``) and process CPU (``train_cpu_seconds``):
evaluation and checkpointing are excluded, so PSNR-vs-time curves measure the model, not how
often it was looked at. ``TrainConfig.clock`` says which of the two a ``minutes`` budget counts.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch

from dynaeval.core.runtime import keep_freed_memory
from dynaeval.errors import InputError
from reference_models.common.data import Dataset, Views, check_same_rig, load_dataset
from reference_models.common.device import check_clock, device_name, resolve_device
from reference_models.common.importance import SAMPLING, RaySampler
from reference_models.common.model import DynamicRadianceModel, RayBatch, RenderConfig
from reference_models.common.rays import pixel_rays


@dataclass
class TrainConfig:
    """Optimisation, losses and logging (K-Planes' DyNeRF values where they exist)."""

    iters: int = 2000
    """Optimisation steps (K-Planes DyNeRF: 90,000 on a GPU)."""
    minutes: float | None = None
    """Training-time budget: stop after this many minutes of training even before ``iters``;
    the cosine schedule and the ISG->IST switch then follow whichever of steps and time is
    further along. None: steps only."""
    clock: str = "wall"
    """What ``minutes`` counts: ``wall`` (elapsed seconds of the training steps) or ``cpu`` (the
    process's CPU seconds over them — the same compute on a shared machine whatever else runs;
    with N torch threads it counts N cores' time)."""
    batch_rays: int = 1024
    """Rays per step (K-Planes: 4,096)."""
    lr: float = 1e-2
    """Adam learning rate, cosine-decayed to 0 after a linear warm-up (K-Planes: 1e-2)."""
    warmup: int = 50
    """Linear warm-up steps (K-Planes: 512 of 90k)."""
    sampling: str = "uniform"
    """``uniform``, ``isg`` or ``ist`` (ISG, then IST from ``ist_from``)."""
    importance_fraction: float = 0.25
    """Share of each batch drawn by importance weights when sampling is ``isg``/``ist``."""
    static_warmup: float = 0.0
    """Fraction of the run (by steps or time, like the schedule) spent learning the static
    scene first: the planes with a time axis are not looked up (they stay 1, so the field is
    K-Planes' own, at about half the look-ups) and rays are drawn uniformly. 0: off; 1: the
    whole run (a stadium pre-training, ``common.stadium``). Needs an encoding with
    ``static_only`` (K-Planes)."""
    ist_from: float = 5 / 9
    """``ist``: fraction of the run after which IST replaces ISG (K-Planes: 50k of 90k)."""
    tv: float = 2e-4
    """Plane total variation weight (K-Planes: 2e-4, field and proposals)."""
    time_smooth: float = 1e-3
    """Second-difference smoothness along time (K-Planes: 1e-3)."""
    time_l1: float = 1e-4
    """L1 of time planes away from 1 (K-Planes: 1e-4)."""
    window_l1: float = 1.0
    """NeRFPlayer: L1 between the two blended time channels of each lookup (published: 1.0)."""
    interlevel: float = 1.0
    """Proposal loss weight (mip-NeRF 360 / K-Planes: 1)."""
    distortion: float = 1e-3
    """Distortion loss weight (K-Planes: 1e-3)."""
    regularize_every: int = 4
    """Steps between the plane regularisers (TV, time smoothness, time L1; field and
    proposals), applied at ``regularize_every`` times their weights: the same pull per step on
    average at a fraction of their cost. 1: every step, as K-Planes."""
    proposal_rays_every: int = 1
    """Every k-th ray of each batch trains the proposal networks (their look-ups with autograd
    and the interlevel loss over those rays); the other rays' proposal look-ups run without
    autograd and only place the samples. 1: every ray, as K-Planes (the default: 2 saves ~5 %
    of a step but cost 0.1-0.2 dB at 400 steps on the close-up, docs/reference-models.md)."""
    bfloat16_mlps: bool = True
    """Training steps run the decoder MLPs' layers in bfloat16 (CPU autocast, on CPUs with
    native bfloat16 only; weights, planes, rendering and losses stay float32), as GPU NeRF codes
    run tiny-cuda-nn's half-precision MLPs. Evaluation and rendering always use float32.
    False: float32 throughout."""
    log_every: int = 25
    """Steps between log lines."""
    eval_every: int = 250
    """Steps between eval-camera PSNR measurements (0: only at the end)."""
    eval_views: int = 4
    """Eval views (evenly spread over the eval frames) rendered for the logged PSNR."""
    eval_stride: int = 1
    """The logged eval PSNR uses every ``eval_stride``-th pixel row and column (1: the whole
    frame; 2: a quarter of the pixels on a regular grid, an estimate of the whole-frame PSNR)."""
    checkpoint_every: int = 500
    """Steps between checkpoints (and one at the end)."""
    seed: int = 0
    """Seed of the initialisation and the ray sampler."""
    init_optimizer: bool = False
    """A run started from another (``train(init=...)``, a pre-trained stadium) also starts from
    its Adam state — moments and step count — for every parameter that run trained (a second
    moment not zero everywhere); the parameters it never moved (the time planes and the moving
    box's factor of a stadium) start fresh, as in a new run. False (the default): the init run's
    weights only, every moment fresh. Measured on the close-up (docs/reference-models.md,
    "A warm restart"): carrying the state gains 0.5 dB at 100 steps and nothing after (0.1-0.2
    dB behind from 300 steps, 0.09 dB behind at 8 CPU minutes), so it is an option. Ignored without
    ``init``; the schedule (warm-up, cosine) is the run's own either way."""


@dataclass
class ModelSpec:
    """What a model package gives the shared CLI: its name, config class, presets and builder."""

    name: str
    """Model name written into ``config.json`` (``kplanes``, ``nerfplayer``)."""
    config_class: type
    """Dataclass of the model's encoding settings."""
    presets: dict[str, tuple[Any, RenderConfig, TrainConfig]]
    """Size name (``tiny``, ``small``) -> (model config, render config, train config)."""
    build_encoding: Callable[[Any, dict], torch.nn.Module]
    """(model config, the run's ``scene`` dict from config.json) -> encoding module."""
    scene_extras: Callable[[Any, Dataset], dict] | None = None
    """(model config, dataset) -> more ``scene`` entries the encoding needs, computed once when
    a run starts and stored in config.json (e.g. the box the motion masks say moves)."""


def standard_presets(tiny: Any, small: Any) -> dict[str, tuple[Any, RenderConfig, TrainConfig]]:
    """The sizes every model offers, given its model configs for each: ``tiny`` for tests
    (seconds: 256 rays x (32 + 16) samples, 80 steps) and ``small`` for the documented runs
    (512 rays x (64 + 32) samples, 1,500 steps or 12 training minutes, whichever comes first)."""
    return {
        "tiny": (tiny, RenderConfig(proposal_samples=(32,), final_samples=16,
                                    proposal_resolution=(16,), hidden=32),
                 TrainConfig(iters=80, batch_rays=256, warmup=10, log_every=10, eval_every=0,
                             eval_views=2, checkpoint_every=1000)),
        "small": (small, RenderConfig(), TrainConfig(iters=1500, minutes=12.0, batch_rays=512,
                                                     eval_every=100, eval_views=2, eval_stride=2)),
    }


def scene_info(data: Dataset) -> dict:
    """What a model needs to know of the scene, stored in ``config.json`` for rendering."""
    return {"box": data.box.tolist(), "n_frames": int(data.n_frames)}


def build_model(spec: ModelSpec, model_cfg: Any, render_cfg: RenderConfig, scene: dict
                ) -> DynamicRadianceModel:
    """The model of a run from its configs and ``scene`` (``scene_info``)."""
    enc = spec.build_encoding(model_cfg, scene)
    return DynamicRadianceModel(enc, torch.tensor(scene["box"]), scene["n_frames"], render_cfg)


PLANE_HEAP = 1 << 30
"""Allocations up to this many bytes come from the heap once freed (``keep_freed_memory``,
called when a run trains or renders): a step allocates and frees the same large tensors every
time, and above glibc's ``mmap`` threshold each was fresh memory faulted in page by page (a
768 x 768 x 16 plane's 37.7 MB gradient: 12 ms to zero, 1 ms reused; a 2,048-ray close-up study
step 0.22 -> 0.19 s CPU, issue 40)."""


def make_optimizer(model: torch.nn.Module, cfg: TrainConfig) -> torch.optim.Optimizer:
    """The training loop's Adam (fused: one kernel over every parameter, ~5x cheaper a step on
    the CPU than the for-loop form), at ``cfg.lr``; the schedule sets the rate each step."""
    return torch.optim.Adam(model.parameters(), lr=cfg.lr, eps=1e-15, fused=True)


def _progress(step: int, seconds: float, cfg: TrainConfig) -> float:
    """How far the run is, in [0, 1]: steps done, or the time budget used when further along."""
    done = step / cfg.iters
    if cfg.minutes:
        done = max(done, seconds / (60.0 * cfg.minutes))
    return min(done, 1.0)


def _progress_bar(tqdm, cfg: TrainConfig, step: int, spent: float, show: bool):
    """The training bar: steps of ``iters`` without a time budget; with ``minutes``, the budget's
    seconds (``cpu-s`` under ``clock="cpu"``), so its percentage and remaining time follow what
    ends the run (a bar of 100,000 steps said 6.5 hours for a 30-minute run)."""
    if not cfg.minutes:
        return tqdm(total=cfg.iters, initial=step, disable=not show, unit="it", dynamic_ncols=True)
    return tqdm(total=round(60.0 * cfg.minutes), initial=_bar_position(step, spent, cfg),
                disable=not show, unit="cpu-s" if cfg.clock == "cpu" else "s", dynamic_ncols=True,
                bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} {unit} [{elapsed}<{remaining}{postfix}]")


def _bar_position(step: int, spent: float, cfg: TrainConfig) -> int:
    """Where the bar stands: ``step`` without a time budget, else the budget's seconds used."""
    return step if not cfg.minutes else round(_progress(step, spent, cfg) * 60.0 * cfg.minutes)


def _advance(bar, cfg: TrainConfig, step: int, spent: float) -> None:
    """Move the bar forward to ``_bar_position``."""
    target = _bar_position(step, spent, cfg)
    if target > bar.n:
        bar.update(target - bar.n)


def _lr_factor(step: int, progress: float, cfg: TrainConfig) -> float:
    if step < cfg.warmup:
        return (step + 1) / cfg.warmup
    start = cfg.warmup / cfg.iters
    frac = (progress - start) / max(1.0 - start, 1e-9)
    return 0.5 * (1.0 + math.cos(math.pi * min(max(frac, 0.0), 1.0)))


def _to_uint8(img: torch.Tensor) -> np.ndarray:
    return np.round(img.cpu().numpy() * 255.0).astype(np.uint8)


def eval_psnr(model: DynamicRadianceModel, views: Views, n_views: int, stride: int = 1) -> float:
    """Mean whole-frame PSNR (dB, 8-bit predictions vs 8-bit ground truth) over ``n_views`` views
    evenly spread over ``views``, on every ``stride``-th pixel row and column."""
    from dynaeval.metrics import psnr

    idx = np.unique(np.round(np.linspace(0, len(views) - 1, min(n_views, len(views)))).astype(int))
    vals = []
    for i in idx:
        img = model.render_image(torch.from_numpy(views.c2w[i]), torch.from_numpy(views.intrinsics[i]),
                                 float(views.times[i]), views.height, views.width, stride=stride)
        vals.append(psnr(_to_uint8(img), views.images[i, ::stride, ::stride], data_range=255.0))
    return float(np.mean(vals))


def _atomic_save(obj: object, path: Path) -> None:
    tmp = path.with_suffix(".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def _config_dict(spec: ModelSpec, data: Dataset, model_cfg: Any, render_cfg: RenderConfig,
                 train_cfg: TrainConfig, size: str) -> dict:
    return {"model": spec.name, "data": str(Path(data.root).resolve()), "size": size,
            "scene": scene_info(data), "model_config": asdict(model_cfg),
            "render_config": asdict(render_cfg), "train_config": asdict(train_cfg)}


def _from_dict(cls: type, d: dict) -> Any:
    names = {f.name for f in fields(cls)}
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in d.items() if k in names})


def load_run(run: str | Path, spec: ModelSpec, device: str = "cpu"
             ) -> tuple[dict, DynamicRadianceModel, dict]:
    """``config.json`` dict, the model with its checkpointed weights on ``device`` (``cpu`` or
    ``cuda``, whichever device saved it), and the checkpoint (its tensors on the CPU)."""
    cfg, ckpt, _ = read_run(run, spec)
    model = build_model(spec, _from_dict(spec.config_class, cfg["model_config"]),
                        _from_dict(RenderConfig, cfg["render_config"]), cfg["scene"])
    model.load_state_dict(ckpt["model"])
    return cfg, model.to(device), ckpt


def read_run(run: str | Path, spec: ModelSpec) -> tuple[dict, dict, bytes]:
    """A run folder's ``config.json`` dict, its checkpoint (tensors on the CPU: the RNG states
    must be CPU tensors; the optimiser's state follows its parameters) and the checkpoint file's
    bytes, without building a model (the RNG is left as it was). Raises InputError for a folder
    without both files or a run of another model."""
    import io

    run = Path(run)
    cfg_file, ckpt_file = run / "config.json", run / "checkpoint.pt"
    if not cfg_file.is_file() or not ckpt_file.is_file():
        raise InputError("not a training run: config.json or checkpoint.pt is missing; train first "
                         f"with `python -m reference_models.{spec.name} train DATA --out RUN`", path=run)
    cfg = json.loads(cfg_file.read_text())
    if cfg.get("model") != spec.name:
        raise InputError(f"run was trained with model {cfg.get('model')!r}, not {spec.name!r}; use "
                         f"`python -m reference_models.{cfg.get('model')} render`", path=run)
    raw = ckpt_file.read_bytes()
    return cfg, torch.load(io.BytesIO(raw), map_location="cpu", weights_only=False), raw


def load_init(model: DynamicRadianceModel, cfg: dict, init: str | Path, spec: ModelSpec,
              optimizer: bool = True) -> tuple[dict, dict | None]:
    """Load the weights of the run ``init`` into ``model`` (the run about to start, whose
    ``config.json`` dict is ``cfg``). Returns what ``config.json`` records of it (folder,
    checkpoint digest, its steps and training seconds, ``optimizer``: whether its Adam state is
    carried, and ``optimizer_fresh``: the parameters that start with fresh moments) and, with
    ``optimizer``, the Adam state the run starts from (``carried_optimizer_state``; else None).
    Raises InputError unless ``init`` was trained for the same model, size, model and render
    configs and scene, or (with ``optimizer``) when its checkpoint holds no Adam state that
    fits the model."""
    import hashlib

    init = Path(init)
    init_cfg, ckpt, raw = read_run(init, spec)
    for key in ("size", "model_config", "render_config", "scene"):
        if init_cfg.get(key) != json.loads(json.dumps(cfg.get(key))):  # tuples as JSON lists
            raise InputError(f"cannot start from this run: its {key} differs from the new run's "
                             f"({init_cfg.get(key)!r} against {cfg.get(key)!r}); pre-train the "
                             "stadium with the same model, size and scene", path=init)
    model.load_state_dict(ckpt["model"])
    state, fresh = None, None
    if optimizer:
        state, fresh = carried_optimizer_state(model, ckpt.get("optimizer"), init / "checkpoint.pt")
    digest = hashlib.sha256(raw).hexdigest()
    return {"run": str(init.resolve()), "checkpoint_sha256": digest, "step": int(ckpt["step"]),
            "train_seconds": float(ckpt["train_seconds"]),
            "train_cpu_seconds": float(ckpt.get("train_cpu_seconds", 0.0)),
            "optimizer": optimizer, "optimizer_fresh": fresh}, state


def carried_optimizer_state(model: torch.nn.Module, saved: dict | None, path: Path
                            ) -> tuple[dict, list[str]]:
    """The Adam state (``make_optimizer``'s ``state_dict`` form) a run of ``model`` starts from,
    given the state ``saved`` in the checkpoint at ``path`` of a run of the same model: every
    parameter's moments and step count as that run left them, except the parameters it never
    moved — a second moment zero everywhere: no gradient but exact zeros ever reached them, like
    a stadium's time planes (only their regularisers, flat at 1, touch them) — which start
    fresh (no state: step 0, so Adam's bias correction holds their first update to ``lr``; a
    carried zero state with a large step count would make it ~3 ``lr``). Returns the state and
    the names of the fresh parameters. Raises InputError when ``saved`` is missing or does not
    fit ``model``'s parameters."""
    names = [n for n, _ in model.named_parameters()]
    params = [p for _, p in model.named_parameters()]
    if not isinstance(saved, dict) or "state" not in saved or "param_groups" not in saved:
        raise InputError("cannot start from this run's optimiser state: its checkpoint holds none; "
                         "pre-train it again, or start from its weights only (no --carry-optimizer)",
                         path=path)
    ids = [i for g in saved["param_groups"] for i in g["params"]]
    if not optimizer_state_fits(saved, params):
        raise InputError(f"cannot start from this run's optimiser state: it holds {len(ids)} "
                         f"parameters, not shaped like the model's {len(params)}; start from its "
                         "weights only (no --carry-optimizer)", path=path)
    state, fresh = {}, []
    for i, name in zip(ids, names, strict=True):
        entry = saved["state"].get(i)
        if entry is None or not bool(entry["exp_avg_sq"].any()):
            fresh.append(name)
        else:
            state[i] = entry
    return {"state": state, "param_groups": saved["param_groups"]}, fresh


def optimizer_state_fits(saved: dict, params: list[torch.Tensor]) -> bool:
    """Whether the Adam ``state_dict`` ``saved`` holds one entry per parameter of ``params``,
    each moment shaped like its parameter (K-Planes' planes are stored (1, H, W, F) since
    issue 40; a checkpoint's Adam state from before holds them (1, F, H, W))."""
    ids = [i for g in saved["param_groups"] for i in g["params"]]
    return len(ids) == len(params) and all(
        i not in saved["state"] or saved["state"][i]["exp_avg"].shape == p.shape
        for i, p in zip(ids, params, strict=True))


def train(spec: ModelSpec, data_path: str | Path, out: str | Path, size: str = "small",
          iters: int | None = None, sampling: str | None = None, resume: bool = False,
          progress: bool = True, overrides: dict | None = None, init: str | Path | None = None,
          scene_data: str | Path | None = None, device: str = "cpu") -> dict:
    """Train ``spec``'s model on the dataset at ``data_path`` into the run folder ``out``.

    ``size`` picks the preset; ``iters``, ``sampling`` and ``overrides`` (TrainConfig field ->
    value) change it. ``resume`` continues a run from its checkpoint (its saved configs, changed
    only by ``iters``, ``sampling`` and ``overrides``). ``init`` starts from the weights of
    another run of the same model, size and scene (a pre-trained stadium,
    ``common.stadium``), and from its Adam state with ``TrainConfig.init_optimizer``
    (``carried_optimizer_state``); ``scene_data`` builds the model for that dataset's scene (box, frames,
    moving box, footprint planes) instead of the training data's (the stadium is trained on the
    empty stadium for the clip's model; both must be filmed by the same cameras). ``device``: ``cpu``, ``cuda`` or ``auto`` (a resumed
    run may continue on another device). Returns the last log record, with the ``device`` it
    trained on. Raises InputError for a bad preset, sampling or device, a missing dataset, an
    ``init`` run that does not match, a ``scene_data`` of other cameras, an existing run without ``resume``, or a ``clock="cpu"``
    budget on CUDA.
    """
    out = Path(out)
    device = resolve_device(device)
    keep_freed_memory(largest=PLANE_HEAP)
    if resume:
        cfg, model, ckpt = load_run(out, spec, device)
        train_cfg = _from_dict(TrainConfig, {**cfg["train_config"], **(overrides or {})})
        size = cfg["size"]
        data_path = cfg["data"] if data_path is None else data_path
    else:
        if size not in spec.presets:
            raise InputError(f"unknown size {size!r}; expected one of {', '.join(spec.presets)}")
        if (out / "checkpoint.pt").exists():
            raise InputError("run folder already holds a checkpoint; pass --resume to continue it "
                             "or choose a new --out", path=out)
        model_cfg, render_cfg, train_cfg = spec.presets[size]
        train_cfg = _from_dict(TrainConfig, {**asdict(train_cfg), **(overrides or {})})
        ckpt = None
    if iters is not None:
        train_cfg.iters = int(iters)
    if sampling is not None:
        train_cfg.sampling = sampling
    if train_cfg.sampling not in SAMPLING:
        raise InputError(f"sampling must be one of {', '.join(SAMPLING)}, got {train_cfg.sampling!r}")
    if train_cfg.iters < 1:
        raise InputError(f"iters must be >= 1, got {train_cfg.iters}")
    if train_cfg.clock not in ("wall", "cpu"):
        raise InputError(f"clock must be 'wall' or 'cpu', got {train_cfg.clock!r}")
    check_clock(device, train_cfg.clock, train_cfg.minutes)
    if not 0.0 <= train_cfg.static_warmup <= 1.0:
        raise InputError(f"static_warmup must be in [0, 1], got {train_cfg.static_warmup}")
    if train_cfg.regularize_every < 1 or train_cfg.proposal_rays_every < 1:
        raise InputError("regularize_every and proposal_rays_every must be >= 1, got "
                         f"{train_cfg.regularize_every} and {train_cfg.proposal_rays_every}")
    if train_cfg.batch_rays < 1:
        raise InputError(f"batch_rays must be >= 1, got {train_cfg.batch_rays}")
    data = load_dataset(data_path)
    init_state = None  # the Adam state a run started from ``init`` carries
    if resume:
        cfg["train_config"] = asdict(train_cfg)
    else:
        torch.manual_seed(train_cfg.seed)
        cfg = _config_dict(spec, data, model_cfg, render_cfg, train_cfg, size)
        built_for = data if scene_data is None else load_dataset(scene_data)
        if scene_data is not None:
            check_same_rig(built_for.train, data.train, data.root)
            cfg["scene"], cfg["scene_data"] = scene_info(built_for), str(Path(scene_data).resolve())
        if spec.scene_extras is not None:
            cfg["scene"].update(spec.scene_extras(model_cfg, built_for))
        model = build_model(spec, model_cfg, render_cfg, cfg["scene"]).to(device)  # CPU init
        if init is not None:
            cfg["init"], init_state = load_init(model, cfg, init, spec, train_cfg.init_optimizer)
    cfg["device"], cfg["device_name"] = device, device_name(device)  # a resume: its own device
    if train_cfg.static_warmup and not hasattr(model.encoding, "static_only"):
        raise InputError(f"static_warmup needs a field with a static part (K-Planes' space "
                         f"planes); {spec.name}'s {type(model.encoding).__name__} has none")
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(cfg, indent=1) + "\n")
    return {**_loop(model, data, train_cfg, out, ckpt, progress, init_state), "device": device,
            "device_name": cfg["device_name"]}


def _loop(model: DynamicRadianceModel, data: Dataset, cfg: TrainConfig, out: Path,
          ckpt: dict | None, progress: bool, init_state: dict | None = None) -> dict:
    from tqdm import tqdm

    views = data.train
    device = model.box.device  # the sampler, its generator and the uint8 images stay on the CPU
    sampler = RaySampler(views, cfg.sampling, cfg.importance_fraction, cfg.ist_from, cfg.seed)
    optim = make_optimizer(model, cfg)
    if init_state is not None:  # a new run from a stadium's Adam state; the step count is its own
        optim.load_state_dict(init_state)
    step, seconds, cpu_seconds = 0, 0.0, 0.0
    if ckpt is not None:
        if not optimizer_state_fits(ckpt["optimizer"], list(model.parameters())):
            raise InputError("cannot resume: the checkpoint's optimiser state is not shaped like "
                             "the model's parameters (written by an older version of the "
                             "reference models?); resume with the code its train.json names "
                             "('code'), or train again", path=out / "checkpoint.pt")
        optim.load_state_dict(ckpt["optimizer"])
        step, seconds = int(ckpt["step"]), float(ckpt["train_seconds"])
        cpu_seconds = float(ckpt.get("train_cpu_seconds", 0.0))
        sampler.generator.set_state(ckpt["sampler_rng"])
        torch.set_rng_state(ckpt["torch_rng"])
    images = torch.from_numpy(views.images)
    c2w, intr = torch.from_numpy(views.c2w), torch.from_numpy(views.intrinsics)
    times = torch.from_numpy(views.times)
    weights = {"tv": cfg.tv, "time_smooth": cfg.time_smooth, "time_l1": cfg.time_l1,
               "window_l1": cfg.window_l1, "interlevel": cfg.interlevel, "distortion": cfg.distortion}
    log_file = (out / "log.jsonl").open("a")
    record: dict = {}
    window_t, window_n, acc_loss, acc_psnr = 0.0, 0, 0.0, 0.0

    def save() -> None:
        _atomic_save({"model": model.state_dict(), "optimizer": optim.state_dict(), "step": step,
                      "train_seconds": seconds, "train_cpu_seconds": cpu_seconds,
                      "sampler_rng": sampler.generator.get_state(),
                      "torch_rng": torch.get_rng_state()}, out / "checkpoint.pt")

    def budget() -> float:
        return cpu_seconds if cfg.clock == "cpu" else seconds

    bar = _progress_bar(tqdm, cfg, step, budget(), progress)

    while _progress(step, budget(), cfg) < 1.0:
        t0, c0 = time.perf_counter(), time.process_time()
        progress_now = _progress(step, budget(), cfg)
        for g in optim.param_groups:
            g["lr"] = cfg.lr * _lr_factor(step, progress_now, cfg)
        static = progress_now < cfg.static_warmup
        model.set_static_only(static)
        v, r, c = sampler.sample(cfg.batch_rays, progress_now, importance=not static)
        if cfg.proposal_rays_every > 1:  # every k-th ray (of the uniform and importance parts) first
            k = cfg.proposal_rays_every
            order = torch.cat([torch.arange(i, len(v), k) for i in range(k)])
            v, r, c = v[order], r[order], c[order]
        o, d = pixel_rays(c2w[v], intr[v], r, c)
        target = images[v, r, c].to(device=device, dtype=torch.float32) / 255.0
        res = model.render(RayBatch(o.to(device), d.to(device), times[v].to(device)), training=True,
                           proposal_rays=-(-len(v) // cfg.proposal_rays_every),
                           bfloat16_mlps=cfg.bfloat16_mlps)
        mse = torch.mean((res.rgb - target) ** 2)
        loss = mse + sum(weights[k] * val for k, val in res.losses.items())  # a new term needs a weight
        if step % cfg.regularize_every == 0:
            loss = loss + cfg.regularize_every * sum(weights[k] * val
                                                     for k, val in model.regularizers().items())
        optim.zero_grad(set_to_none=True)
        loss.backward()
        optim.step()
        step += 1
        dt = time.perf_counter() - t0
        seconds += dt
        cpu_seconds += time.process_time() - c0
        window_t, window_n = window_t + dt, window_n + 1
        acc_loss += float(loss.detach())
        acc_psnr += -10.0 * math.log10(max(float(mse.detach()), 1e-10))
        _advance(bar, cfg, step, budget())
        last = _progress(step, budget(), cfg) >= 1.0
        is_eval = data.eval is not None and (last or (cfg.eval_every and step % cfg.eval_every == 0))
        if step % cfg.log_every == 0 or last or is_eval:
            record = {"step": step, "loss": acc_loss / window_n, "psnr": acc_psnr / window_n,
                      "it_per_s": window_n / window_t, "train_seconds": round(seconds, 3),
                      "train_cpu_seconds": round(cpu_seconds, 3),
                      "lr": optim.param_groups[0]["lr"],
                      "sampling": (None if static else sampler.kind_at(progress_now)) or "uniform",
                      "static": static}
            if is_eval:
                record["eval_psnr"] = eval_psnr(model, data.eval, cfg.eval_views, cfg.eval_stride)
            log_file.write(json.dumps(record) + "\n")
            log_file.flush()
            bar.set_postfix({k: f"{record[k]:.3g}" for k in ("step", "loss", "psnr", "it_per_s",
                                                              "eval_psnr") if k in record})
            window_t, window_n, acc_loss, acc_psnr = 0.0, 0, 0.0, 0.0
        if step % cfg.checkpoint_every == 0 or last:
            save()
    bar.close()
    log_file.close()
    return record


def render_run(spec: ModelSpec, run: str | Path, data_path: str | Path | None = None,
               progress: bool = True, every: int = 1, device: str = "cpu") -> list[Path]:
    """Render the eval views of the run's dataset to ``RUN/pred/<camera>/<frame>.png`` (8-bit
    sRGB); returns the written files. ``data_path`` overrides the dataset recorded in the run;
    ``every`` > 1 renders only every ``every``-th frame of each camera (score those with
    ``dynaeval score --allow-missing``). ``device``: ``cpu``, ``cuda`` or ``auto`` (any run
    renders on any device)."""
    import cv2
    from tqdm import tqdm

    run = Path(run)
    device = resolve_device(device)
    keep_freed_memory(largest=PLANE_HEAP)
    cfg, model, _ = load_run(run, spec, device)
    data = load_dataset(data_path or cfg["data"])
    if data.eval is None:
        raise InputError("the dataset names no evaluation views (eval_cameras / val_filenames / "
                         "transforms_test.json); nothing to render", path=data.root)
    if every < 1:
        raise InputError(f"every must be >= 1, got {every}")
    model.eval()
    views, written = data.eval, []
    keep = [int(i) for seq in views.camera_sequences().values() for i in seq[::every]]
    for i in tqdm(sorted(keep), disable=not progress, unit="view"):
        img = model.render_image(torch.from_numpy(views.c2w[i]), torch.from_numpy(views.intrinsics[i]),
                                 float(views.times[i]), views.height, views.width)
        path = run / "pred" / views.cameras[i] / f"{views.frames[i]}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(path), _to_uint8(img)[..., ::-1])
        written.append(path)
    return written

"""Scoring many (scene, method) runs on a cluster: shards fanned out, merged back bit for bit.

Each job is one ``dynaeval score PRED GT``; it is cut into ``shards`` slices of whole cameras
(``dynaeval.io.frames.select_shard``), every (job, shard) is one task, and the shards of a job are
merged with ``dynaeval.report.merge.merge_results`` into exactly the numbers of an unsharded run.

The executor is anything with ``submit(fn, *args) -> future`` and ``future.result()``: a Dask
``distributed.Client`` (the optional extra ``dynaeval[dist]``), or a ``concurrent.futures``
executor. Tasks receive paths, not pixels: every worker must see PRED and GT at the same paths
(a shared file system), and returns the results as a dict (kilobytes), so nothing large travels.

    from dask.distributed import Client
    from dynaeval.run.distributed import ScoreJob, score_jobs

    client = Client("tcp://scheduler:8786")   # or Client(LocalCluster(...)) on one machine
    jobs = [ScoreJob("/data/kplanes/stadium", "/data/gt/stadium", method="kplanes", scene="stadium")]
    paths = score_jobs(jobs, client, out_dir="/data/results", shards=8, workers=1)
"""

from __future__ import annotations

import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.report.merge import merge_results
from dynaeval.report.results import write_json_atomic
from dynaeval.run.evaluate import score


@dataclass(frozen=True)
class ScoreJob:
    """One ``dynaeval score`` run: a method's predictions of a scene against its ground truth."""

    pred: str
    """Folder (or video/render folder) of the predicted frames, as the workers see it."""
    gt: str
    """Folder of the ground-truth frames, as the workers see it."""
    method: str | None = None
    """Method name in the results (default: PRED's folder name)."""
    scene: str | None = None
    """Scene name in the results (default: GT's folder name)."""
    overrides: dict[str, Any] = field(default_factory=dict)
    """``ScoreConfig`` fields for this job only (on top of the ones given to ``score_jobs``)."""


def score_shard(job: ScoreJob, index: int, count: int, settings: dict[str, Any]) -> dict[str, Any]:
    """Task body: score shard ``index`` of ``count`` of ``job`` (``count == 1``: unsharded).

    Returns the results document (a plain JSON-compatible dict).
    """
    kw = {**settings, **job.overrides, "method": job.method, "scene": job.scene, "progress": False}
    if count > 1:
        kw["shard"] = (index, count)
    return dict(score(job.pred, job.gt, **kw))


def _name(job: ScoreJob) -> str:
    scene = job.scene or Path(job.gt).name
    method = job.method or Path(job.pred).name
    return re.sub(r"[^A-Za-z0-9._-]+", "_", f"{scene}__{method}")


def score_jobs(
    jobs: list[ScoreJob],
    executor: Any,
    *,
    out_dir: str | Path,
    shards: int = 1,
    overwrite: bool = False,
    **settings: Any,
) -> list[Path]:
    """Score every job, ``shards`` tasks each, on ``executor``; write one results file per job.

    Args:
        jobs: the runs; their (scene, method) names must differ (they name the output files).
        executor: ``distributed.Client`` or a ``concurrent.futures`` executor (see module doc).
        out_dir: where ``<scene>__<method>.json`` is written (atomically) for each job.
        shards: slices of whole cameras per job (more shards than cameras leaves some empty).
        overwrite: replace existing results files.
        settings: ``ScoreConfig`` fields for every job (``no_lpips`` style names are not
            accepted: use the field names, e.g. ``metrics=("psnr", "ssim"), temporal=False, workers=1``).

    Returns:
        The results files, in the order of ``jobs``. Their numbers equal those of one unsharded
        ``score`` per job, bit for bit (tested against a local Dask cluster).

    Raises:
        InputError: no jobs, duplicate names, ``shards < 1``, or any error a task raised.
    """
    if not jobs:
        raise InputError("score_jobs needs at least one ScoreJob")
    if shards < 1:
        raise InputError(f"shards must be >= 1, got {shards}")
    names = [_name(j) for j in jobs]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise InputError(f"jobs with the same scene and method: {', '.join(dup)}; give each a "
                         "distinct method= or scene=")
    out = Path(out_dir)
    targets = [out / f"{n}.json" for n in names]
    if not overwrite:
        for t in targets:
            if t.exists():
                raise InputError("results file exists; pass overwrite=True to replace it", path=str(t))
    futures = [[executor.submit(score_shard, job, i, shards, settings) for i in range(1, shards + 1)]
               for job in jobs]
    out.mkdir(parents=True, exist_ok=True)
    for job_futures, target in zip(futures, targets, strict=True):
        docs = [f.result() for f in job_futures]
        if shards == 1:
            doc = docs[0]
        else:
            with tempfile.TemporaryDirectory() as tmp:
                parts = [write_json_atomic(Path(tmp) / f"shard{i}.json", d)
                         for i, d in enumerate(docs, start=1)]
                doc = merge_results(parts)
        write_json_atomic(target, doc, overwrite=overwrite)
    return targets

"""Fan-out scoring: jobs x shards on an executor (threads, a local Dask cluster) merged back
equals one unsharded ``score`` per job, bit for bit."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.regions.focus import FocusConfig
from dynaeval.run.distributed import ScoreJob, score_jobs, score_shard
from dynaeval.run.evaluate import score

from ..helpers import moving_square_scene, write_frames

NUMBERS = ("frames", "cameras", "summary", "counts", "metrics", "settings", "method", "scene")
SETTINGS = {"metrics": ("psnr", "ssim"), "focus": FocusConfig(source="motion", masked=True)}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """Two methods on one 3-camera ground truth."""
    root = tmp_path_factory.mktemp("dist")
    gt, frames = moving_square_scene(root / "gt", cameras=("cam0", "cam1", "cam2"))
    preds = []
    for k, method in enumerate(("m1", "m2")):
        rng = np.random.default_rng(k)
        for cam, seq in frames.items():
            write_frames(root / method, cam, [
                np.clip(f.astype(int) + rng.integers(-9 * (k + 1), 9 * (k + 1) + 1, f.shape), 0, 255)
                .astype(np.uint8) for f in seq])
        preds.append(root / method)
    return preds, gt


def _unsharded(pred, gt) -> dict:
    return json.loads(json.dumps(dict(score(pred, gt, progress=False, **SETTINGS))))


def _check_equal(paths, preds, gt):
    for path, pred in zip(paths, preds, strict=True):
        got = json.loads(path.read_text())
        whole = _unsharded(pred, gt)
        for key in NUMBERS:
            assert got[key] == whole[key], key
        assert "shard" not in got["inputs"]


@pytest.mark.parametrize("shards", [1, 2, 4])
def test_thread_executor_equals_unsharded(tmp_path, scenes, shards):
    preds, gt = scenes
    jobs = [ScoreJob(str(p), str(gt)) for p in preds]
    with ThreadPoolExecutor(2) as pool:
        paths = score_jobs(jobs, pool, out_dir=tmp_path / "out", shards=shards, **SETTINGS)
    assert [p.name for p in paths] == ["gt__m1.json", "gt__m2.json"]
    _check_equal(paths, preds, gt)


def test_local_dask_cluster_equals_unsharded(tmp_path, scenes):
    distributed = pytest.importorskip("distributed")
    preds, gt = scenes
    jobs = [ScoreJob(str(p), str(gt), method=p.name, scene="square") for p in preds]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        paths = score_jobs(jobs, client, out_dir=tmp_path / "out", shards=2, **SETTINGS)
    got = json.loads(paths[0].read_text())
    assert (got["method"], got["scene"]) == ("m1", "square")
    whole = json.loads(json.dumps(dict(score(preds[0], gt, progress=False, method="m1", scene="square",
                                             **SETTINGS))))
    for key in NUMBERS:
        assert got[key] == whole[key], key


def test_score_shard_is_one_slice_of_whole_cameras(scenes):
    preds, gt = scenes
    job = ScoreJob(str(preds[0]), str(gt))
    doc = score_shard(job, 2, 2, SETTINGS)
    assert {f["camera"] for f in doc["frames"]} == {"cam1"}
    assert doc["inputs"]["shard"]["index"] == 2


def test_score_jobs_errors(tmp_path, scenes):
    preds, gt = scenes
    job = ScoreJob(str(preds[0]), str(gt))
    with ThreadPoolExecutor(1) as pool:
        with pytest.raises(InputError, match="at least one ScoreJob"):
            score_jobs([], pool, out_dir=tmp_path)
        with pytest.raises(InputError, match="shards must be >= 1"):
            score_jobs([job], pool, out_dir=tmp_path, shards=0)
        with pytest.raises(InputError, match="same scene and method: gt__m1"):
            score_jobs([job, job], pool, out_dir=tmp_path)
        (tmp_path / "gt__m1.json").write_text("{}")
        with pytest.raises(InputError, match="results file exists"):
            score_jobs([job], pool, out_dir=tmp_path, **SETTINGS)
        with pytest.raises(InputError, match="workers must be an integer >= 1"):
            score_jobs([job], pool, out_dir=tmp_path / "new", workers=0)

"""A suite on a real Dask cluster on the loopback: a ``dask scheduler`` and two ``dask worker``
processes (one thread each, random free ports), started and killed here. The results equal the
local run's bit for bit, and a worker killed mid-run loses no result (its tasks run again on the
other). Bounded: every wait has a timeout and the processes are killed in a ``finally``."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from dynaeval.cli import sample_dir
from dynaeval.run.suite import folder_suite, run_suite, settings_config

from .test_suite import _noisy, _numbers

distributed = pytest.importorskip("distributed")

METHODS = ("m1", "m2", "m3", "m4", "m5")
TIMEOUT = 40.0
"""Seconds any one step may take (the scheduler or a worker coming up, the suite)."""


def _dask() -> list[str]:
    exe = Path(sys.executable).with_name("dask")
    if not exe.is_file():
        pytest.skip("the dask command is not installed beside this Python")
    return [str(exe)]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def suite_tree(tmp_path):
    root, gt = tmp_path / "root", tmp_path / "gt"
    shutil.copytree(sample_dir() / "gt", gt / "sample")
    for k, m in enumerate(METHODS):
        _noisy(gt / "sample", root / m / "sample", k)
    return tmp_path


@pytest.fixture
def cluster():
    """(scheduler address, {worker name: process}) of a scheduler and two workers."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).resolve().parents[3]), os.environ.get("PYTHONPATH", "")])}
    common = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
    procs = [subprocess.Popen([*_dask(), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], **common)]
    workers = {}
    try:
        for name in ("w0", "w1"):
            workers[name] = subprocess.Popen(
                [*_dask(), "worker", address, "--nthreads", "1", "--no-nanny", "--name", name,
                 "--host", "127.0.0.1", "--no-dashboard", "--death-timeout", "60"], **common)
            procs.append(workers[name])
        with distributed.Client(address, timeout=TIMEOUT) as client:
            client.wait_for_workers(2, timeout=TIMEOUT)
        yield address, workers
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait(timeout=TIMEOUT)


def _config():
    return settings_config({"metrics": ["psnr", "ssim"], "focus": "motion"}, "test")


def _run_bounded(fn):
    """``fn()`` in a thread, failing the test if it takes more than ``TIMEOUT`` seconds."""
    box: dict = {}
    thread = threading.Thread(target=lambda: box.update(value=fn()), daemon=True)
    thread.start()
    thread.join(TIMEOUT)
    assert not thread.is_alive(), f"the suite took more than {TIMEOUT} s on the cluster"
    return box["value"]


def test_cluster_equals_local_and_a_killed_worker_loses_nothing(suite_tree, cluster):
    address, workers = cluster
    t0 = time.monotonic()
    local = run_suite(folder_suite(suite_tree / "root", suite_tree / "gt", suite_tree / "local",
                                   _config()), progress=False)
    assert len(local.scored) == len(METHODS) and not local.failed
    killed: list[str] = []
    with distributed.Client(address, timeout=TIMEOUT) as client:
        names = {addr: w["name"] for addr, w in client.scheduler_info()["workers"].items()}

        def kill_a_busy_worker(_pair: str) -> None:
            """After the first result: kill the worker that has a task on hand."""
            if killed:
                return
            busy = [names[a] for a, tasks in client.processing().items() if tasks]
            if busy:
                killed.append(busy[0])
                workers[busy[0]].kill()

        suite = folder_suite(suite_tree / "root", suite_tree / "gt", suite_tree / "dask", _config())
        outcome = _run_bounded(lambda: run_suite(suite, client, progress=False,
                                                 on_result=kill_a_busy_worker))
        left = [w["name"] for w in client.scheduler_info()["workers"].values()]
    assert left == [n for n in workers if n not in killed]  # the rest ran on the other worker
    assert killed, "no worker had a task on hand after the first result"
    assert workers[killed[0]].wait(timeout=TIMEOUT) is not None
    assert not outcome.failed and sorted(outcome.scored) == sorted(local.scored)
    for name in local.scored:
        a = _numbers(suite_tree / "local" / "results" / f"{name}.json")
        b = _numbers(suite_tree / "dask" / "results" / f"{name}.json")
        assert a == b, name  # bit for bit: JSON floats are repr()s of the float64s
    rows = [[{k: v for k, v in r.items() if k != "file"} for r in
             json.loads((suite_tree / out / "leaderboard.json").read_text())["rows"]]
            for out in ("local", "dask")]
    assert rows[0] == rows[1]
    assert time.monotonic() - t0 < 2 * TIMEOUT


def test_a_suite_whose_only_workers_died_says_so_and_finishes_on_a_new_one(suite_tree, cluster,
                                                                           monkeypatch, capsys):
    """Issue 42 item 10: if the only Dask worker died the client waited forever without a word.
    It says so every NO_WORKER_EVERY seconds and goes on once a worker joins."""
    import dynaeval.run.suite as suite_mod

    monkeypatch.setattr(suite_mod, "NO_WORKER_EVERY", 0.3)
    address, workers = cluster
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).resolve().parents[3]), os.environ.get("PYTHONPATH", "")])}
    late: list[subprocess.Popen] = []
    with distributed.Client(address, timeout=TIMEOUT) as client:

        def kill_every_worker_then_start_one(_pair: str) -> None:
            if late:
                return
            for proc in workers.values():
                proc.kill()
                proc.wait(timeout=TIMEOUT)
            deadline = time.monotonic() + TIMEOUT
            while client.scheduler_info()["workers"] and time.monotonic() < deadline:
                time.sleep(0.1)
            time.sleep(1.0)  # long enough for the watch to say it (every 0.3 s)
            late.append(subprocess.Popen(
                [*_dask(), "worker", address, "--nthreads", "1", "--no-nanny", "--name", "w2",
                 "--host", "127.0.0.1", "--no-dashboard"], stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, env=env))

        suite = folder_suite(suite_tree / "root", suite_tree / "gt", suite_tree / "dask", _config())
        try:
            outcome = _run_bounded(lambda: run_suite(suite, client, progress=False,
                                                     on_result=kill_every_worker_then_start_one))
        finally:
            for proc in late:
                proc.kill()
    assert late and not outcome.failed and len(outcome.scored) == len(METHODS)
    assert "the Dask scheduler has no worker: the suite waits for one" in capsys.readouterr().err

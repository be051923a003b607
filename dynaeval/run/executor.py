"""``RunWorkers``: what changes while a run goes — its worker threads, the cameras scored at once,
the frame caches they share, the seconds spent per phase. (Named apart from
``concurrent.futures.Executor`` and a Dask ``Client``, which it is neither: issue 41.)

The numbers of a camera never depend on it (the same with 1 worker or 8, cameras in any order);
the plan of the run (``dynaeval.run.plan.RunPlan``) says what is computed, the workers how it is
spread over threads.
"""

from __future__ import annotations

import threading
from collections import defaultdict
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from typing import Any, TypeVar

from dynaeval.io import FramePair
from dynaeval.io.images import FrameCache

T = TypeVar("T")
R = TypeVar("R")


class Stopped(Exception):
    """Raised in a camera's thread when another camera has failed: the run stops."""


class RunWorkers:
    """A run's worker pool (``workers > 1``), its camera lanes, frame caches and timing.

    Args:
        workers: threads scoring frames and temporal pairs; also how many cameras are scored at
            the same time (at most ``cameras``), all feeding the one pool.
        cameras: cameras of the run (1 for a single camera's work, ``dynaeval prepare``).
        cache_mb: the frame-cache budget in MiB, shared by the cameras scored at once.
        decoded: ``FrameCache``'s ``decoded`` (a prepared ground truth's decodings), or None.
    """

    def __init__(self, workers: int, cameras: int = 1, *, cache_mb: int,
                 decoded: Callable[[Any], Any] | None = None) -> None:
        self.workers = workers
        self.pool = ThreadPoolExecutor(max_workers=workers) if workers > 1 else None
        """Worker threads (``workers > 1``), or None: everything runs in the caller's thread."""
        self.lanes = max(1, min(workers, cameras))
        """Cameras scored at the same time; their frame caches share ``cache_mb``."""
        self.timing: dict[str, float] = defaultdict(float)
        """Seconds per phase and metric, summed over frames and cameras."""
        self._lock = threading.Lock()
        self._cache_bytes = cache_mb * 2**20 // self.lanes
        self._decoded = decoded

    def add_time(self, times: dict[str, float]) -> None:
        """Add seconds per phase (thread-safe)."""
        with self._lock:
            for k, v in times.items():
                self.timing[k] += v

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        """``[fn(x) for x in items]``, on the pool when there is one (results in order)."""
        return list(self.pool.map(fn, items)) if self.pool else [fn(x) for x in items]

    def frame_cache(self) -> FrameCache:
        """A camera's frame cache: its share of the budget (dropped with the camera)."""
        return FrameCache(self._cache_bytes, decoded=self._decoded)

    @property
    def window(self) -> int:
        """Temporal pairs one camera keeps in flight: 2 x workers over all cameras at once."""
        return max(2, 2 * self.workers // self.lanes)

    def cameras_at_once(self, cams: dict[str, list[FramePair]],
                        score: Callable[[str, list[FramePair], threading.Event], T]) -> list[T]:
        """``score(camera, pairs, stop)`` of every camera, ``lanes`` at a time, in camera order:
        the first camera to fail stops the others (``stop`` is set; ``score`` raises ``Stopped``
        at its next frame or pair) and its error is raised. (With one lane the caller scores its
        cameras one after the other itself, inside ``worker_opencv_threads``.)"""
        lanes = ThreadPoolExecutor(max_workers=self.lanes)
        try:
            return cameras_at_once(lanes, cams, score)
        finally:
            lanes.shutdown(cancel_futures=True)

    def shutdown(self, completed: bool) -> None:
        """Stop the pool (pending work cancelled unless the run ``completed``)."""
        if self.pool:
            self.pool.shutdown(cancel_futures=not completed)


def cameras_at_once(lanes: Any, cams: dict[str, list[FramePair]],
                    score: Callable[[str, list[FramePair], threading.Event], T]) -> list[T]:
    """``score(camera, pairs, stop)`` of every camera in the ``lanes`` pool, in camera order. The
    first camera to fail stops the others at their next frame or pair, and its error is raised."""
    stop = threading.Event()
    futures = [lanes.submit(score, c, p, stop) for c, p in cams.items()]
    done, _ = wait(futures, return_when=FIRST_EXCEPTION)
    failed = [f.exception() for f in futures if f in done and f.exception() is not None]
    if failed:
        stop.set()
        wait(futures)
        raise failed[0]
    return [f.result() for f in futures]

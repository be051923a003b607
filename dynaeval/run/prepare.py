"""Ground truth prepared once: ``dynaeval prepare GT -o PREP``, then ``score ... --prepared PREP``.

What a scoring run computes from the ground truth alone is the same for every method scored on
one scene: the regions of every frame (detector boxes, motion masks, the camera's motion check),
the ground-truth optical flows of every consecutive pair (forward and backward, the two of
the three flows a temporal pair needs) with the rest of the ground truth's half of each pair
(its visibility mask and warping errors) and the ground truth's flicker means on the static
pixels. :func:`prepare` computes them once, with the same code
and settings a run uses, and writes them into a folder (``dynaeval.io.prepared``):

* ``manifest.json``: format version, dynaeval version, the settings that change these numbers
  (:func:`prepared_settings`: focus source, expansion, detector or boxes file with its SHA-256,
  motion masks, background, 8-bit step, the protocol's 16-bit decode rule, flow estimator; given
  masks, ``--masks``, are applied on top of the prepared regions when scored), the blake2b of every ground-truth file,
  and per camera its frames, the JSON part of its regions and the keys of its flows;
* ``regions/<i>.npz`` (compressed): camera ``i``'s boxes and bit-packed motion masks;
* ``flows/<key>.npy``: float32 ``(H, W, 2)`` flows (16.6 MB at 1920x1080), named by the flow
  cache's content key (``FlowCache.key``: both gray frames' hashes and the flow settings);
* ``frames/<digest>.npy``: each 8-bit ground-truth image decoded (uint8, as OpenCV returns it:
  6.2 MB at 1080p RGB), named by the file's blake2b, so scoring reads it instead of decoding the
  file (whose digest it still checks);
* ``visible/<key>.npy``: each consecutive pair's visibility mask (``flow.visibility`` of its
  two flows, bit-packed: 260 KB at 1080p), named by its backward flow's key; the manifest holds
  the pair's ground-truth warping errors (whole, focused) beside it (``gt_pairs``), and per
  camera the ground truth's flicker means ``S(gt)`` (whole, focused) with the digest of the
  static mask they follow (``--masks`` that change it: computed again). A scoring run computes
  none of the ground truth's half of a temporal pair (gray images and their hashes, visibility,
  its warp and warping error) nor its temporal std again.

The files are written and hashed in one background thread (``io.prepared.FolderWriter``) while
the next ones are computed, and each ground-truth image is decoded once: the decoding saved is
the one the regions and flows read.

``dynaeval.run.prepared_gt`` reads the folder back (``open_prepared``: checked against the run) and
defines its layout, which this writer follows. The numbers are those of a run without
``--prepared``, bit for bit (tests/dynaeval/run/test_prepare.py).
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError, UndefinedMetricError
from dynaeval.core.progress import Progress
from dynaeval.core.runtime import worker_opencv_threads
from dynaeval.core.validation import as_image, values_known_in
from dynaeval.core.version import VERSION
from dynaeval.io import FramePair, pair_frames
from dynaeval.io.atomic import check_writable
from dynaeval.io.frames import pairs_by_camera
from dynaeval.io.images import STORED_RGB, decode_file
from dynaeval.io.prepared import (
    FORMAT_VERSION,
    MANIFEST,
    FolderWriter,
    file_digest,
    folder_digests,
    manifest_id,
    write_folder_atomic,
)
from dynaeval.metrics.flow import (
    FlowCache,
    FlowConfig,
    check_flow_size,
    flow_from_gray,
    gray_digest,
    gray_of_checked,
)
from dynaeval.metrics.static_flicker import TemporalStd, check_static, static_mean
from dynaeval.metrics.temporal import region_item_mask
from dynaeval.metrics.temporal_pairs import GroundTruthPair, ground_truth_pair, pair_region
from dynaeval.regions.focus import CameraRegions, open_sources
from dynaeval.regions.packed import PackedMask
from dynaeval.run.config import ScoreConfig
from dynaeval.run.executor import RunWorkers
from dynaeval.run.plan import RunPlan, ground_truth_plan
from dynaeval.run.prepared_gt import (
    REGION_FIELDS,
    frame_rel,
    manifest_value,
    prepared_settings,
    static_digest,
)
from dynaeval.run.scoring import camera_regions_of
from dynaeval.run.stages import consecutive
from dynaeval.run.stages.temporal import region_items, static_pixels

__all__ = ["KeptDecodings", "prepare"]


def prepare(gt_dir: str | Path, out: str | Path, config: ScoreConfig | None = None, *,
            overwrite: bool = False, **overrides: Any) -> dict[str, Any]:
    """Compute what scoring depends on from the ground truth alone and write it to ``out``.

    Args:
        gt_dir: ground-truth frames (images, one sub-folder per camera, or videos).
        out: the folder to write (atomically; an existing one only with ``overwrite``).
        config: the settings of the runs that will use it (default ``ScoreConfig()``); its focus,
            background, quantize, temporal and flow fields matter, ``workers`` and ``progress``
            are used; keyword ``overrides`` replace fields.

    Returns:
        The manifest written (``id``: the prepared ground truth's id).

    Raises:
        InputError: ``out`` exists, bad ground truth or settings (before the work starts).
    """
    config = replace(config or ScoreConfig(), **overrides)
    config = replace(config, quantize=config.resolved_quantize())
    gt_dir, out = Path(gt_dir), Path(out)
    if out.exists() and not overwrite:
        raise InputError("prepared folder exists; pass --overwrite or choose another -o", path=out)
    check_writable(out, overwrite=overwrite, what="prepared folder", inputs=[gt_dir], folder=True)
    pairing = pair_frames(gt_dir, gt_dir)
    sources = open_sources(config.focus)
    plan = ground_truth_plan(config, sources)
    cams = pairs_by_camera(pairing.pairs)
    progress = Progress({"regions": len(pairing.pairs),
                         "pairs": sum(len(c) - 1 for c in cams.values()) if config.temporal else 0},
                        enabled=config.progress)
    manifest: dict[str, Any] = {
        "format_version": FORMAT_VERSION, "dynaeval_version": VERSION,
        "gt": str(gt_dir.resolve()), "settings": prepared_settings(config, sources),
        "files": {}, "decoded": {}, "cameras": {},
    }

    kept = KeptDecodings(config.cache_mb * 2**20 // 4)

    def fill(tmp: Path) -> None:
        for sub in ("regions", "flows", "visible", "frames"):
            (tmp / sub).mkdir()
        with FolderWriter(tmp) as writer:  # files written and hashed beside the work
            _save_files(pairing.pairs, gt_dir, manifest, writer, kept)
            for i, (cam, pairs) in enumerate(cams.items()):
                progress.set_note(f"camera {cam}")
                manifest["cameras"][cam] = _prepare_camera(i, cam, pairs, plan, executor, gt_dir,
                                                           writer, progress)
                kept.drop(p.gt.path for p in pairs)  # the camera's frames are read
            written = writer.finish()
        manifest["hashes"] = folder_digests(tmp, written)  # every prepared file, checked when read
        manifest["id"] = manifest_id(manifest)
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")

    executor = RunWorkers(config.workers, cache_mb=config.cache_mb,  # one camera at a time
                        decoded=kept.get)
    completed = False
    try:
        with worker_opencv_threads(config.workers):
            write_folder_atomic(out, fill, overwrite=overwrite, what="prepared folder")
        completed = True
    finally:
        progress.close(completed)
        executor.shutdown(completed=True)  # as before: pending work runs to its end
    return manifest


def _save_files(pairs: list[FramePair], gt_dir: Path, manifest: dict[str, Any],
                writer: FolderWriter, kept: KeptDecodings) -> None:
    """Each ground-truth file's digest into ``manifest["files"]`` (a video file once, not once
    per frame) and, for an 8-bit image, its decoding (``_save_decoded``) into
    ``manifest["decoded"]`` (videos, 16-bit and float images are decoded as usual)."""
    for p in pairs:
        rel = frame_rel(p.gt, gt_dir).split("#")[0]
        if rel in manifest["files"]:
            continue
        digest = manifest["files"][rel] = file_digest(p.gt.path)
        stored = None if p.gt.index is not None else _save_decoded(p.gt.path, digest, writer,
                                                                   kept)
        if stored is not None:
            manifest["decoded"][rel] = stored


def _save_decoded(path: Path, digest: str, writer: FolderWriter,
                  kept: KeptDecodings) -> str | None:
    """An 8-bit image file's decoding (``dynaeval.io.images.decode_file``: uint8, as OpenCV
    returns it) as ``frames/<digest>.npy`` (``writer``), so that scoring skips its decoding; its
    path relative to the prepared folder, or None for files of other depths (16-bit, float,
    EXR) or stored as RGB arrays (``.npy.gz``). The decoding is also ``kept`` for the regions
    and flows of this run, which read the file through it (``read_image``'s ``decoded``, as a
    prepared run does) instead of decoding it a second time."""
    image, kind = decode_file(path)
    if kind in STORED_RGB or image.dtype != np.uint8:
        return None
    rel = f"frames/{digest}.npy"
    if rel not in writer:  # files of equal content share one
        writer.save(rel, image)
    kept.add(path, image)
    return rel


class KeptDecodings:
    """The ground-truth decodings ``prepare`` made, by file, for its own reads of them (the
    executor's ``decoded``): up to ``max_bytes`` (uint8, a quarter of the float32 frames the
    frame cache keeps), a camera's dropped once it is done; a file not kept is decoded again.
    Thread-safe."""

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = max_bytes
        self.bytes = 0
        self._images: dict[Path, np.ndarray] = {}
        self._lock = threading.Lock()

    def add(self, path: Path, image: np.ndarray) -> None:
        """Keep ``image``, the decoding of ``path``, if it fits."""
        with self._lock:
            if path not in self._images and self.bytes + image.nbytes <= self.max_bytes:
                self._images[path] = image
                self.bytes += image.nbytes

    def get(self, path: Path) -> np.ndarray | None:
        """The kept decoding of ``path``, or None."""
        with self._lock:
            return self._images.get(path)

    def drop(self, paths: Iterable[Path]) -> None:
        """Forget the decodings of ``paths``."""
        with self._lock:
            for path in paths:
                image = self._images.pop(path, None)
                self.bytes -= 0 if image is None else image.nbytes


def _prepare_camera(i: int, cam: str, pairs: list[FramePair], plan: RunPlan, executor: RunWorkers,
                    gt_dir: Path, writer: FolderWriter, progress: Any) -> dict[str, Any]:
    """Camera ``cam``'s manifest entry; its regions and flows written by ``writer``."""
    cache = executor.frame_cache()
    regions = camera_regions_of(cam, pairs, plan, executor, cache)
    progress.advance("regions", len(pairs))
    entry: dict[str, Any] = {"frames": [[p.frame, frame_rel(p.gt, gt_dir)] for p in pairs],
                             "regions": None, "flows": None, "gt_pairs": None, "flicker": None}
    if regions.frames and regions.not_video is None:  # no video: computed again when scored
        entry["regions"] = _save_regions(regions, f"regions/{i}.npz", writer)
        if plan.config.temporal:
            entry["flows"], entry["gt_pairs"] = _save_flows(
                pairs, regions, plan, executor, cache, writer, progress) or (None, None)
            if entry["flows"] is not None:  # a sequence the temporal pass scores
                entry["flicker"] = _gt_flicker(pairs, regions, plan, cache)
    if plan.config.temporal:
        progress.advance("pairs", max(len(pairs) - 1, 0) - len(entry["flows"] or ()))
    return entry


def _save_regions(regions: CameraRegions, rel: str, writer: FolderWriter) -> dict[str, Any]:
    """Write the arrays of a camera's regions as ``rel`` (npz, masks bit-packed as
    ``FrameRegions`` holds them); returns the JSON part (reasons, records, sizes, the camera's
    motion check)."""
    arrays: dict[str, np.ndarray] = {}
    frames = []
    for k, r in enumerate(regions.frames):
        packed = r.packed_mask
        for name, value in zip(REGION_FIELDS, (r.boxes, r.raw_boxes,
                                         None if packed is None else packed.bits), strict=True):
            if value is not None:
                arrays[f"{name}{k}"] = value
        boxes, mask = r.boxes_missing, r.mask_missing  # the prepared format keeps both fields
        frames.append({"boxes_reason": boxes and boxes.detail, "mask_reason": mask and mask.detail,
                       "boxes_status": boxes and boxes.status.value,
                       "mask_status": mask and mask.status.value,
                       "records": r.records, "size": r.size,
                       "mask_shape": None if packed is None else list(packed.shape)})
    writer.write(rel, lambda path: np.savez_compressed(path, **arrays))
    return {"file": rel, "frames": manifest_value(frames),
            "camera_motion": manifest_value(None if regions.motion is None
                                            else asdict(regions.motion))}


def _save_flows(pairs: list[FramePair], regions: CameraRegions, plan: RunPlan,
                executor: RunWorkers, cache: Any, writer: FolderWriter,
                progress: Any) -> tuple[list[list[str]], list[dict[str, Any]]] | None:
    """The ground-truth flows of every consecutive pair (forward, backward) as
    ``flows/<key>.npy`` and the rest of its ``GroundTruthPair`` (``_save_pair``); their keys and
    the pairs' entries, or None when the camera has no temporal terms."""
    if len(pairs) < 2 or not consecutive(pairs):
        return None
    first = plan.read_gt(pairs[0], cache)
    try:
        check_flow_size(first.shape)
    except UndefinedMetricError:
        return None
    flow_cfg = FlowConfig(method=plan.config.flow)
    gray = _GrayFrames(lambda k: as_image(plan.read_gt(pairs[k], cache)), len(pairs))
    items = region_items(regions, plan.focus)

    def region(k: int, shape: tuple[int, ...]) -> np.ndarray | None:
        return (None if items is None or items[k] is None
                else region_item_mask(items[k], shape[:2], k))

    def terms(k: int, keys: list[str], flows: list[np.ndarray]) -> dict[str, Any]:
        with values_known_in(1.0, finite=True):  # read by dynaeval.io.images: no NaN/Inf pass
            prev, cur = (as_image(plan.read_gt(pairs[j], cache)) for j in (k, k + 1))
            got = ground_truth_pair(prev, cur, *flows, pair_region(region(k, prev.shape),
                                                                   region(k + 1, cur.shape)))
        return _save_pair(got, f"visible/{keys[1]}.npy", writer)

    def pair(k: int) -> tuple[list[str], Future]:
        with values_known_in(1.0, finite=True):
            (ga, da), (gb, db) = gray.take(k), gray.take(k + 1)
        keys, flows = [], []
        for x, y, digests in ((ga, gb, (da, db)), (gb, ga, (db, da))):
            key = FlowCache.key(x, y, flow_cfg, digests)
            flows.append(flow_from_gray(x, y, flow_cfg))
            writer.save(f"flows/{key}.npy", flows[-1])
            keys.append(key)
        progress.advance("pairs")
        return keys, beside.run(terms, k, keys, flows)

    with _Beside(executor.pool is None) as beside:
        done = executor.map(pair, range(len(pairs) - 1))
        return [keys for keys, _ in done], [entry.result() for _, entry in done]


class _Beside:
    """Calls run on a thread of their own, one at a time, for a run without worker threads: the
    ground truth's terms of pair ``k`` (its visibility, warp and warping errors) are computed
    while the flows of pair ``k + 1`` keep the other core busy (the work is the same, only its
    order changes: no number does). With worker threads (``enabled`` False) a call runs in the
    caller's thread. ``run`` returns the call's future (its error raised by ``result``);
    leaving the block waits for the call in flight."""

    def __init__(self, enabled: bool) -> None:
        self._pool = (ThreadPoolExecutor(max_workers=1, thread_name_prefix="dynaeval-prepare-pair")
                      if enabled else None)
        self._last: Future | None = None

    def run(self, fn: Any, *args: Any) -> Future:
        if self._pool is None:
            done: Future = Future()
            done.set_result(fn(*args))
            return done
        if self._last is not None:
            self._last.result()  # one in flight: its frames and flows are not held longer
        self._last = self._pool.submit(fn, *args)
        return self._last

    def __enter__(self) -> _Beside:
        return self

    def __exit__(self, *_: Any) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)


def _save_pair(terms: GroundTruthPair, rel: str, writer: FolderWriter) -> dict[str, Any]:
    """A pair's visibility mask bit-packed as ``rel`` (``PackedMask``'s bits) and its manifest
    entry: the mask's file and shape, ``E(gt)`` whole and focused (floats, which JSON gives
    back bit for bit, or None)."""
    packed = PackedMask.pack(terms.valid)
    if rel not in writer:  # two pairs of equal frames share one
        writer.save(rel, packed.bits)
    return {"visible": rel, "shape": list(packed.shape), "warp_error": list(terms.warp_error)}


class _GrayFrames:
    """The flow estimators' gray frames of a camera (``gray_of_checked`` and its
    ``gray_digest``, as a scoring run's ``FramePrep`` holds them), each made once: frame ``k`` is
    in pairs ``k - 1`` and ``k``, and kept until both took it. Thread-safe (two threads asking
    for one frame at once may both make it; the values agree)."""

    def __init__(self, load: Any, n: int) -> None:
        self._load = load
        self._uses = {k: (1 if k in (0, n - 1) else 2) for k in range(n)}
        self._kept: dict[int, tuple[np.ndarray, bytes]] = {}
        self._lock = threading.Lock()

    def take(self, k: int) -> tuple[np.ndarray, bytes]:
        """Frame ``k``'s ``(H, W)`` uint8 gray and its digest, for one of its pairs."""
        with self._lock:
            got = self._kept.get(k)
        if got is None:
            g = gray_of_checked(self._load(k))
            got = (g, gray_digest(g))
        with self._lock:
            self._uses[k] -= 1
            if self._uses[k] > 0:
                self._kept.setdefault(k, got)
            else:
                self._kept.pop(k, None)
        return got


def _gt_flicker(pairs: list[FramePair], regions: CameraRegions, plan: RunPlan,
                cache: Any) -> dict[str, Any] | None:
    """The ground truth's ``S`` of the flicker terms (``static_mean`` of its temporal std on the
    camera's static pixels, whole and inside the union of the frames' regions, as
    ``SequenceFlicker`` takes them: ``gt_means``) with the digest of the static mask they
    follow, or None when the camera has no static pixels to follow."""
    if not plan.focus.masked:
        return None
    acc, shape, static = None, None, None
    for p in pairs:
        with values_known_in(1.0, finite=True):  # read by dynaeval.io.images: no NaN/Inf pass
            frame = as_image(plan.read_gt(p, cache))
        if acc is None:
            shape = frame.shape
            static = static_pixels(regions, plan.focus, shape)
            if static is None or static.shape != shape[:2]:
                return None
            acc = TemporalStd(check_static(static, shape[:2]))
        elif frame.shape != shape:  # frames of several sizes: the temporal terms are null
            return None
        acc.update(frame)
    union = None  # the union of the frames' regions, as the temporal engine forms it
    for k, item in enumerate(region_items(regions, plan.focus) or ()):
        if item is not None:
            mask = region_item_mask(item, shape[:2], k)
            union = mask.copy() if union is None else union | mask
    std = acc.std()
    return {"static": static_digest(static),
            "gt": [static_mean(std, acc.pixels, None),
                   None if union is None else static_mean(std, acc.pixels, union)]}

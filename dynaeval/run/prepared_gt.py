"""A prepared ground truth read back: ``score ... --prepared PREP`` (``dynaeval.run.prepare`` writes it).

:func:`open_prepared` checks a prepared folder (``dynaeval.io.prepared``: its files and digests)
against a run before any frame is scored: other settings, another dynaeval version or format, a
ground-truth file that changed or is not in the folder: ``InputError`` naming the setting or the
file. It returns a :class:`PreparedGT`, which the run reads instead of computing: a camera's
regions, each ground-truth image's uint8 decoding, the ground-truth flows (by the flow cache's
content key), each consecutive pair's visibility mask and warping errors, the ground truth's
flicker means. A camera whose frames differ from the prepared ones (``--allow-missing``) gets its
regions computed again; its flows are content-keyed, so a flow is only ever reused for the very
same pair of ground-truth images.

The folder's layout is defined here, for the writer too: :func:`prepared_settings` (the settings
compared key by key), :func:`frame_rel` (a frame's name in the manifest), :data:`REGION_FIELDS`
(the arrays of a camera's regions file), :func:`static_digest` (the key of the flicker means) and
:func:`manifest_value` (a value as the manifest holds it).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError
from dynaeval.core.outcome import Outcome, Status, note
from dynaeval.core.version import VERSION
from dynaeval.io import FramePair
from dynaeval.io.frames import FrameRef, pairs_by_camera
from dynaeval.io.prepared import MANIFEST, PreparedFiles, file_digest, read_manifest
from dynaeval.metrics.flow import FlowCache, FlowConfig
from dynaeval.metrics.protocols import get_protocol
from dynaeval.metrics.temporal_pairs import GroundTruthPair
from dynaeval.regions.focus import CameraRegions, FrameRegions
from dynaeval.regions.packed import PackedMask
from dynaeval.regions.static_camera import CameraMotion
from dynaeval.run.config import ScoreConfig

__all__ = ["REGION_FIELDS", "PreparedGT", "frame_rel", "manifest_value", "open_prepared",
           "prepared_settings", "static_digest"]

REGION_FIELDS = ("boxes", "raw_boxes", "mask")
"""The arrays of a camera's ``regions/<i>.npz``, each stored as ``<field><k>`` for frame ``k``
(``mask``: ``PackedMask`` bits)."""


def manifest_value(value: Any) -> Any:
    """``value`` as the manifest holds it: JSON types, anything else as its ``str``."""
    return json.loads(json.dumps(value, default=str))


def prepared_settings(config: ScoreConfig, sources: Any,
                      temporal: bool | None = None) -> dict[str, Any]:
    """The settings a prepared ground truth depends on (``config``'s, ``sources`` opened from
    its focus; ``temporal``: whether the run has temporal terms, default ``config.temporal``):
    compared key by key when it is used."""
    return manifest_value({
        "background": config.background, "quantize": config.resolved_quantize(),
        "decode": get_protocol(config.protocol).decode_rule(), "focus": sources.settings,
        "flow": (FlowConfig(method=config.flow).describe()
                 if (config.temporal if temporal is None else temporal) else None),
    })


def frame_rel(ref: FrameRef, root: Path) -> str:
    """The file of ``ref`` relative to the ground-truth root, POSIX, ``#index`` for a video frame."""
    rel = Path(os.path.relpath(ref.path.resolve(), root.resolve())).as_posix()
    return rel if ref.index is None else f"{rel}#{ref.index}"


def static_digest(static: np.ndarray) -> str:
    """blake2b of a ``(H, W)`` bool mask (its shape and bits): the key of the prepared flicker
    means."""
    h = hashlib.blake2b(digest_size=16)
    h.update(repr(static.shape).encode())
    h.update(np.packbits(static).tobytes())
    return h.hexdigest()


@dataclass
class PreparedGT:
    """A prepared ground truth checked against one run: regions by camera, flows by key."""

    path: Path
    manifest: dict[str, Any]
    files: PreparedFiles
    """The folder's files, each checked against the manifest's digest when first read."""
    reuse: dict[str, bool] = field(default_factory=dict)
    """Camera -> its prepared regions match the run's frames (else computed again)."""
    decoded_files: dict[str, str] = field(default_factory=dict)
    """Resolved ground-truth image path -> its prepared uint8 decoding (``frames/<digest>.npy``,
    relative to the folder)."""

    def decoded(self, path: Path) -> np.ndarray | None:
        """The prepared decoding of the ground-truth image ``path`` (``FrameCache``'s
        ``decoded``: memory-mapped, read-only), or None: a prediction, or not prepared."""
        stored = self.decoded_files.get(str(Path(path).resolve()))
        return None if stored is None else self.files.load(stored, mmap=True)

    def regions(self, camera: str) -> CameraRegions | None:
        """The prepared regions of ``camera``, or None when they are computed again."""
        if not self.reuse.get(camera):
            return None
        entry = self.manifest["cameras"][camera]["regions"]
        motion = entry["camera_motion"]  # the camera's static check, as computed
        out = []
        with self.files.load(entry["file"]) as arrays:
            for k, f in enumerate(entry["frames"]):
                got = {n: arrays[f"{n}{k}"] if f"{n}{k}" in arrays else None for n in REGION_FIELDS}
                packed = (None if got["mask"] is None else
                          PackedMask(got["mask"], tuple(f["mask_shape"])))  # kept packed
                out.append(FrameRegions(
                    boxes=got["boxes"], packed_mask=packed,
                    boxes_missing=_missing(f["boxes_reason"], f.get("boxes_status")),
                    mask_missing=_missing(f["mask_reason"], f.get("mask_status")),
                    raw_boxes=got["raw_boxes"], records=f["records"],
                    size=None if f["size"] is None else tuple(f["size"])))
        return CameraRegions(out, motion=None if motion is None else CameraMotion(**motion))

    def gt_flicker(self, camera: str, static: np.ndarray) -> tuple[float | None, float | None] | None:
        """The ground truth's ``S`` on ``camera``'s static pixels ``static``, whole and inside
        the union of the regions (``SequenceFlicker``'s ``gt_means``), or None when computed
        again: frames that differ from the prepared ones, other static pixels (``--masks``),
        none prepared."""
        entry = (self.manifest["cameras"].get(camera) or {}).get("flicker")
        if not self.reuse.get(camera) or not entry or entry["static"] != static_digest(static):
            return None
        whole, focused = entry["gt"]
        return whole, focused

    def ground_truth_pairs(self, camera: str) -> Any:
        """``k -> GroundTruthPair`` of ``camera``'s pair ``k`` (frames ``k, k + 1``), read from
        the folder (flows memory-mapped, visibility mask unpacked, ``E(gt)`` from the manifest),
        or None when they are computed again: frames that differ from the prepared ones, a
        camera without prepared pairs."""
        entry = self.manifest["cameras"].get(camera) or {}
        if not self.reuse.get(camera) or not entry.get("gt_pairs"):
            return None

        def load(k: int) -> GroundTruthPair:
            (fw, bw), got = entry["flows"][k], entry["gt_pairs"][k]
            valid = PackedMask(self.files.load(got["visible"]), tuple(got["shape"])).unpack()
            e_whole, e_focused = got["warp_error"]
            return GroundTruthPair(self._flow(fw), self._flow(bw), valid, (e_whole, e_focused))

        return load

    def _flow(self, key: str) -> np.ndarray:
        """The prepared flow ``key``, memory-mapped read-only."""
        return self.files.load(f"flows/{key}.npy", mmap=True)

    def flow_cache(self) -> Any:
        """A flow cache (64 MiB in memory, as the run's own) that reads the prepared flows."""
        known = {k: self.path / "flows" / f"{k}.npy"
                 for cam in self.manifest["cameras"].values() for pair in cam["flows"] or ()
                 for k in pair}
        return FlowCache(max_bytes=1 << 26, known=known, load_known=self._load_flow)

    def _load_flow(self, path: Path) -> np.ndarray:
        return self.files.load(path.relative_to(self.path).as_posix(), mmap=True)

    def describe(self) -> dict[str, Any]:
        """``settings["prepared"]`` of the results: the folder and its id (the same for every
        shard of a run, so that ``dynaeval merge`` combines them)."""
        return {"path": str(self.path), "id": self.manifest["id"]}

    def warnings(self) -> list[dict[str, str]]:
        """One results warning per camera whose regions were computed again."""
        return [note("regions computed again, not read from the prepared ground truth: the "
                     "camera's frames differ from the prepared ones (or it is no video)",
                     camera=cam)
                for cam, ok in self.reuse.items() if not ok]


def _missing(reason: str | None, status: str | None) -> Outcome | None:
    """A ``FrameRegions`` region's ``*_missing`` as stored in the manifest (both None: the frame
    has its region; a reason without a status, a folder of format 2: ``NO_REGION``)."""
    if reason is None and status is None:
        return None
    return Outcome(None, Status.NO_REGION if status is None else Status(status), reason)


def open_prepared(path: str | Path, gt_root: Path, pairs: list[FramePair],
                  config: ScoreConfig, sources: Any, *, temporal: bool | None = None) -> PreparedGT:
    """Check the prepared ground truth at ``path`` against a run (its ground-truth folder, its
    pairs, its settings and region ``sources``; ``temporal``: whether it has temporal terms,
    default ``config.temporal``) and open it.

    Raises:
        InputError: not a prepared folder; another format or dynaeval version; a setting that
            differs (named, with both values); a ground-truth file that is not in it or changed
            since (named).
    """
    path = Path(path)
    manifest = read_manifest(path)
    where = path / MANIFEST
    if manifest.get("dynaeval_version") != VERSION:
        raise InputError(f"prepared with dynaeval {manifest.get('dynaeval_version')}, this is "
                         f"{VERSION}: prepare it again", path=where)
    _check_settings(manifest["settings"], prepared_settings(config, sources, temporal), where)
    digests: dict[str, str] = {}
    for p in pairs:
        rel = frame_rel(p.gt, gt_root).split("#")[0]
        if rel in digests:
            continue
        if rel not in manifest["files"]:
            raise InputError("ground-truth file is not in the prepared ground truth "
                             f"{path} (added since?): run 'dynaeval prepare' again", path=p.gt.path)
        digests[rel] = file_digest(p.gt.path)
        if digests[rel] != manifest["files"][rel]:
            raise InputError(f"ground-truth file changed since it was prepared in {path}: run "
                             "'dynaeval prepare' again", path=p.gt.path)
    prepared = PreparedGT(path, manifest, PreparedFiles(path, manifest["hashes"]))
    for rel, stored in manifest.get("decoded", {}).items():  # only files checked just above
        if rel in digests:
            prepared.decoded_files[str((gt_root / rel).resolve())] = stored
    for cam, cam_pairs in pairs_by_camera(pairs).items():
        entry = manifest["cameras"].get(cam)
        frames = [[p.frame, frame_rel(p.gt, gt_root)] for p in cam_pairs]
        prepared.reuse[cam] = bool(entry and entry["regions"] and entry["frames"] == frames)
    prepared.files.check_in_background(_files_in_order_of_use(prepared, pairs, gt_root))
    return prepared


def _files_in_order_of_use(prepared: PreparedGT, pairs: list[FramePair], gt_root: Path) -> list[str]:
    """The prepared files a run of ``pairs`` reads, camera by camera as it reads them (regions,
    decoded frames, flows and visibility masks): the order of the background check."""
    out: list[str] = []
    for cam, cam_pairs in pairs_by_camera(pairs).items():
        entry = prepared.manifest["cameras"].get(cam) or {}
        if prepared.reuse.get(cam):
            out.append(entry["regions"]["file"])
        out += [prepared.manifest["decoded"][rel] for rel in
                (frame_rel(p.gt, gt_root).split("#")[0] for p in cam_pairs)
                if rel in prepared.manifest.get("decoded", {})]
        for k, pair in enumerate(entry.get("flows") or ()):
            out += [f"flows/{key}.npy" for key in pair]
            if prepared.reuse.get(cam) and entry.get("gt_pairs"):
                out.append(entry["gt_pairs"][k]["visible"])
    return out


def _check_settings(prepared: dict[str, Any], run: dict[str, Any], where: Path) -> None:
    """InputError naming the first setting of the run that differs from the prepared one's."""
    for key, value in run.items():
        got = prepared.get(key)
        if key == "flow" and (value is None or got is None):
            continue  # no temporal terms in the run, or no flows prepared (computed as usual)
        if got != value:
            name, got, value = _first_difference(key, got, value)
            raise InputError(
                f"setting {name!r} differs from the prepared ground truth's: prepared "
                f"{json.dumps(got)}, this run {json.dumps(value)}; score with the prepared "
                "settings or run 'dynaeval prepare' again with these", path=where)


def _first_difference(key: str, a: Any, b: Any) -> tuple[str, Any, Any]:
    """The dotted name and the two values of the first leaf where settings ``a`` and ``b``
    differ (``focus.source``, not the whole ``focus`` dict)."""
    while isinstance(a, dict) and isinstance(b, dict):
        sub = next((k for k in dict.fromkeys([*a, *b]) if a.get(k) != b.get(k)), None)
        if sub is None:
            break
        key, a, b = f"{key}.{sub}", a.get(sub), b.get(sub)
    return key, a, b

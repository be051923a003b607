"""How small an object the detector test of presence can judge (issue 43).

    python -m reference_models.studies.detector_size SCENE [SCENE ...] [--every 3] [--noise 0.01]
        [--write]

Each SCENE is a generator output folder (``python -m reference_models.scenes render PRESET DIR
--size small``). For every ``--every``-th frame of every camera, the bundled detector runs on
the ground truth (the objects presence judges under ``--focus detector``) and on a near-perfect
prediction of it (the ground truth plus Gaussian noise of sigma ``--noise``, 8-bit: ~40 dB).
Each ground-truth detection is then matched to a same-class detection on the prediction as
presence's detector test matches it (``match_objects``, IoU >= 0.5). A near-perfect prediction
shows every object, so an unmatched one is the detector's error, not the prediction's; the table
gives the rate at which objects are re-found by their shorter side *at the detector's input*
(the letterboxed frame: 416 px on the longer side), and the smallest side from which every bin
re-finds at least ``RELIABLE_RATE`` of its objects: ``dynaeval.regions.detector``'s
``RELIABLE_SIDE``, below which presence decides by the region test alone.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from reference_models.common.paths import docs_dir
from reference_models.studies._doc import replace_block

DOC = "presence.md"
BEGIN, END = "<!-- BEGIN detector_size -->", "<!-- END detector_size -->"
EDGES = (0, 4, 6, 8, 10, 12, 16, 24, 10_000)
"""Bins of the shorter side at the detector's input (px)."""
RELIABLE_RATE = 0.99
"""Re-found share a size bin needs (and every larger bin) to count as reliable: a near-perfect
prediction must not lose more than 1 object in 100 to the detector."""
MIN_OBJECTS = 20
"""Objects (both classes) a bin needs to decide; smaller bins are shown, not used."""


def _frames(scene: Path, every: int):  # noqa: ANN202
    import cv2

    for cam in sorted(p for p in (scene / "images").iterdir() if p.is_dir()):
        for k, f in enumerate(sorted(cam.glob("*.png"))):
            if k % every == 0:
                yield cam.name, f.stem, cv2.imread(str(f))[..., ::-1]


def measure(scenes: list[Path], every: int = 3, sigma: float = 0.01, seed: int = 0) -> list[dict]:
    """One row per ground-truth detection: scene, class, shorter side at the input (px),
    whether the detector re-found it on the noisy prediction at IoU >= 0.5."""
    from dynaeval.metrics.presence import match_objects
    from dynaeval.regions.detector import Detector

    det = Detector()
    rng = np.random.default_rng(seed)
    rows = []
    for scene in scenes:
        for _, _, gt in _frames(scene, every):
            noisy = np.clip(gt.astype(np.float64) + rng.normal(0, 255 * sigma, gt.shape), 0, 255)
            found, again = det(gt), det(np.round(noisy).astype(np.uint8))
            if not len(found):
                continue
            match = match_objects(found.boxes, list(found.classes), again.boxes,
                                  list(again.classes), iou_min=0.5, det_scores=again.scores)
            scale = det.input_scale(gt.shape[:2])
            for box, cls, m in zip(found.boxes, found.classes, match, strict=True):
                side = float(min(box[2] - box[0], box[3] - box[1])) * scale
                rows.append({"scene": scene.name, "class": cls, "side": side, "found": bool(m >= 0)})
    return rows


def reliable_side(rows: list[dict], rate: float = RELIABLE_RATE) -> int:
    """The smallest bin edge from which every bin of at least ``MIN_OBJECTS`` objects (the
    classes pooled: the detector's boxes move alike) re-finds ``rate`` of them."""
    side = EDGES[-2]
    for lo, hi in reversed(list(zip(EDGES[:-1], EDGES[1:], strict=True))):
        mine = [r["found"] for r in rows if lo <= r["side"] < hi]
        if len(mine) >= MIN_OBJECTS and np.mean(mine) < rate:
            break
        side = lo
    return side


def table(rows: list[dict], scenes: list[Path], every: int, sigma: float) -> str:
    lines = [f"Scenes {', '.join(s.name for s in scenes)} (one frame in {every} of every camera), "
             f"prediction = ground truth + noise sigma {sigma} (8-bit); IoU >= 0.5.", "",
             "| shorter side at the input (px) | persons | re-found | balls | re-found | all | re-found |",
             "|---|---|---|---|---|---|---|"]
    for lo, hi in zip(EDGES[:-1], EDGES[1:], strict=True):
        cells = []
        for cls in ("person", "ball", None):
            mine = [r["found"] for r in rows if cls in (None, r["class"]) and lo <= r["side"] < hi]
            cells += [str(len(mine)), f"{np.mean(mine):.2f}" if mine else "–"]
        label = f">= {lo}" if hi == EDGES[-1] else f"{lo}–{hi}"
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", f"Smallest side from which every bin of >= {MIN_OBJECTS} objects re-finds >= "
                  f"{RELIABLE_RATE:.0%}: **{reliable_side(rows)} px** at the input."]
    return "\n".join(lines)


def presence_check(preset: str = "players-stadium",
                   cameras=tuple(f"cam{i:02d}" for i in range(0, 30, 4)) + ("eval00", "eval01"),
                   frames=range(0, 24, 3), sigma: float = 0.01, seed: int = 0) -> str:
    """Presence under ``--focus detector`` (the detector on the ground truth gives the objects,
    on the prediction the detector test) of a near-perfect prediction (noise ``sigma``, 8-bit)
    and of one where every player has vanished (the view rendered without them), with the
    detector trusted at every size (``detector_min_input_side=0``, the rule before issue 43)
    and with the measured rule (the default): a Markdown table."""
    from dynaeval.metrics.presence import PresenceConfig, frame_presence
    from dynaeval.regions.detector import Detector
    from reference_models.studies.presence import noise, render_frames

    det, rules = Detector(), {"every size": PresenceConfig(detector_min_input_side=0.0),
                              "measured": PresenceConfig()}
    sums = {(k, r): [] for k in ("near-perfect", "players vanished") for r in rules}
    decided: dict[str, int] = {}
    for cam in cameras:
        for f in render_frames(preset, cam, seed, frames, hide=("person",)):
            gt = np.round(f.gt * 255) / 255
            preds = {"near-perfect": np.round(noise(gt, sigma, seed) * 255) / 255,
                     "players vanished": np.round(f.hidden["person"] * 255) / 255}
            records = det(gt).records()
            for kind, pred in preds.items():
                found = det(pred)
                for name, cfg in rules.items():
                    fp = frame_presence(pred, gt, records, detections=found, config=cfg)
                    if fp.values["presence_person"] is not None:
                        sums[(kind, name)].append(fp.values["presence_person"])
                    if kind == "near-perfect" and name == "measured":
                        for o in fp.objects:
                            decided[o["decided_by"]] = decided.get(o["decided_by"], 0) + 1
    lines = [f"{preset} {', '.join(cameras)}, frames {list(frames)}, seed {seed}; objects: the "
             "detector on the ground truth; mean `presence_person` over the frames:", "",
             "| prediction | detector trusted at every size (before) | measured rule (now) |",
             "|---|---|---|"]
    for kind in ("near-perfect", "players vanished"):
        lines.append(f"| {kind} | " + " | ".join(f"{np.mean(sums[(kind, r)]):.3f}"
                                                 for r in rules) + " |")
    lines += ["", "Near-perfect, who decided: " + ", ".join(f"`{k}` {v}"
                                                            for k, v in sorted(decided.items()))]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", type=Path)
    ap.add_argument("--every", type=int, default=3)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--write", action="store_true", help=f"write the table into docs/{DOC}")
    args = ap.parse_args()
    rows = measure(args.scenes, args.every, args.noise)
    text = table(rows, args.scenes, args.every, args.noise) + "\n\n" + presence_check()
    print(text)
    if args.write:
        replace_block(docs_dir() / DOC, BEGIN, END, text)


if __name__ == "__main__":
    main()

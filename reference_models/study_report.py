"""The validation study's report (docs/validation.md), generated from the study folder only.

Nothing here is typed by hand: tables come from the results files, times from the runs'
``train.json`` / ``render.json``, findings are comparisons of those numbers, crops are cut from
the renders with the generator's exact boxes.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.io.atomic import write_text_atomic

TABLE_METRICS = (
    ("psnr", "PSNR"), ("focused_psnr", "f-PSNR"), ("masked_psnr", "m-PSNR"),
    ("ssim", "SSIM"), ("focused_ssim", "f-SSIM"), ("masked_ssim", "m-SSIM"),
    ("lpips", "LPIPS"), ("focused_lpips", "f-LPIPS"),
    ("presence_person", "pres. person"), ("presence_ball", "pres. ball"),
    ("tight_psnr_ball", "ball PSNR"),
    ("warp_error", "warp err"), ("tof", "tOF"), ("flicker", "flicker"),
)


def _load(study: Path) -> list[dict[str, Any]]:
    docs = []
    for path in sorted((study / "results").glob("*.json")):
        doc = json.loads(path.read_text())
        scene, run = path.stem.split("__")
        run_dir = study / "runs" / scene / run
        doc["_train"] = json.loads((run_dir / "train.json").read_text())
        doc["_render"] = json.loads((run_dir / "render.json").read_text())
        doc["_run"] = run_dir
        docs.append(doc)
    return docs


def _fmt(name: str, v: Any) -> str:
    if v is None:
        return "n/a"
    if "psnr" in name:
        return f"{v:.2f}"
    if name.startswith("presence"):
        return f"{v:.2f}"
    return f"{v:.4f}" if abs(v) >= 1e-3 or v == 0 else f"{v:.1e}"


def _train_cpu_min(train: dict) -> float:
    """A run's training time in CPU minutes (``train_cpu_seconds``; what ``--clock cpu``
    budgets, and unlike the wall time not cut short by a resume); wall minutes for a run
    that did not record it."""
    return train.get("train_cpu_seconds", train["wall_s"]) / 60


def train_device(train: dict) -> str:
    """What trained a run, from its ``train.json``: the GPU's name, ``cpu``; a run recorded before
    the device option trained on the CPU."""
    return train.get("device_name") or train.get("device") or "cpu"


def _train_min_cell(train: dict) -> str:
    """The table's training minutes: CPU minutes on the CPU, wall minutes (marked) on a GPU,
    where process CPU time counts only the kernel launches."""
    if train.get("device", "cpu") != "cpu":
        return f"{train['train_seconds'] / 60:.1f} wall"
    return f"{_train_cpu_min(train):.1f}"


def code_cell(train: dict) -> str:
    """The code a run trained with, from its ``train.json``: the commit's first 8 hex digits
    (``+changes`` where files differed from it), or ``not recorded`` (runs before the study
    recorded it, or an installed package)."""
    code = train.get("code")
    if not code:
        return "not recorded"
    return code["commit"][:8] + ("+changes" if code["dirty"] else "")


def code_line(docs: list[dict], study: Path) -> str:
    """One sentence naming the commits the study's runs and stadiums trained with, and how many
    of each (a study resumed across commits says so instead of hiding it)."""
    trains = [d["_train"] for d in docs] + [
        json.loads(f.read_text()) for f in sorted((study / "runs").glob("*/*-stadium/train.json"))]
    counts = Counter(code_cell(t) for t in trains)
    return "Code: " + ", ".join(f"`{name}` ({n} run{'s' * (n != 1)})"
                                for name, n in sorted(counts.items())) + \
        " (runs and stadiums; the commit of the checkout each trained from)."


def _stadium_cell(train: dict) -> str:
    """The CPU minutes of the pre-trained stadium a run started from ("—" for none)."""
    stadium = train.get("stadium")
    return "—" if not stadium else f"{stadium['train_cpu_seconds'] / 60:.1f}"


def scene_table(docs: list[dict]) -> str:
    cols = [(k, label) for k, label in TABLE_METRICS if any(k in d["summary"] for d in docs)]
    head = ("| run | " + " | ".join(label for _, label in cols)
            + " | train min | + stadium min | steps | render s | device |")
    sep = "|---" * (len(cols) + 6) + "|"
    rows = []
    for d in docs:
        cells = [_fmt(k, d["summary"].get(k)) for k, _ in cols]
        rows.append(f"| {d['method']} | " + " | ".join(cells)
                    + f" | {_train_min_cell(d['_train'])} | {_stadium_cell(d['_train'])} "
                    f"| {d['_train'].get('step', 'n/a')} "
                    f"| {d['_render']['wall_s']:.1f} | {train_device(d['_train'])} |")
    return "\n".join([head, sep, *rows])


def stadium_lines(study: Path, scene: str) -> list[str]:
    """What each pre-trained stadium of ``scene`` cost and how well it shows the empty stadium
    (its last logged eval PSNR, on the eval cameras' empty-stadium views)."""
    out = []
    for f in sorted((study / "runs" / scene).glob("*-stadium/train.json")):
        t = json.loads(f.read_text())
        psnr = t.get("eval_psnr")
        out.append(f"- `{f.parent.name}` ({t['size']}): {_train_min_cell(t)} min, "
                   f"{t.get('step', 'n/a')} steps of {t.get('batch_rays', 'n/a')} rays"
                   + (f", eval PSNR {psnr:.2f} dB on the empty stadium" if psnr is not None else "")
                   + "; every run of its model on this scene starts from it.")
    return ["Pre-trained stadium:", "", *out, ""] if out else []


def _crop(img: np.ndarray, box: list[int], size: int = 96, pad: float = 0.6) -> np.ndarray:
    import cv2

    h, w = img.shape[:2]
    x0, y0, x1, y1 = box
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    half = max(x1 - x0, y1 - y0) * (0.5 + pad) + 4
    a, b = int(max(0, cx - half)), int(min(w, cx + half))
    c, d = int(max(0, cy - half)), int(min(h, cy + half))
    crop = img[c:d, a:b]
    return cv2.resize(crop, (size, size), interpolation=cv2.INTER_NEAREST)


def crops_figure(docs: list[dict], data: Path, out: Path) -> tuple[str, str] | None:
    """Player and ball crops of one eval frame: ground truth then each run. Returns (camera/frame,
    image path) or None when the frame shows no player."""
    import cv2

    boxes = json.loads((data / "boxes.json").read_text())
    boxes = boxes.get("boxes", boxes)
    first = docs[0]["frames"]
    frame = first[len(first) // 2]
    key = f"{frame['camera']}/{frame['frame']}"
    objs = {b["class"]: b["box"] for b in sorted(boxes.get(key, []), key=lambda b: -b["visible"])}
    if "person" not in objs:
        return None
    gt = cv2.imread(str(data / "images" / f"{key}.png"))
    tiles = [("ground truth", gt)] + [
        (d["method"], cv2.imread(str(d["_run"] / "pred" / f"{key}.png"))) for d in docs]
    rows = []
    for cls in ("person", "ball"):
        if cls in objs:
            rows.append(np.concatenate([_crop(img, objs[cls]) for _, img in tiles], axis=1))
    grid = np.concatenate(rows, axis=0)
    out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out), grid)
    return key, " · ".join(name for name, _ in tiles)


def frames_better(base: dict, other: dict, key: str) -> tuple[int, int]:
    """(frames where ``other``'s ``key`` is higher than ``base``'s, frames where both have one),
    frames matched by camera and frame name: how consistent a difference of means is."""
    before = {(f["camera"], f["frame"]): f.get(key) for f in base["frames"]}
    pairs = [(before.get((f["camera"], f["frame"])), f.get(key)) for f in other["frames"]]
    pairs = [(a, b) for a, b in pairs if a is not None and b is not None]
    return sum(b > a for a, b in pairs), len(pairs)


def findings(by_scene: dict[str, list[dict]]) -> list[str]:
    """Statements of the seed study, checked against these numbers."""
    out: list[str] = []

    def s(d: dict, k: str) -> float | None:
        return d["summary"].get(k)

    # 1. importance sampling helps the player and the ball (judged on their own pixels: the
    #    tight-box PSNR of each object; the expanded-box and motion-mask PSNR are shown beside)
    for scene, docs in by_scene.items():
        runs = {d["method"]: d for d in docs}
        for model in sorted({m.rsplit("-", 1)[0] for m in runs}):
            u, i = runs.get(f"{model}-uniform"), runs.get(f"{model}-isg")
            if not (u and i):
                continue
            parts, verdicts = [], []
            for k in ("tight_psnr_person", "masked_psnr", "focused_psnr", "tight_psnr_ball",
                      "presence_ball"):
                if s(u, k) is not None and s(i, k) is not None:
                    parts.append(f"{k} {s(u, k):.3f} → {s(i, k):.3f} ({s(i, k) - s(u, k):+.3f})")
            for what, k in (("player", "tight_psnr_person"), ("ball", "tight_psnr_ball")):
                if s(u, k) is not None and s(i, k) is not None:
                    better, n = frames_better(u, i, k)
                    verdicts.append(f"{what} {'holds' if s(i, k) > s(u, k) else 'does not hold'}"
                                    f" (IS better on {better} of {n} frames)")
            if parts:
                out.append(f"- **IS helps the player and the ball** ({scene}, {model}): "
                           f"{', '.join(verdicts) or 'n/a'} — " + "; ".join(parts))
    # 2. broadcast and stadium-wide views are harder than close-up
    scenes = list(by_scene)
    if "single-player-closeup" in by_scene:
        for scene in scenes:
            if scene == "single-player-closeup":
                continue
            for d in by_scene[scene]:
                ref = next((c for c in by_scene["single-player-closeup"]
                            if c["method"] == d["method"]), None)
                if ref and s(ref, "focused_psnr") is not None and s(d, "focused_psnr") is not None:
                    harder = s(d, "focused_psnr") < s(ref, "focused_psnr")
                    out.append(f"- **{scene} is harder than close-up** ({d['method']}, focused "
                               f"PSNR {s(ref, 'focused_psnr'):.2f} → {s(d, 'focused_psnr'):.2f}): "
                               f"{'holds' if harder else 'does not hold'}")
    # 3. region metrics rank runs the other way from whole-frame metrics
    for scene, docs in by_scene.items():
        for key, label in (("focused_psnr", "focused (expanded boxes)"),
                           ("masked_psnr", "masked (motion masks)"),
                           ("tight_psnr_person", "player tight-box")):
            flips = []
            for a, b in combinations(docs, 2):
                if None in (s(a, "psnr"), s(b, "psnr"), s(a, key), s(b, key)):
                    continue
                da, dr = s(a, "psnr") - s(b, "psnr"), s(a, key) - s(b, key)
                if da * dr < 0:
                    flips.append(f"{a['method']} vs {b['method']} (PSNR {da:+.2f} dB, {key} "
                                 f"{dr:+.2f} dB)")
            out.append(f"- **{label} and whole-frame PSNR rank runs differently** ({scene}): "
                       + (f"{len(flips)} of {len(docs) * (len(docs) - 1) // 2} pairs: "
                          + "; ".join(flips) if flips
                          else "no pair of runs is ranked the other way here"))
    return out


def disagreements(docs: list[dict], data: Path, img_dir: Path, scene: str,
                  rel: str) -> list[str]:
    """Frames where whole-frame and focused PSNR disagree most between two runs, with crops."""
    import cv2

    lines: list[str] = []
    best = None
    for a, b in combinations(docs, 2):
        for fa, fb in zip(a["frames"], b["frames"], strict=True):
            vals = [fa.get("psnr"), fb.get("psnr"), fa.get("focused_psnr"), fb.get("focused_psnr")]
            if None in vals:
                continue
            dw, df = vals[0] - vals[1], vals[2] - vals[3]
            if dw * df < 0 and (best is None or abs(dw * df) > best[0]):
                best = (abs(dw * df), a, b, fa, fb, dw, df)
    if best is None:
        return [f"No frame of {scene} where whole-frame and focused PSNR disagree between two "
                "runs."]
    _, a, b, fa, fb, dw, df = best
    key = f"{fa['camera']}/{fa['frame']}"
    boxes = json.loads((data / "boxes.json").read_text())
    boxes = boxes.get("boxes", boxes)
    person = next((o["box"] for o in boxes.get(key, []) if o["class"] == "person"), None)
    tight = [fa.get("tight_psnr_person"), fb.get("tight_psnr_person")]
    if person is not None:
        imgs = [cv2.imread(str(data / "images" / f"{key}.png"))] + [
            cv2.imread(str(d["_run"] / "pred" / f"{key}.png")) for d in (a, b)]
        out = img_dir / f"{scene}-disagree.png"
        cv2.imwrite(str(out), np.concatenate([_crop(i, person, 128) for i in imgs], axis=1))
        lines += [f"![{scene} disagreement]({rel}/{out.name})", ""]
    winner_whole = a["method"] if dw > 0 else b["method"]
    winner_focus = a["method"] if df > 0 else b["method"]
    lines.append(f"Frame `{key}`: whole-frame PSNR prefers **{winner_whole}** ({dw:+.2f} dB for "
                 f"{a['method']}), focused PSNR prefers **{winner_focus}** ({df:+.2f} dB). "
                 "Crops: ground truth, " + f"{a['method']}, {b['method']}.")
    if None not in tight:
        eye = a["method"] if tight[0] > tight[1] else b["method"]
        lines.append(f"The player's own pixels (tight-box PSNR {tight[0]:.2f} vs {tight[1]:.2f} "
                     f"dB) side with **{eye}**, i.e. with the "
                     f"{'focused' if eye == winner_focus else 'whole-frame'} metric.")
    return lines


def study_elapsed_s(study: Path) -> float:
    """Seconds from the start of the first scene render to the last results file written
    (file times; scene render start = ``timing.json``'s time minus its ``render_seconds``)."""
    starts = [f.stat().st_mtime - json.loads(f.read_text())["render_seconds"]
              for f in (study / "data").glob("*/timing.json")]
    ends = [f.stat().st_mtime for f in (study / "results").glob("*.json")]
    if not starts or not ends:
        return 0.0
    return max(ends) - min(starts)


def write_report(study: Path, path: Path, *, preset: str, command: str,
                 results_dir: Path | None = None) -> Path:
    """Write the Markdown report of ``study`` to ``path`` (images next to it in img/)."""
    docs = _load(study)
    from reference_models.study import PRESETS, SCENES

    by_scene: dict[str, list[dict]] = {}
    for d in sorted(docs, key=lambda d: (SCENES.index(d["scene"]) if d["scene"] in SCENES
                                         else len(SCENES), d["scene"], d["method"])):
        by_scene.setdefault(d["scene"], []).append(d)
    img_dir = path.parent / "img" / f"validation-{preset}"
    img_dir.mkdir(parents=True, exist_ok=True)
    rel = os.path.relpath(img_dir, path.parent)
    total_train = sum(d["_train"]["wall_s"] for d in docs)
    total_render = sum(d["_render"]["wall_s"] for d in docs)
    total_score = sum(d["timing"]["total_s"] for d in docs)
    elapsed = study_elapsed_s(study)
    lines = [
        f"# Validation study ({preset} preset)",
        "",
        "Generated by `reference_models/study_report.py` from the study folder; no number here "
        "is typed by hand. Reproduce with:",
        "",
        f"    {command}",
        "",
        f"Machine: {os.cpu_count()} CPU cores (shared); wall time: training "
        f"{total_train / 60:.1f} min, rendering {total_render / 60:.1f} min, scoring "
        f"{total_score / 60:.1f} min over {len(docs)} runs (summed over runs; with `--jobs 2` "
        f"two run at once). From the first scene render to the last result "
        f"{elapsed / 60:.1f} min elapsed (including any pause before a resume).",
        "",
        "Trained on: " + ", ".join(f"{name} ({n} run{'s' * (n != 1)})" for name, n in sorted(
            Counter(train_device(d["_train"]) for d in docs).items())) + "; `train min` is "
        "CPU minutes on the CPU, wall minutes (marked) on a GPU.",
        "",
        code_line(docs, study),
        "",
        *([f"Training: {PRESETS[preset].description}.", ""]
          if preset in PRESETS and PRESETS[preset].description else []),
        "Runs are `<model>-<sampling>`: `uniform` samples training rays uniformly, `isg` uses ray "
        "importance sampling (ISG weights from dynaeval's motion masks). Metrics: whole frame, "
        "`f-` focused (generator's exact boxes, expanded as in the paper), `m-` masked (motion "
        "masks of the ground truth); presence and ball PSNR on each object's tight box; temporal "
        "terms lower is better. LPIPS columns appear only where the backbone weights were on the "
        "machine.",
        "",
    ]
    if results_dir is not None:
        rel_results = os.path.relpath(results_dir, path.parent)
        schemas = ", ".join(f"`{name}`" for name in sorted({d["schema"] for d in docs}))
        lines += [f"Every run's results JSON ({schemas}) and the leaderboard are in "
                  f"[{rel_results}/]({rel_results}/).", ""]
    for scene, sdocs in by_scene.items():
        lines += [f"## {scene}", "", scene_table(sdocs), "", *stadium_lines(study, scene)]
        fig = crops_figure(sdocs, study / "data" / scene, img_dir / f"{scene}-crops.png")
        if fig:
            key, order = fig
            lines += [f"![{scene} crops]({rel}/{scene}-crops.png)", "",
                      f"Frame `{key}`, player (top) and ball (bottom): {order}.", ""]
        lines += ["### Where whole-frame and focused metrics disagree", ""]
        lines += disagreements(sdocs, study / "data" / scene, img_dir, scene, rel) + [""]
    lines += ["## The seed study's findings, checked", "", *findings(by_scene), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, "\n".join(lines) + "\n", overwrite=True)
    return path

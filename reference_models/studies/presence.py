"""Object presence (issue 11): calibrate the region-test thresholds, then validate them.

**Calibration** (seed 1 of the scenes): for every ground-truth object of the chosen views, the
per-object ``ncc`` / ``psnr`` of ``dynaeval.metrics.presence`` are computed for predictions that
*show* the object, lightly degraded (``PRESENT_KINDS``: Gaussian blur sigma 1 px, JPEG quality 30,
Gaussian noise sigma 0.03, a 1-sample-per-pixel render (aliasing), the whole frame shifted by 1 px),
and for predictions where it is *erased* (the view rendered without the object's class: the pitch
or stands behind it, no shadow). Per class, the thresholds ``(ncc_min, psnr_min)`` on a grid
(0.01 / 0.5 dB) minimise misses + false detections (each as a fraction of its set, an object
below ``visibility_min`` always counting as flagged); among the minimisers, ``ncc_min`` is the
middle of the widest run at the lowest ``psnr_min`` that reaches the minimum, then ``psnr_min`` the
middle of the widest run at that ``ncc_min``, so both boundaries sit between the two sets, not on
one of them. Heavier blur (sigma 2 px) and ghosts are
reported, not used.

**Validation** (seed 0, other scenes' objects than the calibration's): a "good method" prediction
(the ground truth blurred with sigma 0.7 px plus noise sigma 0.01, 8-bit) is scored with
``dynaeval.score`` and the generator's boxes file; then the same prediction with the ball *erased*
(the render without the ball, degraded the same way) or *ghosted* (the ball blended in at 30 / 60 /
90 % opacity over the pitch behind it) on chosen frames only. The table says on which frames
``presence_ball`` fell (must be exactly the chosen ones for erased balls, never an untouched frame)
and how little full-frame and focused PSNR moved.

Deterministic (fixed seeds, no timing); a few minutes:

    python -m reference_models.studies.presence            # prints the Markdown
    python -m reference_models.studies.presence --write    # also updates docs/presence.md
    python -m reference_models.studies.presence --models-scene SCENE --positive NAME=PRED ...
        [--context NAME=PRED ...] [--write]   # person thresholds again, model renders as shown

The last form adds the players of model renders that keep them to the shown set (the issue-21
recalibration; its block in docs/presence.md is written only by it).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dynaeval.metrics.presence import PresenceConfig, crop_similarity, tight_box, visibility
from reference_models.common.paths import docs_dir
from reference_models.studies._doc import replace_block

DOC = "presence.md"  # in the repository's docs/ (reference_models.common.paths)
BEGIN, END = "<!-- BEGIN presence_study -->", "<!-- END presence_study -->"

CALIBRATION_VIEWS = (("single-player-broadcast", "eval00"), ("single-player-closeup", "eval00"),
                     ("players-stadium", "eval00"), ("players-stadium", "eval01"))
"""(preset, camera) pairs of the calibration (seed ``CALIBRATION_SEED``)."""
CALIBRATION_SEED = 1
CALIBRATION_FRAMES = range(1, 24, 3)
"""Frames of each calibration view (small size: 24 frames)."""
PRESENT_KINDS = ("blur1", "jpeg30", "noise3", "spp1", "shift1")
"""Degradations after which an object still counts as shown (the positive set)."""
REPORTED_KINDS = ("blur2", "ghost30", "ghost60", "ghost90")
"""Reported for context, not used to choose thresholds."""

VALIDATION_VIEWS = (("single-player-broadcast", "eval00"), ("single-player-closeup", "eval00"),
                    ("players-stadium", "eval00"))
VALIDATION_SEED = 0
VALIDATION_FRAMES = 12
"""Consecutive frames 0..11 of each validation view."""
TOUCHED = (3, 7)
"""Frames whose ball is erased or ghosted (chosen among frames showing a ball)."""
CONDITIONS = ("erased", "ghost30", "ghost60", "ghost90")


# ------------------------------------------------------------------------------ rendering


@dataclass
class Frame:
    gt: np.ndarray
    """(H, W, 3) float32 in [0, 1], 4 samples per pixel."""
    boxes: list[dict]
    """Generator records ``{class, id, box, visible}``."""
    hidden: dict[str, np.ndarray]
    """Class -> the view rendered without that class."""
    spp1: np.ndarray | None = None
    """The view at 1 sample per pixel."""


def render_frames(preset: str, camera: str, seed: int, frames, *, hide=("ball", "person"),
                  spp1: bool = False, size: str = "small") -> list[Frame]:
    """Render the views of one camera with, and without each class of ``hide``."""
    from reference_models.scenes import CameraRenderer, build_scene

    scene = build_scene(preset, seed=seed, size=size)
    cam = scene.camera(camera)
    full = CameraRenderer(cam, scene.sun, scene.seed, scene.spp)
    low = CameraRenderer(cam, scene.sun, scene.seed, 1) if spp1 else None
    out = []
    for f in frames:
        view = full.render(scene.bodies(f), None)
        hidden = {c: full.render(scene.bodies(f, (c,)), None).rgb for c in hide}
        out.append(Frame(view.rgb, view.boxes, hidden,
                         low.render(scene.bodies(f), None).rgb if low else None))
    return out


# ------------------------------------------------------------------------------ degradations


def blur(img: np.ndarray, sigma: float) -> np.ndarray:
    import cv2

    return cv2.GaussianBlur(img, (0, 0), sigma)


def jpeg(img: np.ndarray, quality: int) -> np.ndarray:
    import cv2

    ok, buf = cv2.imencode(".jpg", np.round(img[..., ::-1] * 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].astype(np.float32) / 255


def noise(img: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0.0, sigma, img.shape), 0, 1).astype(np.float32)


def shift(img: np.ndarray, dx: int) -> np.ndarray:
    """The frame moved ``dx`` px to the right (the left column repeated)."""
    out = np.empty_like(img)
    out[:, dx:] = img[:, :-dx]
    out[:, :dx] = img[:, :1]
    return out


def ghost(shown: np.ndarray, erased: np.ndarray, opacity: float) -> np.ndarray:
    """The object blended in at ``opacity`` over what is behind it."""
    return (opacity * shown + (1.0 - opacity) * erased).astype(np.float32)


def good_method(img: np.ndarray, seed: int) -> np.ndarray:
    """A prediction of a good method: blur sigma 0.7 px, noise sigma 0.01, 8-bit."""
    return np.round(noise(blur(img, 0.7), 0.01, seed) * 255) / 255


# ------------------------------------------------------------------------------ calibration


def calibration_rows(views=CALIBRATION_VIEWS, seed: int = CALIBRATION_SEED,
                     frames=CALIBRATION_FRAMES, config: PresenceConfig | None = None,
                     size: str = "small") -> list[dict]:
    """Per object and prediction kind: ``{view, frame, class, id, kind, ncc, psnr}``."""
    cfg = config or PresenceConfig()
    rows = []
    for v, (preset, camera) in enumerate(views):
        for f, fr in zip(frames, render_frames(preset, camera, seed, frames, spp1=True, size=size),
                         strict=True):
            k = 1000 * v + f
            preds: dict[str, Callable[[str], np.ndarray]] = {
                "blur1": lambda c, g=fr.gt: blur(g, 1.0),
                "blur2": lambda c, g=fr.gt: blur(g, 2.0),
                "jpeg30": lambda c, g=fr.gt: jpeg(g, 30),
                "noise3": lambda c, g=fr.gt, k=k: noise(g, 0.03, k),
                "spp1": lambda c, fr=fr: fr.spp1,
                "shift1": lambda c, g=fr.gt: shift(g, 1),
                "erased": lambda c, fr=fr: fr.hidden[c],
                **{f"ghost{int(a * 100)}": (lambda c, fr=fr, a=a: ghost(fr.gt, fr.hidden[c], a))
                   for a in (0.3, 0.6, 0.9)},
            }
            cache: dict[tuple[str, str], np.ndarray] = {}
            h, w = fr.gt.shape[:2]
            for obj in fr.boxes:
                if obj.get("visible", 1.0) < cfg.min_visible:
                    continue  # mostly occluded: skipped by the library too
                box = tight_box(obj["box"], h, w, cfg.margin)
                inner = np.asarray(obj["box"])
                for kind, make in preds.items():
                    key = (kind, obj["class"])
                    if key not in cache:
                        cache[key] = make(obj["class"])
                    ncc, psnr = crop_similarity(cache[key], fr.gt, box, shift=cfg.shift,
                                                data_range=cfg.data_range)
                    vis = visibility(cache[key], fr.gt, box, inner, data_range=cfg.data_range)
                    rows.append({"view": f"{preset}/{camera}", "frame": f, "class": obj["class"],
                                 "id": obj["id"], "kind": kind, "ncc": ncc, "psnr": psnr,
                                 "visibility": vis})
    return rows


def _visible(rows: list[dict], visibility_min: float) -> np.ndarray:
    return np.array([r["visibility"] is None or r["visibility"] >= visibility_min for r in rows])


def model_rows(scene: Path, runs: dict[str, Path], camera: str = "eval00",
               config: PresenceConfig | None = None) -> list[dict]:
    """Per object of ``camera``'s frames in the generator folder ``scene`` (its ``images/`` and
    ``boxes.json``), for each model run's renders (``name -> pred folder``, ``pred/<camera>/
    NNNN.png``): rows like ``calibration_rows``' with ``kind`` ``model:<name>``."""
    from dynaeval.io.images import read_image

    cfg = config or PresenceConfig()
    boxes = json.loads((scene / "boxes.json").read_text())
    rows = []
    for gt_path in sorted((scene / "images" / camera).glob("*.png")):
        gt = read_image(gt_path)
        h, w = gt.shape[:2]
        key = f"{camera}/{gt_path.stem}"
        for name, pred_dir in runs.items():
            pred = read_image(pred_dir / camera / gt_path.name)
            for obj in boxes.get(key, []):
                if obj.get("visible", 1.0) < cfg.min_visible:
                    continue
                box = tight_box(obj["box"], h, w, cfg.margin)
                ncc, psnr = crop_similarity(pred, gt, box, shift=cfg.shift, data_range=cfg.data_range)
                vis = visibility(pred, gt, box, np.asarray(obj["box"]), data_range=cfg.data_range)
                rows.append({"view": f"{scene.name}/{camera}", "frame": int(gt_path.stem),
                             "class": obj["class"], "id": obj["id"], "kind": f"model:{name}",
                             "ncc": ncc, "psnr": psnr, "visibility": vis})
    return rows


def choose_thresholds(rows: list[dict], cls: str, visibility_min: float = 0.5,
                      present_kinds: tuple[str, ...] = PRESENT_KINDS) -> dict:
    """Thresholds of one class from calibration rows (rule in the module docstring); objects
    below ``visibility_min`` count as flagged whatever the thresholds; ``present_kinds``: the
    kinds of the positive set."""
    pos = [r for r in rows if r["class"] == cls and r["kind"] in present_kinds]
    neg = [r for r in rows if r["class"] == cls and r["kind"] == "erased"]
    if not pos or not neg:
        raise ValueError(f"no calibration objects of class {cls!r}")

    def ncc(r):
        return 1.0 if r["ncc"] is None else r["ncc"]  # undefined ncc passes (as in the library)

    def arr(rs):
        return np.array([ncc(r) for r in rs]), np.array([r["psnr"] for r in rs])

    pn, pp = arr(pos)
    nn, npsnr = arr(neg)
    pv, nv = _visible(pos, visibility_min), _visible(neg, visibility_min)
    ts = np.round(np.arange(0.0, 1.0001, 0.01), 2)
    ss = np.round(np.arange(5.0, 40.0001, 0.5), 1)
    err = np.empty((len(ss), len(ts)))
    for i, s in enumerate(ss):
        for j, t in enumerate(ts):
            miss = np.mean((pn < t) | (pp < s) | ~pv)
            false = np.mean((nn >= t) & (npsnr >= s) & nv)
            err[i, j] = miss + false
    best = err.min()
    i = int(np.nonzero((err == best).any(axis=1))[0][0])  # lowest psnr_min reaching the best
    run = _widest_run(err[i] == best)
    t = float(np.round(ts[run].mean(), 2))
    j = int(np.argmin(np.abs(ts - t)))
    srun = _widest_run(err[:, j] == best)
    s = float(np.round(ss[srun].mean() * 2) / 2)
    miss = float(np.mean((pn < t) | (pp < s) | ~pv))
    false = float(np.mean((nn >= t) & (npsnr >= s) & nv))
    return {"class": cls, "ncc_min": t, "psnr_min": s, "n_present": len(pos), "n_erased": len(neg),
            "missed": miss, "false": false}


def _widest_run(ok: np.ndarray) -> np.ndarray:
    """Indices of the longest run of True (the first one on ties)."""
    best, start = (0, 0), None
    for k, v in enumerate([*ok, False]):
        if v and start is None:
            start = k
        elif not v and start is not None:
            if k - start > best[1] - best[0]:
                best = (start, k)
            start = None
    return np.arange(best[0], best[1])


def calibration_tables(rows: list[dict], chosen: list[dict], visibility_min: float = 0.5,
                       present_kinds: tuple[str, ...] = PRESENT_KINDS,
                       context_kinds: tuple[str, ...] = REPORTED_KINDS) -> str:
    th = {c["class"]: c for c in chosen}
    out = ["| class | prediction | objects | ncc min / median / max | psnr dB min / median / max | "
           "visibility 5 % / median / 95 % | present (calibrated) |",
           "|---|---|---|---|---|---|---|"]
    for cls in th:
        for kind in (*present_kinds, "erased", *context_kinds):
            rs = [r for r in rows if r["class"] == cls and r["kind"] == kind]
            n = np.array([1.0 if r["ncc"] is None else r["ncc"] for r in rs])
            p = np.array([r["psnr"] for r in rs])
            v = np.array([r["visibility"] for r in rs if r["visibility"] is not None])
            ok = np.mean((n >= th[cls]["ncc_min"]) & (p >= th[cls]["psnr_min"])
                         & _visible(rs, visibility_min))
            vq = np.percentile(v, [5, 50, 95]) if len(v) else [np.nan] * 3
            if not rs:
                continue
            role = "shown" if kind in present_kinds else ("erased" if kind == "erased" else "context")
            out.append(f"| {cls} | {kind} ({role}) | {len(rs)} | {n.min():.2f} / {np.median(n):.2f} / "
                       f"{n.max():.2f} | {p.min():.1f} / {np.median(p):.1f} / {p.max():.1f} | "
                       f"{vq[0]:.2f} / {vq[1]:.2f} / {vq[2]:.2f} | {100 * ok:.0f} % |")
    out += ["", "| class | ncc_min | psnr_min (dB) | objects shown / erased | shown but missed | "
            "erased but passed |", "|---|---|---|---|---|---|"]
    for c in chosen:
        out.append(f"| {c['class']} | {c['ncc_min']:.2f} | {c['psnr_min']:.1f} | {c['n_present']} / "
                   f"{c['n_erased']} | {100 * c['missed']:.1f} % | {100 * c['false']:.1f} % |")
    return "\n".join(out)


# ------------------------------------------------------------------------------ validation


def _write(root: Path, camera: str, frames: list[np.ndarray]) -> None:
    import cv2

    (root / camera).mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames):
        rgb8 = np.round(np.clip(f, 0, 1) * 255).astype(np.uint8)
        cv2.imwrite(str(root / camera / f"{i:04d}.png"), np.ascontiguousarray(rgb8[..., ::-1]))


def validation_rows(views=VALIDATION_VIEWS, seed: int = VALIDATION_SEED,
                    n_frames: int = VALIDATION_FRAMES, touched=TOUCHED, size: str = "small",
                    conditions=CONDITIONS) -> list[dict]:
    """Score the good-method prediction and each condition; one row per view and condition."""
    import dynaeval
    from dynaeval.regions.focus import FocusConfig

    rows = []
    for preset, camera in views:
        frames = render_frames(preset, camera, seed, range(n_frames), hide=("ball",), size=size)
        missing = [t for t in touched if not any(o["class"] == "ball" for o in frames[t].boxes)]
        if missing:
            raise ValueError(f"{preset}/{camera}: no ball on frames {missing}; choose others")
        base = [good_method(fr.gt, 100 + i) for i, fr in enumerate(frames)]
        erased = [good_method(fr.hidden["ball"], 100 + i) for i, fr in enumerate(frames)]
        preds = {"none": base}
        for cond in conditions:
            seq = list(base)
            for t in touched:
                seq[t] = erased[t] if cond == "erased" else ghost(base[t], erased[t],
                                                                  int(cond[5:]) / 100)
            preds[cond] = seq
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            _write(root / "gt", camera, [fr.gt for fr in frames])
            boxes = {f"{camera}/{i:04d}": fr.boxes for i, fr in enumerate(frames)}
            (root / "boxes.json").write_text(json.dumps(boxes))
            results = {}
            for cond, seq in preds.items():
                _write(root / cond, camera, seq)
                results[cond] = dynaeval.score(
                    root / cond, root / "gt", metrics=("psnr", "ssim"), temporal=False, progress=False,
                    focus=FocusConfig(source="boxes", boxes_file=str(root / "boxes.json"),
                                      masked=False))
        ref = results["none"]["frames"]
        for cond, res in results.items():
            fr_rows = res["frames"]
            ball = [r["presence_ball"] for r in fr_rows]
            person = [r["presence_person"] for r in fr_rows]
            flagged = [i for i, v in enumerate(ball) if v is not None and v < 1.0]
            pflag = [i for i, v in enumerate(person) if v is not None and v < 1.0]
            t = list(touched)

            def delta(name, got=fr_rows, ref=ref, t=t):
                return float(np.mean([got[i][name] - ref[i][name] for i in t]))

            rows.append({
                "view": f"{preset}/{camera}", "condition": cond, "flagged": flagged,
                "person_flagged": pflag,
                "ball_touched": float(np.mean([ball[i] for i in t])),
                "ball_untouched": float(np.mean([v for i, v in enumerate(ball)
                                                 if i not in t and v is not None])),
                "d_psnr": delta("psnr"), "d_focused_psnr": delta("focused_psnr"),
                "d_tight_psnr_ball": delta("tight_psnr_ball"),
                "ncc_ball": _mean_of(fr_rows, t, "ncc"),
                "visibility_ball": _mean_of(fr_rows, t, "visibility"),
            })
    return rows


def _mean_of(frame_rows: list[dict], frames: list[int], key: str) -> float:
    """Mean of an object field over the balls of some frames (undefined values left out)."""
    vals = [o[key] for i in frames for o in frame_rows[i]["objects"]
            if o["class"] == "ball" and o[key] is not None]
    return float(np.mean(vals)) if vals else float("nan")


def validation_table(rows: list[dict]) -> str:
    out = [f"| view | prediction (frames {', '.join(map(str, TOUCHED))} changed) | frames with "
           "presence_ball < 1 | presence_ball changed / untouched frames | ball ncc / visibility "
           "(changed) | Δ psnr | Δ focused_psnr | Δ tight_psnr_ball | frames with "
           "presence_person < 1 |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(
            f"| {r['view']} | {r['condition']} | {r['flagged'] or '–'} | {r['ball_touched']:.2f} / "
            f"{r['ball_untouched']:.2f} | {r['ncc_ball']:.2f} / {r['visibility_ball']:.2f} | "
            f"{r['d_psnr']:+.3f} | "
            f"{r['d_focused_psnr']:+.2f} | {r['d_tight_psnr_ball']:+.2f} | "
            f"{r['person_flagged'] or '–'} |")
    return "\n".join(out)


MODELS_BEGIN, MODELS_END = "<!-- BEGIN presence_models -->", "<!-- END presence_models -->"


def _named_dirs(items: list[str]) -> dict[str, Path]:
    """``NAME=DIR`` arguments as ``{name: Path(dir)}``."""
    out = {}
    for item in items:
        name, sep, folder = item.partition("=")
        if not sep or not name or not Path(folder).is_dir():
            raise SystemExit(f"error: expected NAME=PRED_DIR with an existing folder, got {item!r}")
        out[name] = Path(folder)
    return out


def models_calibration(scene: Path, positive: dict[str, Path], context: dict[str, Path],
                       cfg: PresenceConfig) -> str:
    """Markdown: the person thresholds chosen again with the players of model renders that keep
    them (``positive``) added to the shown set; ``context`` runs reported, not used."""
    cal = calibration_rows(config=cfg)
    rows = cal + model_rows(scene, {**positive, **context}, config=cfg)
    pos_kinds = (*PRESENT_KINDS, *(f"model:{n}" for n in positive))
    ctx_kinds = (*REPORTED_KINDS, *(f"model:{n}" for n in context))
    chosen = [choose_thresholds(rows, "person", cfg.visibility_min, pos_kinds)]
    lib = cfg.thresholds["person"]
    same = (lib.ncc_min, lib.psnr_min) == (chosen[0]["ncc_min"], chosen[0]["psnr_min"])
    return "\n".join([
        f"Person thresholds chosen again (the rule above) with the players of "
        f"{', '.join(positive)} ({scene.name}/eval00, every frame) added to the shown set; "
        f"{', '.join(context) or 'none'} reported for context.", "",
        calibration_tables(rows, chosen, cfg.visibility_min, pos_kinds, ctx_kinds), "",
        f"Library thresholds (person ncc_min {lib.ncc_min:.2f}, psnr_min {lib.psnr_min:.1f} dB): "
        + ("the same as this calibration." if same else "**differ from this calibration.**"),
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"replace the study block in docs/{DOC}")
    parser.add_argument("--models-scene", type=Path, metavar="SCENE",
                        help="generator folder the model runs were trained on: calibrate "
                             "presence_person again with their renders (--positive) instead")
    parser.add_argument("--positive", nargs="+", default=[], metavar="NAME=PRED",
                        help="runs that keep the player (their pred/ folders): shown set")
    parser.add_argument("--context", nargs="+", default=[], metavar="NAME=PRED",
                        help="runs reported for context only")
    args = parser.parse_args()
    cfg = PresenceConfig()
    if args.models_scene is not None:
        md = models_calibration(args.models_scene, _named_dirs(args.positive),
                                _named_dirs(args.context), cfg)
        print(md)
        if args.write:
            replace_block(docs_dir() / DOC, MODELS_BEGIN, MODELS_END, md)
        return
    cal = calibration_rows(config=cfg)
    chosen = [choose_thresholds(cal, c, cfg.visibility_min) for c in ("person", "ball")]
    lib = {c: (t.ncc_min, t.psnr_min) for c, t in cfg.thresholds.items()}
    text = [
        f"Calibration: seed {CALIBRATION_SEED}, size small (320 x 180), views "
        f"{', '.join(p + '/' + c for p, c in CALIBRATION_VIEWS)}, frames "
        f"{list(CALIBRATION_FRAMES)}; margin {cfg.margin} px, shift {cfg.shift} px.", "",
        calibration_tables(cal, chosen, cfg.visibility_min), "",
        "Thresholds in the library (`CALIBRATED_THRESHOLDS`): "
        + ", ".join(f"{c} ncc_min {t[0]:.2f}, psnr_min {t[1]:.1f} dB" for c, t in lib.items())
        + ("" if all(lib[c["class"]] == (c["ncc_min"], c["psnr_min"]) for c in chosen)
           else " — **differ from this calibration: update them**") + ".", "",
        f"Validation: seed {VALIDATION_SEED}, size small, frames 0–{VALIDATION_FRAMES - 1} of "
        f"{', '.join(p + '/' + c for p, c in VALIDATION_VIEWS)}; Δ = mean over the changed frames "
        "of (condition − unchanged good-method prediction).", "",
        validation_table(validation_rows()),
    ]
    md = "\n".join(text)
    print(md)
    if args.write:
        replace_block(docs_dir() / DOC, BEGIN, END, md)


if __name__ == "__main__":
    main()

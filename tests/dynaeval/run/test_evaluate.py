"""The orchestration: numbers equal the pure functions, regions, temporal terms, invariances."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import dynaeval
from dynaeval import metrics as M
from dynaeval.errors import InputError
from dynaeval.regions import write_boxes_file
from dynaeval.regions.focus import FocusConfig
from dynaeval.report import schema_path
from dynaeval.run.evaluate import ScoreConfig
from dynaeval.run.prepare import prepare

from ..helpers import moving_square_scene, write_frames


@pytest.fixture
def scene(tmp_path):
    gt, frames = moving_square_scene(tmp_path / "gt")
    rng = np.random.default_rng(1)
    pred = {
        cam: [np.clip(f.astype(int) + rng.integers(-12, 13, f.shape), 0, 255).astype(np.uint8)
              for f in seq]
        for cam, seq in frames.items()
    }
    for cam, seq in pred.items():
        write_frames(tmp_path / "pred", cam, seq)
    return tmp_path / "pred", gt, frames, pred


def _frame_values(results, name):
    return [f[name] for f in results["frames"]]


def test_whole_frame_values_equal_pure_functions(scene):
    pred_dir, gt_dir, gt, pred = scene
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, progress=False)
    f32 = lambda x: x.astype(np.float32) / np.float32(255)  # noqa: E731 - as the reader does
    expected = [M.psnr(f32(p), f32(g)) for c in gt for p, g in zip(pred[c], gt[c], strict=True)]
    np.testing.assert_allclose(_frame_values(res, "psnr"), expected, rtol=0, atol=1e-12)
    assert res["summary"]["psnr"] == pytest.approx(np.mean(expected), abs=1e-9)
    assert res["summary"]["n_frames"] == 8 and list(res["cameras"]) == ["cam00", "cam01"]
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(json.loads(json.dumps(res)), json.loads(schema_path().read_text()))


def test_summary_is_mean_of_frames_not_pooled_error(scene):
    pred_dir, gt_dir, gt, pred = scene
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, progress=False)
    stats = [M.squared_error_stats(p / 255, g / 255) for c in gt
             for p, g in zip(pred[c], gt[c], strict=True)]
    pooled = 10 * math.log10(1 / (sum(s.sse for s in stats) / sum(s.count for s in stats)))
    assert res["summary"]["psnr"] != pytest.approx(pooled, abs=1e-6)


def test_workers_do_not_change_numbers(scene, random_lpips):
    pred_dir, gt_dir, _, _ = scene
    focus = FocusConfig(source="motion")
    one = dynaeval.score(pred_dir, gt_dir, workers=1, focus=focus, progress=False)
    two = dynaeval.score(pred_dir, gt_dir, workers=2, focus=focus, progress=False)
    assert one["settings"]["lpips"]["enabled"]
    assert one["frames"] == two["frames"]
    assert one["summary"] == two["summary"]


def test_ground_truth_against_itself_is_ideal(scene, random_lpips):
    _, gt_dir, _, _ = scene
    res = dynaeval.score(gt_dir, gt_dir, focus=FocusConfig(source="motion"), progress=False)
    s = res["summary"]
    assert s["psnr"] is None  # +inf is written as null with a reason
    assert any("infinite" in w["reason"] for w in res["warnings"])
    for name in ("ssim", "focused_ssim", "masked_ssim"):
        assert s[name] == pytest.approx(1.0, abs=1e-12)
    for name in ("lpips", "warp_error", "tof", "tlp", "focused_lpips"):
        assert s[name] == pytest.approx(0.0, abs=1e-7), name
    json.dumps(res, allow_nan=False)


def test_focused_metrics_ignore_changes_outside_boxes(tmp_path, scene):
    _, gt_dir, gt, _ = scene
    boxes = {}
    pred_root = tmp_path / "outside"
    for cam, seq in gt.items():
        changed = []
        for t, f in enumerate(seq):
            box = [8 + 4 * t, 20, 18 + 4 * t, 30]
            boxes[f"{cam}/{t:04d}"] = [{"class": "person", "id": 1, "box": box, "visible": 1.0}]
            g = f.copy()
            g[:, 40:] = 255 - g[:, 40:]  # change the stadium, far right of the square
            changed.append(g)
        write_frames(pred_root, cam, changed)
    write_boxes_file(tmp_path / "boxes.json", boxes)
    focus = FocusConfig(source="boxes", boxes_file=str(tmp_path / "boxes.json"), expand="none",
                        masked=False)
    res = dynaeval.score(pred_root, gt_dir, metrics=("psnr", "ssim"), temporal=False, focus=focus,
                         progress=False)
    assert res["summary"]["focused_ssim"] == pytest.approx(1.0, abs=1e-12)
    assert res["summary"]["focused_psnr"] is None  # perfect in the boxes: +inf -> null
    assert res["summary"]["psnr"] < 15


def test_frame_missing_from_boxes_file_is_null_with_reason(tmp_path, scene):
    pred_dir, gt_dir, _, _ = scene
    write_boxes_file(tmp_path / "b.json", {"cam00/0000": [{"class": "ball", "id": 1,
                                                          "box": [0, 0, 20, 20], "visible": 1.0}]})
    focus = FocusConfig(source="boxes", boxes_file=str(tmp_path / "b.json"), masked=False)
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, focus=focus,
                         progress=False)
    vals = _frame_values(res, "focused_psnr")
    assert vals[0] is not None and vals[1:] == [None] * 7
    assert res["counts"]["focused_psnr"] == 1
    assert any("not in the boxes file" in w["reason"] for w in res["warnings"])


def test_temporal_terms_grow_with_flicker(tmp_path, scene):
    _, gt_dir, gt, _ = scene
    vals = []
    for amp in (0, 10, 30):
        root = tmp_path / f"flicker{amp}"
        for cam, seq in gt.items():
            write_frames(root, cam, [np.clip(f.astype(int) + (amp if t % 2 else -amp), 0, 255)
                                     .astype(np.uint8) for t, f in enumerate(seq)])
        res = dynaeval.score(root, gt_dir, metrics=("psnr", "ssim"), focus=FocusConfig(source="motion"),
                             progress=False)
        vals.append((res["summary"]["warp_error"], res["summary"]["flicker"]))
    assert vals[0][0] < vals[1][0] < vals[2][0]
    assert vals[0][1] < vals[1][1] < vals[2][1]


@pytest.mark.parametrize("prepared", [False, True])
def test_a_static_camera_where_nothing_moves_has_flicker_over_the_whole_frame(tmp_path, prepared):
    """Six identical ground-truth frames (a static camera, nothing moves: every motion mask
    empty) against a prediction whose brightness flickers by +-0.05: flicker is a value over the
    whole frame, not null for a "missing" static mask (issue 43); a steady prediction scores 0."""
    rng = np.random.default_rng(0)
    still = rng.integers(40, 200, (48, 64, 3), dtype=np.uint8)
    write_frames(tmp_path / "gt", "cam00", [still] * 6)
    write_frames(tmp_path / "steady", "cam00", [still] * 6)
    write_frames(tmp_path / "flicker", "cam00", [np.clip(still.astype(int) + (13 if t % 2 else -13),
                                                         0, 255).astype(np.uint8) for t in range(6)])
    gt = tmp_path / "gt"
    kwargs = {"metrics": ("psnr", "ssim"), "focus": FocusConfig(source="motion"), "progress": False}
    if prepared:
        prepare(gt, tmp_path / "prep", config=ScoreConfig(**kwargs))
        kwargs["prepared"] = tmp_path / "prep"
    flicker = dynaeval.score(tmp_path / "flicker", gt, **kwargs)
    steady = dynaeval.score(tmp_path / "steady", gt, **kwargs)
    assert flicker["regions"]["cameras"]["cam00"]["global_motion_px"] == 0.0
    assert flicker["summary"]["flicker"] > 0.02 and steady["summary"]["flicker"] == 0.0
    assert flicker["summary"]["masked_psnr"] is None  # no moving pixel: the masked terms stay null


def test_size_mismatch_names_both_files(tmp_path, scene):
    _, gt_dir, gt, _ = scene
    write_frames(tmp_path / "p", "cam00", [f[:40] for f in gt["cam00"]])
    with pytest.raises(InputError, match=r"0000\.png: prediction is 64x40 px but its ground truth"):
        dynaeval.score(tmp_path / "p", gt_dir, metrics=("psnr", "ssim"), progress=False)


def test_channel_mismatch(tmp_path, scene):
    _, gt_dir, gt, _ = scene
    import cv2

    (tmp_path / "p" / "cam00").mkdir(parents=True)
    for i, f in enumerate(gt["cam00"]):
        cv2.imwrite(str(tmp_path / "p" / "cam00" / f"{i:04d}.png"), f[..., 0])
    with pytest.raises(InputError, match="prediction has 1 channel"):
        dynaeval.score(tmp_path / "p", gt_dir, metrics=("psnr", "ssim"), progress=False)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("quantize", "ceil", "quantize must be one of none, round, truncate, got 'ceil'"),
    ("workers", 0, "workers must be an integer >= 1, got 0"),
    ("workers", 1.5, "workers must be an integer >= 1"),
    ("cache_mb", -1, "cache_mb must be an integer >= 0"),
    ("background", "grey", "background must be one of white, black"),
    ("lpips_backend", "tf", "lpips_backend must be one of torch, onnxruntime"),
    ("lpips_net", "squeeze", "lpips_net must be one of alex, vgg"),
    ("device", "tpu", "device must be cpu, cuda, cuda:N or auto"),
    ("flow", "raft", "flow method must be one of"),
    ("protocol", "nerf", "protocol must be one of dynaeval, nerfbaselines, nerfstudio"),
    ("metrics", ("psnr", "fid"), r"unknown metric\(s\) \['fid'\]"),
    ("metrics", "psnr", "metrics must be a sequence of metric names"),
    ("shard", (3, 2), "needs 1 <= I <= N"),
    ("focus", "moving", r"focus must be detector, motion, none or boxes:FILE, got 'moving' "
                        r"\(did you mean 'motion'\?\); "
                        r"or a FocusConfig \(dynaeval.regions.focus\) to set expand"),
    ("focus", "boxes:", "focus boxes:FILE needs a file name after 'boxes:'"),
    ("focus", None, "focus must be a FocusConfig or one of the CLI's strings detector, motion, "
                    "none, boxes:FILE, got None \\(NoneType\\)"),
    ("frames_are_video", "yes", "frames_are_video must be True, False or None"),
    ("metric_options", {"ssim": {"window": 7}}, "metric 'ssim' has no options"),
    ("metric_options", {"flip": {"observer": 1}}, "flip has no option 'observer'"),
    ("metric_options", {"flip": {"pixels_per_degree": "many"}}, "must be a number, got 'many'"),
])
def test_bad_settings_are_refused_before_any_frame_is_read(tmp_path, field, value, message):
    with pytest.raises(InputError, match=message):
        dynaeval.score(tmp_path / "missing", tmp_path / "missing", **{field: value})
    with pytest.raises(InputError, match=message):
        ScoreConfig(**{field: value})


def test_protocol_conflicts_are_refused_in_the_config():
    with pytest.raises(InputError, match="protocol nerfbaselines uses quantize=truncate, not round"):
        ScoreConfig(protocol="nerfbaselines", quantize="round")
    with pytest.raises(InputError, match="reports LPIPS with the alex backbone, not vgg"):
        ScoreConfig(protocol="nerfstudio", lpips_net="vgg")
    assert ScoreConfig(protocol="nerfbaselines").resolved_quantize() == "truncate"
    assert ScoreConfig(shard="2/3").shard == (2, 3)


def test_quantize_recorded_and_applied(scene):
    pred_dir, gt_dir, _, _ = scene
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, quantize="truncate",
                         progress=False)
    assert res["settings"]["quantize"] == "truncate"


def test_dataframe_accessor(scene):
    pred_dir, gt_dir, _, _ = scene
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False, progress=False)
    df = res.to_dataframe()
    assert len(df) == 8 and {"camera", "frame", "psnr", "ssim"} <= set(df.columns)
    assert list(res.to_dataframe("cameras").index) == ["cam00", "cam01"]


def test_metrics_selects_the_per_frame_metrics(scene):
    pred_dir, gt_dir, _, _ = scene
    focus = FocusConfig(source="none", masked=False)
    res = dynaeval.score(pred_dir, gt_dir, ScoreConfig(metrics=("psnr", "ssim"), temporal=False,
                                                       progress=False, focus=focus))
    assert set(res["metrics"]) == {"psnr", "ssim"}
    res = dynaeval.score(pred_dir, gt_dir, ScoreConfig(metrics=("ssim",), temporal=False,
                                                       progress=False, focus=focus))
    assert set(res["metrics"]) == {"ssim"}


def test_default_config_is_the_cli_default():
    """The library's defaults are the command's: detector boxes, motion masks, presence,
    temporal terms, PSNR/SSIM/LPIPS (docs/architecture.md)."""
    from dynaeval.cli import build_parser, config_from_args

    args = build_parser().parse_args(["score", "p", "g"])
    assert config_from_args(args) == ScoreConfig()
    d = ScoreConfig()
    assert d.focus.source == "detector" and d.focus.masked and d.presence and d.temporal
    assert d.metrics == ("psnr", "ssim", "lpips")


def test_temporal_pass_on_the_pool_keeps_numbers_and_order(tmp_path):
    """With workers > 1, 2 or 3 of the 3 cameras are scored at once and each camera's frame
    pairs run on the shared pool (up to 2 x workers in flight, more than the 3 pairs of a
    camera): numbers and camera order unchanged."""
    cams = ("cam0", "cam1", "cam2")
    gt, frames = moving_square_scene(tmp_path / "gt", cameras=cams)
    rng = np.random.default_rng(5)
    for cam, seq in frames.items():
        write_frames(tmp_path / "pred", cam, [
            np.clip(f.astype(int) + rng.integers(-9, 10, f.shape), 0, 255).astype(np.uint8) for f in seq])
    kw = {"metrics": ("psnr", "ssim"), "focus": FocusConfig(source="motion"), "progress": False}
    runs = [json.loads(json.dumps(dict(dynaeval.score(tmp_path / "pred", gt, workers=w, **kw))))
            for w in (1, 2, 3)]
    assert list(runs[0]["cameras"]) == list(cams)
    assert runs[0]["summary"]["warp_error"] is not None
    for other in runs[1:]:
        for key in ("frames", "cameras", "summary"):
            assert other[key] == runs[0][key], key
        assert list(other["cameras"]) == list(cams)


def test_onnxruntime_lpips_backend_gives_the_same_numbers(scene, random_lpips, monkeypatch):
    pytest.importorskip("onnxruntime")
    load_onnx = M.load_lpips_onnx
    monkeypatch.setattr(M, "load_lpips_onnx",
                        lambda net, **kw: load_onnx(net, pretrained_backbone=False, **kw))
    pred_dir, gt_dir, _, _ = scene
    kw = {"temporal": False, "focus": FocusConfig(source="motion"), "progress": False}
    torch_run = dynaeval.score(pred_dir, gt_dir, **kw)
    onnx_run = dynaeval.score(pred_dir, gt_dir, lpips_backend="onnxruntime", **kw)
    assert onnx_run["settings"]["lpips"]["backend"] == "onnxruntime"
    for name in ("lpips", "focused_lpips", "masked_lpips"):
        np.testing.assert_allclose([f[name] for f in onnx_run["frames"]],
                                   [f[name] for f in torch_run["frames"]], rtol=0, atol=1e-6)
    with pytest.raises(InputError, match="lpips_backend must be one of torch, onnxruntime"):
        dynaeval.score(pred_dir, gt_dir, lpips_backend="tensorrt", **kw)


def test_focused_metrics_drop_when_only_the_inside_changes(tmp_path, scene):
    _, gt_dir, gt, _ = scene
    boxes = {}
    for cam, seq in gt.items():
        changed = []
        for t, f in enumerate(seq):
            boxes[f"{cam}/{t:04d}"] = [{"class": "person", "id": 1,
                                         "box": [8 + 4 * t, 20, 18 + 4 * t, 30], "visible": 1.0}]
            g = f.copy()
            g[20:30, 8 + 4 * t: 18 + 4 * t] = 0  # the moving square goes black
            changed.append(g)
        write_frames(tmp_path / "inside", cam, changed)
    write_boxes_file(tmp_path / "boxes.json", boxes)
    focus = FocusConfig(source="boxes", boxes_file=str(tmp_path / "boxes.json"), expand="none",
                        masked=False)
    res = dynaeval.score(tmp_path / "inside", gt_dir, metrics=("psnr", "ssim"), temporal=False, focus=focus,
                         progress=False)
    s = res["summary"]
    assert s["focused_psnr"] < s["psnr"] - 10  # the box is ~3 % of the frame: 10 log10(1/0.03)
    assert s["focused_ssim"] < s["ssim"]
    assert s["presence_person"] == 0.0  # and the object check says it is gone


def test_detector_regions_on_the_pool_equal_the_sequential_ones():
    """With workers > 1 the shipped detector runs over a camera's frames on the pool; the boxes,
    records and numbers are those of one worker."""
    from importlib.resources import files

    sample = files("dynaeval") / "data" / "sample"
    kw = {"metrics": ("psnr", "ssim"), "temporal": False, "presence": False, "progress": False,
          "focus": FocusConfig(source="detector")}
    runs = [json.loads(json.dumps(dict(dynaeval.score(sample / "pred", sample / "gt", workers=w, **kw))))
            for w in (1, 2)]
    assert runs[0]["frames"] == runs[1]["frames"] and runs[0]["summary"] == runs[1]["summary"]
    assert runs[0]["summary"]["focused_psnr"] is not None  # the detector found the player


def test_every_key_of_a_full_run_is_registered_and_documented(random_lpips):
    """The sample scored with everything on (boxes with classes: presence; motion masks;
    temporal terms; LPIPS on a random backbone): every metric key in the results is in the
    registry and in docs/metrics.md, and every registered key is written."""
    from pathlib import Path

    from dynaeval.cli import sample_dir
    from dynaeval.metrics.registry import METRICS, SPECS, keys_of, selectable_specs

    root = sample_dir()
    every = tuple(s.name for s in selectable_specs())  # those off by default too (flip, jod)
    res = dynaeval.score(root / "pred", root / "gt", progress=False, metrics=every,
                         focus=FocusConfig(source="boxes", boxes_file=str(root / "boxes.json")))
    keys = set(res["metrics"]) | set(res["summary"]) - {"n_frames"}
    keys |= {k for row in res["frames"] for k in row} - {"camera", "frame", "index", "pred", "gt",
                                                          "objects"}
    # a metric whose extra is not installed here is reported unavailable, with its reason
    unavailable = {w["metric"] for w in res["warnings"] if "not computed" in w["reason"]}
    assert unavailable <= {s.name for s in SPECS.values() if s.extra not in (None, "lpips")}
    expected = set(METRICS) - {k for n in unavailable for k in SPECS[n].keys()}
    expected -= set(keys_of("frame", region="covisible"))  # DyCheck's m*: --protocol dycheck only
    assert keys == expected, (keys ^ expected)
    doc = (Path(__file__).resolve().parents[3] / "docs" / "metrics.md").read_text()
    undocumented = [k for k in keys if f"`{k}`" not in doc]
    assert not undocumented, f"not in docs/metrics.md: {undocumented}"
    assert res["settings"]["lpips"]["enabled"] and res["summary"]["tlp"] is not None


# ------------------------------------------------------------------------------------------
# issue 17 item 3: the bundled detector says what it is; every run says what regions it found


def _photo_sequence(root, name="chelsea", n=3, noise=3):
    """A real photograph without people (scikit-image) as an n-frame static sequence, the
    prediction a few grey levels off."""
    skdata = pytest.importorskip("skimage.data")
    photo = getattr(skdata, name)()[:150, :225]
    rng = np.random.default_rng(0)
    gt = [np.clip(photo.astype(int) + rng.integers(-1, 2, photo.shape), 0, 255).astype(np.uint8)
          for _ in range(n)]
    for cam_root, frames in ((root / "gt", gt), (root / "pred", [
            np.clip(f.astype(int) + noise, 0, 255).astype(np.uint8) for f in gt])):
        write_frames(cam_root, "cam00", frames)
    return root / "pred", root / "gt"


def test_bundled_detector_on_a_real_photo_says_once_what_it_is(tmp_path):
    from dynaeval.regions.detector import SYNTHETIC_DETECTOR

    pred, gt = _photo_sequence(tmp_path)
    with pytest.warns(dynaeval.DynaevalWarning, match="bundled synthetic-scene detector"):
        res = dynaeval.score(pred, gt, metrics=("psnr",), temporal=False, progress=False)
    said = [w for w in res["warnings"] if w["reason"] == SYNTHETIC_DETECTOR]
    assert len(said) == 1 and "camera" not in said[0]
    assert "dynaeval detector fetch retinanet" in SYNTHETIC_DETECTOR and "--focus motion" in SYNTHETIC_DETECTOR
    regions = res["regions"]
    assert regions["source"] == "detector" and regions["bundled_detector"] is True
    cam = regions["cameras"]["cam00"]
    assert cam["n_frames"] == 3 and list(cam["boxes"])[:2] == ["person", "ball"]
    n_records = sum(len(f["objects"]) for f in res["frames"])  # presence lists every GT object
    assert sum(cam["boxes"].values()) >= n_records
    assert cam["frames_with_boxes"] == sum(f["focused_psnr"] is not None for f in res["frames"])
    _validate(res)


def _validate(res):
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(json.loads(json.dumps(res)), json.loads(schema_path().read_text()))


def test_another_detector_is_not_called_synthetic(tmp_path):
    pytest.importorskip("onnx")
    from tests.dynaeval.regions.test_detector import yolo_model, yolo_pred

    model = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 20, 20, 0, 0.9)]))
    pred, gt = _photo_sequence(tmp_path)
    res = dynaeval.score(pred, gt, metrics=("psnr",), temporal=False, progress=False,
                         focus=FocusConfig(detector_model=str(model)))
    assert not any("synthetic" in w["reason"] for w in res["warnings"])
    assert res["regions"]["bundled_detector"] is False
    assert res["regions"]["cameras"]["cam00"]["boxes"] == {"person": 3, "ball": 0}


@pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")
def test_no_box_anywhere_gives_one_headline_instead_of_null_summaries(tmp_path):
    from dynaeval.report.results import NO_REGIONS

    pred, gt = _photo_sequence(tmp_path)
    boxes = tmp_path / "boxes.json"
    write_boxes_file(boxes, {f"cam00/{t:04d}": [] for t in range(3)}, {"kind": "test"})
    res = dynaeval.score(pred, gt, metrics=("psnr", "ssim"), progress=False,
                         focus=FocusConfig.parse(f"boxes:{boxes}"))
    run_level = [w for w in res["warnings"] if "camera" not in w]
    assert run_level[0]["reason"].startswith(f"{NO_REGIONS} 3 ground-truth frames: the boxes file "
                                             "lists none, so every focused_* value and presence "
                                             "value is null. Fix: check that the file's keys")
    explained = [w for w in run_level if w.get("metric", "").startswith(("focused_", "presence_", "tight_"))]
    assert explained == []  # the per-metric "summary is null" lines are replaced
    assert res["summary"]["focused_psnr"] is None and res["summary"]["psnr"] is not None
    assert res["regions"]["cameras"]["cam00"]["frames_with_boxes"] == 0


@pytest.mark.filterwarnings("ignore::dynaeval.DynaevalWarning")
def test_bundled_detector_finding_nothing_names_the_coco_fix(tmp_path):
    from dynaeval.report.results import NO_REGIONS

    root = tmp_path
    grey = [np.full((64, 96, 3), 128, np.uint8)] * 3  # nothing to find
    write_frames(root / "gt", "cam00", grey)
    write_frames(root / "pred", "cam00", [g + 2 for g in grey])
    res = dynaeval.score(root / "pred", root / "gt", metrics=("psnr",), temporal=False, progress=False)
    head = [w["reason"] for w in res["warnings"] if w["reason"].startswith(NO_REGIONS)]
    assert len(head) == 1 and "the bundled synthetic-scene detector found none" in head[0]
    assert "dynaeval detector fetch retinanet" in head[0] and "--focus motion" in head[0]


def test_without_lpips_tlp_is_recorded_as_off_without_warnings():
    """LPIPS not among the metrics: tLP is switched off in the settings and says nothing else
    (its null values are what was asked for); every other number is scored."""
    from dynaeval.cli import sample_dir

    root = sample_dir()
    res = dynaeval.score(root / "pred", root / "gt", metrics=("psnr",), progress=False,
                         focus=FocusConfig(source="boxes", boxes_file=str(root / "boxes.json")))
    assert res["settings"]["temporal"]["tlp"] is False
    assert res["summary"]["tlp"] is None and res["summary"]["warp_error"] is not None
    assert not [w for w in res["warnings"] if "tlp" in w.get("metric", "")]


def test_a_failing_camera_stops_the_others_and_its_error_is_raised():
    import time
    from concurrent.futures import ThreadPoolExecutor

    from dynaeval.core.progress import Progress
    from dynaeval.run.executor import cameras_at_once
    from dynaeval.run.scoring import CameraProgress

    frames_of = {"a": 0, "b": 0}
    progress = Progress({"regions": 6, "frames": 800, "pairs": 4, "video": 2}, enabled=False)
    fail = [False]

    def score(cam, cam_pairs, stop=None):  # as dynaeval.run.scoring.score_camera ticks
        ticks = CameraProgress(progress, cam, stop, frames=len(cam_pairs))
        for _ in range(2 if cam == "a" else 400):
            time.sleep(0.005)
            frames_of[cam] += 1
            ticks.frame()
        if cam == "a" and fail[0]:
            raise InputError("frame 0002.png is broken")
        ticks.done(None)
        return cam

    cams = {"a": [None] * 3, "b": [None] * 3}

    with ThreadPoolExecutor(max_workers=2) as lanes:
        assert cameras_at_once(lanes, cams, score) == ["a", "b"]
    assert frames_of["b"] == 400
    frames_of["b"], fail[0] = 0, True
    with ThreadPoolExecutor(max_workers=2) as lanes, pytest.raises(InputError, match="0002.png"):
        cameras_at_once(lanes, cams, score)
    assert frames_of["b"] < 100  # stopped at its next frame, not run to its end


@pytest.mark.parametrize("focus", ["detector", "motion", "none", "boxes:b.json"])
@pytest.mark.parametrize("device", ["cpu", "auto"])
def test_focus_strings_are_read_as_the_cli_reads_them(focus, device):
    """Issue 32 item 12: score(focus="motion") was refused ("focus must be a FocusConfig")."""
    from dynaeval.cli import build_parser, config_from_args

    args = build_parser().parse_args(["score", "p", "g", "--focus", focus, "--device", device])
    assert ScoreConfig(focus=focus, device=device) == config_from_args(args)


def test_score_with_a_focus_string_gives_the_cli_numbers(tmp_path, scene):
    from dynaeval.cli import main

    pred_dir, gt_dir, _, _ = scene
    res = dynaeval.score(pred_dir, gt_dir, metrics=("psnr", "ssim"), temporal=False,
                         focus="motion", progress=False)
    out = tmp_path / "cli.json"
    code = main(["score", str(pred_dir), str(gt_dir), "--metrics", "psnr", "ssim", "--no-temporal",
                 "--focus", "motion", "--quiet", "-o", str(out)])
    cli = json.loads(out.read_text())
    assert code == 0 and res["settings"]["focus"] == cli["settings"]["focus"]
    keys = ("psnr", "focused_psnr", "masked_psnr", "ssim", "focused_ssim", "masked_ssim")
    assert [[f.get(k) for k in keys] for f in res["frames"]] == [
        [f.get(k) for k in keys] for f in cli["frames"]]
    assert any(f.get("focused_psnr") is not None for f in cli["frames"])  # motion boxes found

# ----------------------------------------------------------- separate views (issue 32 item 5)


def _nerfbaselines_run(root, scene):
    """A NeRFBaselines render folder (color/ + gt-color/) made of the scene's camera cam00."""
    pred, gt, frames, preds = scene
    write_frames(root, "color", preds["cam00"])
    write_frames(root, "gt-color", frames["cam00"])
    return root


def test_render_folder_of_separate_views_is_scored_per_frame_and_says_so_once(tmp_path, scene,
                                                                              capsys):
    """Issue 32 item 5: a NeRFBaselines / ns-render / 3DGS render folder (separate test views)
    got tOF, warping error and motion masks over unrelated photos by default. Now per frame
    only, said once on the console and in ``settings.sequence``; ``--frames-are-video`` gives
    the temporal terms and motion masks back; per-frame numbers are those of the plain folders."""
    from dynaeval.cli import main

    run = _nerfbaselines_run(tmp_path / "run", scene)
    out, video = tmp_path / "r.json", tmp_path / "v.json"
    args = ["score", str(run), "--no-lpips", "--focus", "none", "-q"]
    assert main([*args, "-o", str(out)]) == 0
    err = capsys.readouterr().err
    said = ("the nerfbaselines render folder's frames are separate test views, not a video: "
            "scored per frame only (temporal terms and motion masks and masked_* skipped, "
            "meaningless across unrelated views); pass --frames-are-video")
    assert err.count(said) == 1 and "warp_error" not in err
    doc = json.loads(out.read_text())
    assert doc["settings"]["sequence"]["video"] is False
    assert doc["settings"]["sequence"]["skipped"] == ["temporal terms", "motion masks and masked_*"]
    assert not {"warp_error", "tof", "flicker", "masked_psnr"} & set(doc["summary"])
    assert "temporal" not in doc["settings"] and "motion" not in doc["settings"]["focus"]
    plain = dynaeval.score(run / "color", run / "gt-color", metrics=("psnr", "ssim"),
                           focus=FocusConfig(source="none", masked=False), temporal=False,
                           progress=False)
    assert [r["psnr"] for r in doc["frames"]] == [r["psnr"] for r in plain["frames"]]
    assert main([*args, "--frames-are-video", "-o", str(video)]) == 0
    doc = json.loads(video.read_text())
    assert doc["settings"]["sequence"]["video"] is True
    assert doc["summary"]["warp_error"] is not None and "masked_psnr" in doc["summary"]
    assert "separate test views" not in capsys.readouterr().err


def test_motion_focus_or_jod_on_separate_views_is_exit_2_with_the_fix(tmp_path, scene, capsys):
    from dynaeval.cli import main

    run = _nerfbaselines_run(tmp_path / "run", scene)
    assert main(["score", str(run), "--no-lpips", "--focus", "motion", "-q"]) == 2
    err = capsys.readouterr().err
    assert ("--focus motion needs each camera's frames as a video, but the nerfbaselines render "
            "folder's frames are separate test views, not a video; pass --frames-are-video") in err
    with pytest.raises(InputError, match="--jod needs each camera's frames as a video"):
        dynaeval.score(run, metrics=("psnr", "jod"), focus=FocusConfig(source="none"),
                       progress=False)
    with pytest.raises(InputError, match=r"scored as separate views \(frames_are_video=False\)"):
        dynaeval.score(scene[0], scene[1], metrics=("psnr",), progress=False,
                       focus=FocusConfig(source="motion"), frames_are_video=False)


def test_given_masks_keep_masked_metrics_on_separate_views(tmp_path, scene):
    """A NeRFBaselines render folder's mask/ is per frame: masked_* over it stay (only the motion
    masks are skipped), and ordinary folders under frames_are_video=False lose the temporal
    terms as a render folder does."""
    import cv2

    run = _nerfbaselines_run(tmp_path / "run", scene)
    (run / "mask").mkdir()
    for f in sorted((run / "gt-color").iterdir()):
        m = np.zeros((48, 64), np.uint8)
        m[:24] = 255
        cv2.imwrite(str(run / "mask" / f.name), m)
    res = dynaeval.score(run, metrics=("psnr",), focus=FocusConfig(source="none"),
                         progress=False)
    assert res["summary"]["masked_psnr"] is not None
    assert res["settings"]["sequence"]["skipped"] == ["temporal terms"]
    flat = dynaeval.score(scene[0], scene[1], metrics=("psnr",), progress=False,
                          focus=FocusConfig(source="none", masked=False), frames_are_video=False)
    assert "warp_error" not in flat["summary"] and flat["settings"]["sequence"]["video"] is False

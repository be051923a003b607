"""JOD (ColorVideoVDP, FovVideoVDP): dynaeval's numbers held to the packages' own API on the same
decoded frames, the focused window on a case with a known answer, properties, error paths, the
run (library and CLI) and the run without the packages.

The oracle is each package's documented call, ``metric.predict(test, reference,
dim_order="FHWC", frames_per_second=fps)`` on the stacked float32 frames; dynaeval streams the
frames through its own video source (``dynaeval.metrics.jod._sources``). Tolerance: 1e-3 JOD
(measured: equal to the last bit on these inputs).

torch runs single-threaded here (``one_thread``): on this shared 2-core machine two threads are
10x slower, never different in value beyond float rounding.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from dynaeval.errors import EmptyRegionError, InputError
from dynaeval.metrics import jod as J

HAVE = {}
for _model, (_, _module) in J.MODELS.items():
    try:
        __import__(_module)
        HAVE[_model] = True
    except ImportError:
        HAVE[_model] = False
needs_cvvdp = pytest.mark.skipif(not HAVE["cvvdp"], reason="cvvdp not installed (dynaeval[video])")
needs_fvvdp = pytest.mark.skipif(not HAVE["fvvdp"], reason="pyfvvdp not installed (dynaeval[fvvdp])")
models = pytest.mark.parametrize("model", [
    pytest.param("cvvdp", marks=needs_cvvdp), pytest.param("fvvdp", marks=needs_fvvdp)])

TOL = 1e-3


@pytest.fixture(autouse=True)
def one_thread():
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def _frames(side: str, camera: str = "cam07") -> list[np.ndarray]:
    from dynaeval.cli import sample_dir
    from dynaeval.io import read_image

    folder = sample_dir() / side / camera
    return [read_image(p) for p in sorted(folder.glob("*.png"))]


@pytest.fixture(scope="module")
def clip():
    """The sample's cam07: 8 frames of 256x144, prediction and ground truth as decoded."""
    return _frames("pred"), _frames("gt")


_MODELS: dict[tuple[str, str], object] = {}


def _model(model: str, display: str = J.DEFAULT_DISPLAY):
    if (model, display) not in _MODELS:
        _MODELS[model, display] = J.load_model(model, display)
    return _MODELS[model, display]


def _oracle(model: str, pred, gt, fps: float = 30.0, window=None) -> float:
    p, g = np.stack(pred).astype(np.float32), np.stack(gt).astype(np.float32)
    if window is not None:
        x0, y0, x1, y1 = window
        p, g = p[:, y0:y1, x0:x1], g[:, y0:y1, x0:x1]
    q, _ = _model(model).predict(np.ascontiguousarray(p), np.ascontiguousarray(g),
                                 dim_order="FHWC", frames_per_second=fps)
    return float(q)


# --------------------------------------------------------------------------------------------
# Against the packages' own API


@models
def test_equals_the_packages_predict_on_the_same_frames(model, clip):
    pred, gt = clip
    got = J.jod(pred, gt, fps=30, model=model)
    want = _oracle(model, pred, gt)
    assert got == pytest.approx(want, abs=TOL)
    assert 5.0 < got < 10.0
    window = (40, 20, 200, 120)
    assert J.jod(pred, gt, metric=_model(model), window=window) == pytest.approx(
        _oracle(model, pred, gt, window=window), abs=TOL)
    # the frame rate reaches the temporal filters: 10 fps gives another number, the package's
    low = J.jod(pred, gt, fps=10, metric=_model(model))
    assert low == pytest.approx(_oracle(model, pred, gt, fps=10), abs=TOL)
    assert low != got


@models
def test_identical_clips_give_ten(model, clip):
    _, gt = clip
    assert J.jod(gt, gt, metric=_model(model)) == pytest.approx(10.0, abs=1e-6)
    assert J.jod(gt[:1], gt[:1], metric=_model(model)) == pytest.approx(10.0, abs=1e-6)  # image


@needs_cvvdp
def test_display_model_changes_the_number_as_the_package_does(clip):
    pred, gt = clip
    m4k = _model("cvvdp", "standard_4k")
    got = J.jod(pred, gt, model="cvvdp", display="standard_4k")
    want, _ = m4k.predict(np.stack(pred), np.stack(gt), dim_order="FHWC", frames_per_second=30)
    assert got == pytest.approx(float(want), abs=TOL)
    assert got != pytest.approx(J.jod(pred, gt, metric=_model("cvvdp")), abs=1e-3)


# --------------------------------------------------------------------------------------------
# Properties


@needs_cvvdp
def test_uint8_scores_like_float_divided_by_255_and_grey_like_its_rgb(clip):
    pred, gt = clip
    m = _model("cvvdp")
    p8 = [np.round(f * 255).astype(np.uint8) for f in pred[:4]]
    g8 = [np.round(f * 255).astype(np.uint8) for f in gt[:4]]
    as_float = J.jod([f / np.float32(255) for f in p8], [f / np.float32(255) for f in g8], metric=m)
    assert J.jod(p8, g8, metric=m) == pytest.approx(as_float, abs=1e-5)
    grey_p, grey_g = [f.mean(axis=2) for f in pred[:4]], [f.mean(axis=2) for f in gt[:4]]
    rgb = J.jod([np.repeat(f[..., None], 3, 2) for f in grey_p],
                [np.repeat(f[..., None], 3, 2) for f in grey_g], metric=m)
    assert J.jod(grey_p, grey_g, metric=m) == pytest.approx(rgb, abs=1e-6)


@needs_cvvdp
def test_monotone_in_added_noise(clip):
    _, gt = clip
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 1, (len(gt), *gt[0].shape)).astype(np.float32)
    values = [J.jod([np.clip(g + s * n, 0, 1) for g, n in zip(gt, noise, strict=True)], gt,
                    metric=_model("cvvdp")) for s in (0.01, 0.03, 0.1)]
    assert values[0] > values[1] > values[2]


# --------------------------------------------------------------------------------------------
# The focused window: known answers


def test_focus_window_is_the_union_box_over_the_clip_grown_and_kept_inside():
    boxes = [np.array([[100, 50, 120, 90]]), None, np.array([[130, 60, 150, 80], [90, 70, 95, 75]])]
    # union: x 90..150, y 50..90 = 60 x 40; grown to 64 x 64 around its centre (120, 70)
    np.testing.assert_array_equal(J.focus_window(boxes, 144, 256), [88, 38, 152, 102])
    np.testing.assert_array_equal(J.focus_window(boxes, 144, 256, min_size=10), [90, 50, 150, 90])
    # at the border: shifted inside, not cut
    np.testing.assert_array_equal(J.focus_window([np.array([[0, 0, 10, 10]])], 144, 256),
                                  [0, 0, 64, 64])
    np.testing.assert_array_equal(J.focus_window([np.array([[250, 140, 300, 200]])], 144, 256),
                                  [192, 80, 256, 144])  # clipped to the frame first
    # a frame smaller than the minimum: the whole frame along that side
    np.testing.assert_array_equal(J.focus_window([np.array([[2, 2, 5, 5]])], 40, 100),
                                  [0, 0, 64, 40])
    with pytest.raises(EmptyRegionError, match="no frame of the camera has a focus box"):
        J.focus_window([None, np.zeros((0, 4), np.int64), np.array([[300, 300, 310, 310]])],
                       144, 256)


@needs_cvvdp
def test_focused_jod_is_the_jod_of_the_window_every_frame_is_cut_to(clip):
    pred, gt = clip
    fn = J.build_jod(_ctx())
    boxes = [np.array([[100, 50, 120, 90]]), *[None] * 6, np.array([[130, 60, 150, 80]])]
    got = fn(pred, gt, 30.0, {"boxes": boxes})
    assert got == pytest.approx(_oracle("cvvdp", pred, gt, window=(93, 38, 157, 102)), abs=TOL)
    assert fn(pred, gt, 30.0, {}) == pytest.approx(_oracle("cvvdp", pred, gt), abs=TOL)


def _ctx(**options):
    from dynaeval.metrics.registry import FrameContext

    return FrameContext(options={"jod": options} if options else {})


# --------------------------------------------------------------------------------------------
# Errors


def test_bad_inputs_raise_input_error():
    img = np.zeros((16, 16, 3), np.float32)
    cases = [
        (dict(pred=[img, img], gt=[img]), "same number"),
        (dict(pred=[], gt=[]), "same number"),
        (dict(pred=[img], gt=[img], fps=0), "frames per second must be a positive number"),
        (dict(pred=[img], gt=[img], fps=True), "frames per second must be a positive number"),
        (dict(pred=[img], gt=[img], model="vmaf"), "jod model must be one of cvvdp, fvvdp"),
        (dict(pred=[img + 2], gt=[img]), r"float values must be in \[0, 1\]"),
        (dict(pred=[img[..., :2]], gt=[img]), "JOD needs RGB"),
    ]
    for kw, match in cases:
        with pytest.raises(InputError, match=match):
            J.jod(**kw)


@needs_cvvdp
def test_bad_display_window_and_frame_sizes_raise(clip):
    pred, gt = clip
    with pytest.raises(InputError, match="unknown display model 'crt'"):
        J.load_model("cvvdp", "crt")
    with pytest.raises(InputError, match="a video has one frame size"):
        J.jod([pred[0], pred[1][:100]], gt[:2], metric=_model("cvvdp"))
    with pytest.raises(EmptyRegionError, match="holds no pixel"):
        J.jod(pred, gt, metric=_model("cvvdp"), window=(300, 0, 400, 10))
    with pytest.raises(InputError, match="one box"):
        J.jod(pred, gt, metric=_model("cvvdp"), window=[[0, 0, 4, 4], [1, 1, 5, 5]])


# --------------------------------------------------------------------------------------------
# Through the run: library, CLI, options, without the packages

KEYS = ("jod", "focused_jod")


def _score(root=None, **kw):
    import dynaeval
    from dynaeval.cli import sample_dir
    from dynaeval.regions.focus import FocusConfig

    root = root or sample_dir()
    focus = FocusConfig(source="boxes", boxes_file=str(sample_dir() / "boxes.json"), masked=False)
    args = dict(metrics=("psnr", "jod"), temporal=False, presence=False, progress=False,
                focus=focus)
    return dynaeval.score(root / "pred", root / "gt", **{**args, **kw})


@needs_cvvdp
def test_the_run_reports_jod_per_camera_equal_to_the_package():
    regions = {}
    res = _score(on_regions=lambda cam, pairs, r: regions.setdefault(cam, r))
    assert res["metrics"]["jod"] == {"higher_is_better": True, "unit": "JOD"}
    for cam in ("cam07", "eval00"):
        pred, gt = _frames("pred", cam), _frames("gt", cam)
        assert res["cameras"][cam]["jod"] == pytest.approx(_oracle("cvvdp", pred, gt), abs=TOL)
        window = J.focus_window([r.boxes for r in regions[cam]], 144, 256)
        assert res["cameras"][cam]["focused_jod"] == pytest.approx(
            _oracle("cvvdp", pred, gt, window=window), abs=TOL)
    for k in KEYS:  # camera-level: the summary is the mean over cameras, no per-frame value
        assert res["summary"][k] == pytest.approx(
            np.mean([c[k] for c in res["cameras"].values()]), abs=1e-12)
        assert not any(k in row for row in res["frames"])
        assert res["counts"][k] == 2
    s = res["settings"]["jod"]
    assert (s["model"], s["display"], s["fps"], s["enabled"]) == ("cvvdp", "standard_fhd", 30.0, True)
    assert s["package"].startswith("cvvdp ") and "masked" in s
    assert not any("masked_jod" in k for k in res["summary"])
    assert "psnr" in res["summary"] and not res["warnings"]


@needs_fvvdp
def test_fvvdp_is_a_selectable_variant_and_fps_a_run_setting(tmp_path):
    from dynaeval.cli import main, sample_dir

    root, out = sample_dir(), tmp_path / "r.json"
    assert main(["score", str(root / "pred" / "cam07"), str(root / "gt" / "cam07"), "--jod",
                 "--metric-option", "jod.model=fvvdp", "--fps", "25", "--no-lpips",
                 "--no-temporal", "--no-presence", "--focus", "none", "--no-masked", "-q",
                 "-o", str(out)]) == 0
    res = json.loads(out.read_text())
    want = _oracle("fvvdp", _frames("pred"), _frames("gt"), fps=25)
    assert res["summary"]["jod"] == pytest.approx(want, abs=TOL)
    assert res["settings"]["jod"]["model"] == "fvvdp" and res["settings"]["jod"]["fps"] == 25.0
    assert res["settings"]["jod"]["package"].startswith("pyfvvdp ")


@needs_cvvdp
def test_a_video_camera_is_played_at_its_own_frame_rate(tmp_path):
    """Ground truth and prediction as mp4 files of 12 fps: JOD uses 12, not --fps; the oracle
    gets the frames dynaeval decoded."""
    cv2 = pytest.importorskip("cv2")
    from dynaeval.io.video import read_video_frame

    for side in ("pred", "gt"):
        (tmp_path / side).mkdir()
        writer = cv2.VideoWriter(str(tmp_path / side / "cam07.avi"),
                                 cv2.VideoWriter_fourcc(*"MJPG"), 12, (256, 144))
        if not writer.isOpened():
            pytest.skip("OpenCV cannot write MJPG here")
        for f in _frames(side):
            writer.write(np.round(f[..., ::-1] * 255).astype(np.uint8))
        writer.release()
    import dynaeval
    from dynaeval.regions.focus import FocusConfig

    res = dynaeval.score(tmp_path / "pred", tmp_path / "gt", metrics=("jod",), temporal=False,
                         presence=False, progress=False, fps=50.0,
                         focus=FocusConfig(source="none", masked=False))
    decoded = {s: [read_video_frame(tmp_path / s / "cam07.avi", i) for i in range(8)]
               for s in ("pred", "gt")}
    want = _model("cvvdp").predict(np.stack(decoded["pred"]), np.stack(decoded["gt"]),
                                   dim_order="FHWC", frames_per_second=12)[0]
    assert res["summary"]["jod"] == pytest.approx(float(want), abs=TOL)


@needs_cvvdp
def test_skipped_frames_make_jod_null_with_the_reason(tmp_path):
    import shutil

    from dynaeval.cli import sample_dir

    root = sample_dir()
    for side in ("pred", "gt"):
        shutil.copytree(root / side / "cam07", tmp_path / side / "cam07")
    (tmp_path / "pred" / "cam07" / "0003.png").unlink()
    res = _score(tmp_path, allow_missing=True, focus=_none())
    assert res["cameras"]["cam07"]["jod"] is None and res["summary"]["jod"] is None
    assert any(w.get("metric") == "jod" and "not consecutive" in w["reason"]
               for w in res["warnings"])


def _none():
    from dynaeval.regions.focus import FocusConfig

    return FocusConfig(source="none", masked=False)


def test_jod_is_off_by_default_and_bad_options_are_usage_errors(capsys):
    from dynaeval.cli import main, sample_dir
    from dynaeval.run.config import ScoreConfig

    assert "jod" not in ScoreConfig().metrics
    with pytest.raises(InputError, match="frames per second must be a positive number"):
        ScoreConfig(fps=0)
    with pytest.raises(InputError, match="jod has no option 'ppd'"):
        ScoreConfig(metrics=("psnr", "jod"), metric_options={"jod": {"ppd": 1}})
    root = sample_dir()
    base = ["score", str(root / "pred"), str(root / "gt"), "--jod", "-q", "--no-lpips"]
    for extra, message in ((["--metric-option", "jod.model=vmaf"], "jod model must be one of"),
                           (["--fps", "-3"], "frames per second must be a positive number")):
        assert main(base + extra) == 2
        assert message in capsys.readouterr().err


def test_without_the_packages_a_run_asking_for_jod_is_refused_with_the_install_line(monkeypatch):
    """JOD is off by default, so naming it is asking for it: without its package the run is
    refused before any frame is read (issue 32, item 4: it used to go on without the metric)."""
    monkeypatch.setitem(sys.modules, "pycvvdp", None)  # import pycvvdp fails
    with pytest.raises(InputError, match=r"JOD was asked for but cannot run here: JOD "
                       r"\(ColorVideoVDP\) needs the cvvdp package, which is not installed: pip "
                       r"install 'dynaeval\[video\]'; or score without JOD \(drop --jod"):
        _score(focus=_none())
    with pytest.raises(ImportError, match=r"pip install 'dynaeval\[video\]'"):
        J.jod([np.zeros((8, 8, 3))], [np.zeros((8, 8, 3))])


def test_fovvideovdp_absent_names_its_own_extra(monkeypatch):
    """jod.model=fvvdp needs pyfvvdp, which is in dynaeval[fvvdp] (non-commercial), never in
    dynaeval[video]: the refusal, the registry's soft path and the model loader all say so
    (issue 32, item 4: the registry appended dynaeval[video])."""
    from dynaeval.metrics.registry import FrameContext, build_frame_metrics

    monkeypatch.setitem(sys.modules, "pyfvvdp", None)
    with pytest.raises(InputError, match=r"JOD \(FovVideoVDP\) needs the pyfvvdp package, "
                       r"which is not installed: pip install 'dynaeval\[fvvdp\]'; or score"):
        _score(focus=_none(), metric_options={"jod": {"model": "fvvdp"}})
    ctx = FrameContext(options={"jod": {"model": "fvvdp"}})
    assert J.missing_package(ctx).endswith("pip install 'dynaeval[fvvdp]'")
    built = build_frame_metrics(ctx, ("psnr", "jod"))
    assert built.unavailable["jod"].endswith("pip install 'dynaeval[fvvdp]'"), built.unavailable
    assert "dynaeval[video]" not in built.unavailable["jod"]

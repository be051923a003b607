"""K-Planes' evaluation stack (prediction / ground truth / error map, stacked vertically) read as
a prediction-ground-truth pair, from Python and the CLI."""

from __future__ import annotations

import json
import warnings

import cv2
import numpy as np
import pytest
import skimage.data

import dynaeval
from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.io.kplanes import STACK_PARTS, StackedFrameRef, pair_stack
from dynaeval.io.layouts import detect_layout
from dynaeval.metrics import psnr
from dynaeval.metrics.multiscale import ms_ssim
from dynaeval.metrics.protocols import get_protocol
from dynaeval.regions.focus import FocusConfig

NO_FOCUS = FocusConfig(source="none", masked=False)
FAST = dict(metrics=("psnr", "ssim"), focus=NO_FOCUS, temporal=False, progress=False)


def _stack_frames(n: int, h: int = 180, w: int = 200, seed: int = 0):
    """(stacks, preds, gts): uint8 RGB frames built as K-Planes builds them (base_trainer)."""
    rng = np.random.default_rng(seed)
    photo = skimage.data.astronaut()
    stacks, preds, gts = [], [], []
    for t in range(n):
        gt = photo[t * 4:t * 4 + h, :w].astype(np.float32) / 255
        pred = np.clip(gt + rng.normal(0, 0.04, gt.shape), 0, 1).astype(np.float32)
        err = np.abs(pred - gt).mean(-1, keepdims=True)
        err = ((err - err.min()) / err.max()).repeat(3, -1)
        stack = (np.concatenate([pred, gt, err]) * 255).astype(np.uint8)  # .byte(): truncation
        stacks.append(stack)
        preds.append(stack[:h])
        gts.append(stack[h:2 * h])
    return stacks, preds, gts


def _write_video(path, frames, fourcc):
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 30, (w, h))
    assert writer.isOpened(), f"OpenCV cannot write {fourcc} here"
    for f in frames:
        writer.write(np.ascontiguousarray(f[..., ::-1]))  # K-Planes: RGB -> BGR
    writer.release()


def _decoded(path):
    cap = cv2.VideoCapture(str(path))
    out = []
    while True:
        ok, f = cap.read()
        if not ok:
            return out
        out.append(f[..., ::-1])


def test_lossless_video_stack_scores_its_thirds_exactly(tmp_path):
    stacks, preds, gts = _stack_frames(3)
    path = tmp_path / "logs" / "dnerf_lego" / "step30000.mkv"
    path.parent.mkdir(parents=True)
    _write_video(path, stacks, "FFV1")  # lossless: the decoded thirds are the written ones
    with pytest.warns(dynaeval.DynaevalWarning, match="not comparable to the psnr/ssim/ms-ssim"):
        res = dynaeval.score(path, protocol="kplanes", **FAST)
    proto = get_protocol("kplanes")
    f = lambda u: u.astype(np.float32) / 255  # noqa: E731
    assert [r["psnr"] for r in res["frames"]] == pytest.approx(
        [proto.whole_psnr(f(p), f(g)) for p, g in zip(preds, gts, strict=True)], abs=1e-12)
    assert res["summary"]["msssim"] == pytest.approx(
        np.mean([ms_ssim(f(p), f(g), clip=True) for p, g in zip(preds, gts, strict=True)]), abs=1e-12)
    assert res["inputs"]["cameras"] == ["step30000"] and res["summary"]["n_frames"] == 3
    assert res["method"] == "dnerf_lego"  # the experiment's log folder, as for render folders
    stack = res["inputs"]["layout"]["stack"]
    assert stack["parts"] == list(STACK_PARTS) and stack["ground_truth_rows"] == [180, 360]


def test_mp4v_stack_as_kplanes_writes_it(tmp_path):
    stacks, _, _ = _stack_frames(4)
    path = tmp_path / "step30000.mp4"
    _write_video(path, stacks, "mp4v")
    decoded = _decoded(path)
    assert len(decoded) == 4 and decoded[0].shape == stacks[0].shape
    assert np.abs(decoded[0].astype(int) - stacks[0]).max() > 0  # lossy
    res = dynaeval.score(path, protocol="kplanes", **FAST)
    assert any("MPEG-4" in w["reason"] for w in res["warnings"])
    assert not any("not grey" in w["reason"] for w in res["warnings"])  # survives the codec
    h = 180
    u = lambda a: a / np.float32(255)  # noqa: E731
    expect = [psnr(u(d[:h]), u(d[h:2 * h])) for d in decoded]  # the decoded frames, in thirds
    assert [r["psnr"] for r in res["frames"]] == pytest.approx(expect, abs=1e-5)


def test_odd_height_stack_reads_intact_prediction_and_ground_truth(tmp_path):
    # mp4v drops the last row/column of an odd-sized frame: 3 x 181 = 543 rows decode as 542
    stacks, _, _ = _stack_frames(2, h=181, w=201)
    path = tmp_path / "step7.mp4"
    _write_video(path, stacks, "mp4v")
    decoded = _decoded(path)
    assert decoded[0].shape[:2] == (542, 200)
    pairing = pair_stack(path)
    assert any("drops the last row" in w["reason"] for w in pairing.warnings)
    pred, gt = pairing.pairs[1].pred.read(), pairing.pairs[1].gt.read()
    assert np.array_equal(pred, decoded[1][:181] / np.float32(255))
    assert np.array_equal(gt, decoded[1][181:362] / np.float32(255))


def test_png_stack_and_parts(tmp_path):
    stacks, preds, gts = _stack_frames(1, h=60, w=70)
    path = tmp_path / "step500-0.png"
    cv2.imwrite(str(path), stacks[0][..., ::-1])
    pairing = pair_stack(path)
    (pair,) = pairing.pairs
    assert isinstance(pair.pred, StackedFrameRef) and str(pair.gt).endswith("(ground truth)")
    assert np.array_equal(pair.pred.read(), preds[0] / np.float32(255))
    assert np.array_equal(pair.gt.read(), gts[0] / np.float32(255))
    assert any("truncation" in w["reason"] for w in pairing.warnings)
    res = dynaeval.score(path, **FAST)  # dynaeval's protocol reads the stack the same way
    assert res["frames"][0]["psnr"] == pytest.approx(psnr(preds[0] / np.float32(255), gts[0] / np.float32(255)),
                                                    abs=1e-12)
    assert res["settings"]["protocol"]["name"] == "dynaeval"


def test_layout_rules(tmp_path):
    stacks, _, _ = _stack_frames(1, h=30, w=40)
    good = tmp_path / "step10-3.png"
    cv2.imwrite(str(good), stacks[0])
    lay = detect_layout(good)
    assert (lay.name, lay.pred, lay.gt, lay.root, lay.sequence) == ("kplanes", good, good, tmp_path, True)
    assert detect_layout(good, good) == lay
    cv2.imwrite(str(tmp_path / "step10-3-depth.png"), stacks[0])
    with pytest.raises(InputError, match=r"depth output.*score the stack next to it, step10-3.png"):
        detect_layout(tmp_path / "step10-3-depth.png")
    cv2.imwrite(str(tmp_path / "frame.png"), stacks[0])
    with pytest.raises(InputError, match="named step<N>.mp4"):
        detect_layout(tmp_path / "frame.png")
    cv2.imwrite(str(tmp_path / "step11-0.png"), stacks[0][:-1])  # 89 rows
    with pytest.raises(InputError, match=r"step11-0.png.*89 rows high, not a multiple of 3"):
        detect_layout(tmp_path / "step11-0.png")


def test_cli_scores_a_stack_and_refuses_a_bad_height(tmp_path, capsys):
    stacks, _, _ = _stack_frames(2, h=180, w=200)
    path = tmp_path / "step30000.mkv"
    _write_video(path, stacks, "FFV1")
    out = tmp_path / "r.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["score", str(path), "--protocol", "kplanes", "--no-lpips", "--focus", "none",
                     "--no-masked", "--no-temporal", "-q", "-o", str(out)])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert "K-Planes evaluation stack: scored the top third" in err and "not comparable" in err
    doc = json.loads(out.read_text())
    lib = dynaeval.score(path, protocol="kplanes", **FAST)
    assert doc["summary"]["psnr"] == lib["summary"]["psnr"]
    assert doc["summary"]["dssim"] == lib["summary"]["dssim"]
    assert doc["settings"]["protocol"]["choices"]["ssim"].startswith("mip-NeRF SSIM")
    bad = tmp_path / "step1.mkv"
    _write_video(bad, [s[:-2] for s in stacks], "FFV1")  # 538 rows: 538 % 3 == 1
    code = main(["score", str(bad), "--no-lpips", "-q", "-o", str(tmp_path / "bad.json")])
    _, err = capsys.readouterr()
    assert code == 2 and "step1.mkv" in err and "not a multiple of 3" in err
    assert "Traceback" not in err and not (tmp_path / "bad.json").exists()


def test_each_video_frame_is_decoded_once(tmp_path, monkeypatch):
    # prediction and ground truth are one decoded frame: the reader keeps the last one instead of
    # re-opening the file to go back to it
    from dynaeval.io import video

    stacks, _, _ = _stack_frames(4, h=30, w=40)
    path = tmp_path / "step2.mkv"
    _write_video(path, stacks, "FFV1")
    opens = []
    original = video.VideoReader._open
    monkeypatch.setattr(video.VideoReader, "_open", lambda self: (opens.append(1), original(self))[1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = dynaeval.score(path, metrics=("psnr",), focus=NO_FOCUS, temporal=False,
                             progress=False, cache_mb=0)
    assert res["summary"]["n_frames"] == 4 and len(opens) == 1


def test_a_colour_bottom_third_warns_that_it_is_no_error_map(tmp_path):
    stacks, _, _ = _stack_frames(1, h=60, w=70)
    good, bad = tmp_path / "step1-0.png", tmp_path / "step2-0.png"
    cv2.imwrite(str(good), stacks[0][..., ::-1])
    swapped = np.concatenate([stacks[0][:60], stacks[0][120:], stacks[0][60:120]])  # colour last
    cv2.imwrite(str(bad), swapped[..., ::-1])
    assert not any("not grey" in w["reason"] for w in pair_stack(good).warnings)
    (warning,) = [w for w in pair_stack(bad).warnings if "not grey" in w["reason"]]
    assert "step2-0.png" in warning["reason"]


def test_log_folder_scores_its_latest_evaluation(tmp_path):
    stacks, preds, gts = _stack_frames(3, h=60, w=70)
    log = tmp_path / "lego_run"
    log.mkdir()
    for step in (1000, 30000):
        _write_video(log / f"step{step}.mkv", stacks if step == 30000 else stacks[:1], "FFV1")
    _write_video(log / "step30000-depth.mkv", stacks, "FFV1")  # K-Planes' depth video: ignored
    lay = detect_layout(log)
    assert (lay.name, lay.pred, lay.sequence) == ("kplanes", log, True)
    res = dynaeval.score(log, **FAST)
    assert res["inputs"]["layout"]["stack"]["files"] == [str(log / "step30000.mkv")]
    assert res["inputs"]["cameras"] == ["step30000"] and res["summary"]["n_frames"] == 3
    assert res["method"] == "lego_run"
    # a static-scene log folder: one PNG per test image, the latest step's set in image order
    png = tmp_path / "static"
    png.mkdir()
    for step in (10, 20):
        for i, st in enumerate(stacks):
            cv2.imwrite(str(png / f"step{step}-{i}.png"), st[..., ::-1])
    assert detect_layout(png).sequence is False  # separate test views
    pairing = pair_stack(png)
    assert [(p.camera, p.frame) for p in pairing.pairs] == [("step20", "0"), ("step20", "1"), ("step20", "2")]
    assert np.array_equal(pairing.pairs[2].gt.read(), gts[2] / np.float32(255))
    with pytest.raises(InputError, match="no K-Planes evaluation stack"):
        pair_stack(tmp_path)  # folders only

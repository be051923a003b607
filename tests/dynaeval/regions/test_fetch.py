"""``dynaeval detector fetch``: the exported ONNX files give the PyTorch models' own boxes
through dynaeval's runtime (random weights: this machine has no network), names resolve, and
every failure is one exit-2 message that says what to do."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.regions import fetch
from dynaeval.regions.detector import Detector, DetectorConfig, resolve_model_path

PHOTOS = ("astronaut", "coffee", "chelsea")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "detectors"
    monkeypatch.setenv(fetch.CACHE_ENV, str(folder))
    return folder


def _photo(name: str) -> np.ndarray:
    data = pytest.importorskip("skimage.data")
    return getattr(data, name)()


def _calibrate_batch_norm(model, run) -> None:
    """Random weights leave batch norm at mean 0 / variance 1, and the features of a random
    network then die out: every box of the random mobilenet gets the score 0.0114, every YOLO
    candidate the same box. Set the statistics from two photos (not the test ones)."""
    import torch

    data = pytest.importorskip("skimage.data")
    norms = [m for m in model.modules() if isinstance(m, torch.nn.BatchNorm2d)]
    for m in norms:
        m.momentum = None  # cumulative average over the calibration images
        m.reset_running_stats()
        m.train()
    with torch.no_grad():
        for name in ("rocket", "hubble_deep_field"):
            run(getattr(data, name)().astype(np.float32) / 255)
    for m in norms:
        m.eval()


def recalibrated_batch_norm(model) -> None:
    """A torchvision detector's backbone batch norm, from two photos."""
    import torch

    def run(image):
        images, _ = model.transform([torch.from_numpy(image).permute(2, 0, 1)])
        model.backbone(images.tensors)

    _calibrate_batch_norm(model, run)


def recalibrated_yolo(model) -> None:
    """A YOLO ``DetectionModel``'s batch norm from two letterboxed photos; its class logits
    scaled down (x 0.05, bias 0), else every score of the random model is 1.0 in float32 and
    ties make the NMS order arbitrary."""
    import torch

    from dynaeval.regions.yolo import letterbox

    def run(image):
        canvas = letterbox(image, (640, 640))[0]
        model(torch.from_numpy(canvas).permute(2, 0, 1)[None])

    _calibrate_batch_norm(model, run)
    with torch.no_grad():
        for branch in model.model[-1].cv3:
            branch[-1].weight.mul_(0.05)
            branch[-1].bias.zero_()


def _gap_threshold(scores: np.ndarray, quantile: float) -> float:
    """A threshold near the ``quantile`` of the model's own scores that sits in a gap of at least
    1e-4 between two of them, so a float difference of 1e-5 cannot move a box across it."""
    s = np.sort(scores)[::-1]
    start = int(len(s) * (1 - quantile))
    for i in range(max(start, 1), len(s)):
        if s[i - 1] - s[i] > 1e-4:
            return float((s[i - 1] + s[i]) / 2)
    raise AssertionError("no gap in the scores")


def _rounded_out(boxes: np.ndarray, h: int, w: int) -> np.ndarray:
    b = boxes.astype(np.float64).copy()
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, w)
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, h)
    return np.concatenate([np.floor(b[:, :2] + 1e-6), np.ceil(b[:, 2:] - 1e-6)], axis=1)


def _matched_ious(want: np.ndarray, want_cls: np.ndarray, got: np.ndarray,
                  got_cls: np.ndarray) -> np.ndarray:
    """For each reference box, the IoU of the best unmatched same-class box found (greedy)."""
    from dynaeval.core.boxes import box_iou_matrix

    iou = box_iou_matrix(want, got) * (want_cls[:, None] == got_cls[None])
    taken, out = np.zeros(len(got), bool), []
    for i in range(len(want)):
        j = int(np.argmax(np.where(taken, -1.0, iou[i])))
        taken[j] = True
        out.append(iou[i, j])
    return np.asarray(out)


def _hold_equal(det: Detector, image: np.ndarray, want: np.ndarray, want_cls: np.ndarray,
                photo: str, nms_in_graph: bool = True) -> None:
    """The runtime's boxes of ``image`` against the reference's (float xyxy, original pixels):
    the final boxes (threshold, NMS, clipping, rounding) are as many, each reference box has a
    decoded candidate of its class at IoU >= 0.99 (all candidates above the threshold are the
    reference boxes when NMS is inside the graph), and the final boxes are the reference ones
    rounded outwards (IoU > 0.8: a coordinate within float error of an integer may round the
    other way)."""
    boxes, scores, cls = det.raw(image)
    sel = (scores >= det.config.score_threshold) & np.isin(cls, det.selected_ids)
    assert len(want) > 0, photo
    if nms_in_graph:
        assert int(sel.sum()) == len(want), photo
    ious = _matched_ious(want, want_cls, boxes[sel], cls[sel])
    assert ious.min() >= 0.99, (photo, np.sort(ious)[:5])
    found = det(image)
    h, w = image.shape[:2]
    assert len(found) == len(want), photo
    assert _matched_ious(_rounded_out(want, h, w), want_cls, found.boxes, found.class_ids).min() > 0.8


def _compare_torchvision(name: str, cache, photos, **builder_kwargs) -> list[int]:
    """Fetch ``name`` with random weights, run torch and the ONNX file on real photos, hold
    the boxes kept at a score threshold (from the model's own scores) equal. Returns the box
    counts per photo."""
    torch = pytest.importorskip("torch")
    pytest.importorskip("torchvision")
    pytest.importorskip("onnx")
    torch.manual_seed(0)
    path = fetch.fetch(name, pretrained=False, builder_kwargs=builder_kwargs,
                       model_hook=recalibrated_batch_norm)
    torch.manual_seed(0)
    model, _ = fetch.torchvision_model(fetch.KNOWN[name], False, **builder_kwargs)
    recalibrated_batch_norm(model)
    counts = []
    for photo in photos:
        image = _photo(photo)
        h, w = image.shape[:2]
        x = torch.from_numpy(image.astype(np.float32) / 255.0).permute(2, 0, 1)
        with torch.no_grad():
            ref = {k: v.numpy() for k, v in model([x])[0].items()}
        thr = _gap_threshold(ref["scores"], 0.5)
        keep = ref["scores"] >= thr
        det = Detector(DetectorConfig(model=name, classes=tuple(range(1, 91)), score_threshold=thr,
                                      nms_iou=1.0))
        _hold_equal(det, image, ref["boxes"][keep], ref["labels"][keep], photo)
        found = det(image)
        counts.append(len(found))
    doc = json.loads(path.with_suffix(".json").read_text())
    assert doc["pretrained"] is False and doc["export"]["opset"] == fetch.OPSET
    from dynaeval.core.runtime import file_sha256

    assert doc["onnx_sha256"] == file_sha256(path)
    assert Detector(DetectorConfig(model=name)).source()["fetched"]["name"] == name  # in results
    return counts


def test_fasterrcnn_mobilenet_export_gives_the_torch_boxes(cache):
    """Faster R-CNN returns boxes, labels, scores (not RetinaNet's order): the export names its
    outputs after what the model returns, and the runtime reads them by name."""
    counts = _compare_torchvision("fasterrcnn-mobilenet", cache, PHOTOS[1:],
                                  box_score_thresh=0.02)  # 0.0 keeps 91 classes x 1000 proposals
                                                          # for NMS: 4x slower, same check
    doc = json.loads((cache / "fasterrcnn-mobilenet.json").read_text())
    assert doc["export"]["outputs"] == ["boxes", "labels", "scores"]
    assert doc["class_names"][1] == "person" and doc["class_names"][37] == "sports ball"
    assert min(counts) > 0


@pytest.mark.slow
def test_retinanet_export_gives_the_torch_boxes(cache):
    _compare_torchvision("retinanet", cache, ("chelsea",), score_thresh=0.0)
    doc = json.loads((cache / "retinanet.json").read_text())
    assert doc["export"]["outputs"] == ["boxes", "scores", "labels"]


def test_yolo_export_gives_the_ultralytics_boxes(cache):
    """The torch model on the same letterboxed image, filtered by Ultralytics' own
    ``non_max_suppression`` (score threshold, per-class NMS at 0.45), against the exported
    file through dynaeval's runtime."""
    ultralytics = pytest.importorskip("ultralytics")
    torch = pytest.importorskip("torch")
    from ultralytics.utils.nms import non_max_suppression

    from dynaeval.regions.yolo import letterbox

    torch.manual_seed(0)
    path = fetch.fetch("yolov8n", pretrained=False, model_hook=recalibrated_yolo)
    torch.manual_seed(0)
    model = ultralytics.YOLO("yolov8n.yaml").model
    recalibrated_yolo(model)
    model.eval()
    for photo in PHOTOS[:2]:
        image = _photo(photo)
        canvas, (sx, sy), (ox, oy) = letterbox(image.astype(np.float32) / 255, (640, 640))
        with torch.no_grad():
            raw = model(torch.from_numpy(canvas).permute(2, 0, 1)[None])[0]
        scores = raw[0, 4:].max(dim=0).values.numpy()
        thr = _gap_threshold(scores, 0.98)
        (kept,) = non_max_suppression(raw, conf_thres=thr, iou_thres=0.45, max_det=300)
        kept = kept.numpy().astype(np.float64)
        want = kept[:, :4].copy()
        want[:, [0, 2]] = (want[:, [0, 2]] - ox) / sx
        want[:, [1, 3]] = (want[:, [1, 3]] - oy) / sy
        det = Detector(DetectorConfig(model=path, classes=tuple(range(80)), score_threshold=thr))
        _hold_equal(det, image, want, kept[:, 5].astype(int), photo, nms_in_graph=False)


# ------------------------------------------------------------------------------------------
# names, listing, failures


def test_names_resolve_and_list(cache, tmp_path):
    with pytest.raises(InputError, match="not fetched yet: run 'dynaeval detector fetch retinanet'"):
        resolve_model_path("retinanet")
    with pytest.raises(InputError, match="neither an .onnx file nor a fetched detector"):
        resolve_model_path("no-such-detector")
    cache.mkdir()
    (cache / "retinanet.onnx").write_bytes(b"x")
    (cache / "retinanet.json").write_text(json.dumps({"schema": "dynaeval/detector/v1",
                                                      "weights": {"name": "W"}, "date": "D"}))
    assert resolve_model_path("retinanet") == cache / "retinanet.onnx"
    rows = {r["name"]: r for r in fetch.list_detectors()}
    assert rows["retinanet"]["fetched"] and rows["retinanet"]["weights"] == "W"
    assert not rows["yolov8n"]["fetched"]
    local = tmp_path / "mine.onnx"
    local.write_bytes(b"x")
    assert resolve_model_path(str(local)) == local  # a path still works


def test_cache_folder_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.delenv(fetch.CACHE_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert fetch.cache_dir() == tmp_path / "dynaeval" / "detectors"
    monkeypatch.setenv(fetch.CACHE_ENV, str(tmp_path / "x"))
    assert fetch.cache_dir() == tmp_path / "x"


def test_offline_fetch_is_one_message_with_the_file_to_place(cache, monkeypatch, capsys):
    torch = pytest.importorskip("torch")
    pytest.importorskip("torchvision")
    monkeypatch.setenv("TORCH_HOME", str(cache.parent / "torch"))

    def offline(*args, **kwargs):
        raise OSError("Name or service not known")

    monkeypatch.setattr(torch.hub, "load_state_dict_from_url", offline)
    assert main(["detector", "fetch", "fasterrcnn-mobilenet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "fasterrcnn_mobilenet_v3_large_fpn-fb6a3cc7.pth" in err[0]
    assert str(cache.parent / "torch" / "hub" / "checkpoints") in err[0]
    assert not (cache / "fasterrcnn-mobilenet.onnx").exists()


def test_fetch_without_the_library_says_what_to_install(cache, monkeypatch, capsys):
    import builtins

    real = builtins.__import__

    def no_ultralytics(name, *args, **kwargs):
        if name.split(".")[0] == "ultralytics":
            raise ImportError("no ultralytics", name="ultralytics")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ultralytics)
    monkeypatch.setattr("importlib.import_module", lambda n: no_ultralytics(n))
    assert main(["detector", "fetch", "yolo11n"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("needs the ultralytics package: pip install --no-deps "
                                      "ultralytics && pip install torch torchvision pyyaml "
                                      "requests onnx") in err


def test_fetch_refuses_to_overwrite(cache, capsys):
    cache.mkdir()
    (cache / "yolov8n.onnx").write_bytes(b"x")
    assert main(["detector", "fetch", "yolov8n"]) == 2
    assert "already fetched; pass --overwrite" in capsys.readouterr().err


def test_detector_list_cli(cache, capsys):
    assert main(["detector", "list"]) == 0
    out = capsys.readouterr().out
    assert str(cache) in out and "retinanet" in out and "not fetched" in out


def test_the_yolo_install_line_keeps_opencv_python_out_and_is_the_documented_one(cache, capsys):
    # a plain 'pip install ultralytics' pulls opencv-python over dynaeval's contrib build and
    # takes --flow tvl1 away (issue 32): the line installs ultralytics without its dependencies
    line = fetch.ULTRALYTICS_INSTALL
    assert line.startswith("pip install --no-deps ultralytics && pip install ")
    assert "opencv" not in line
    docs = (Path(__file__).parents[3] / "docs" / "regions.md").read_text()
    assert f"```bash\n{line}\n```" in docs
    assert main(["detector", "list"]) == 0
    listed = [r for r in capsys.readouterr().out.splitlines() if "Ultralytics" in r]
    assert len(listed) == 2 and all(r.endswith(f"(needs: {line})") for r in listed)


def _fake_ultralytics(monkeypatch, *, load=None, export=None):
    """An ``ultralytics`` module whose ``YOLO(...)`` raises ``load`` and whose export raises
    ``export`` (what a --no-deps install without requests or onnx does)."""

    class YOLO:
        def __init__(self, source):
            if load is not None:
                raise load
            self.model, self.names = None, {}

        def export(self, **kwargs):
            raise export

    monkeypatch.setitem(sys.modules, "ultralytics", types.SimpleNamespace(YOLO=YOLO,
                                                                            __version__="0"))


def test_yolo_weights_without_requests_name_the_package_not_the_network(cache, monkeypatch,
                                                                        capsys):
    _fake_ultralytics(monkeypatch, load=ModuleNotFoundError("No module named 'requests'",
                                                            name="requests"))
    assert main(["detector", "fetch", "yolov8n"]) == 2
    err = capsys.readouterr().err
    assert "fetching yolov8n needs the requests package: pip install --no-deps ultralytics" in err
    assert "could not download" not in err and not (cache / "yolov8n.onnx").exists()


def test_yolo_export_without_onnx_is_an_input_error(cache, monkeypatch):
    _fake_ultralytics(monkeypatch, export=ModuleNotFoundError("No module named 'onnx'",
                                                              name="onnx"))
    with pytest.raises(InputError, match=r"fetching yolo11n needs the onnx package: pip install "
                                         r"--no-deps ultralytics && pip install .*onnx"):
        fetch.fetch("yolo11n", pretrained=False)
    assert list((cache / "weights").iterdir()) == []


def test_torchvision_export_without_onnx_says_to_install_it(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "onnx", None)  # import onnx raises ImportError
    with pytest.raises(InputError, match=r"needs the onnx package: pip install torch torchvision "
                                         r"onnx \(dynaeval only needs it to fetch"):
        fetch.write_onnx_metadata(tmp_path / "m.onnx", {"names": "{}"})

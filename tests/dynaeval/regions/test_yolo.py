"""The YOLO convention against its source: Ultralytics' ``non_max_suppression`` + ``scale_boxes``
(NMS on the unclipped boxes in letterbox pixels, then mapping back and clipping), held by a
float64 re-implementation of that source and, where it imports, by ``ultralytics`` itself."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.regions.detector import Detector, DetectorConfig, detect

pytest.importorskip("onnx")
from tests.dynaeval.regions.test_detector import yolo_model, yolo_pred  # noqa: E402


def test_nms_runs_before_clipping(tmp_path):
    """Two person boxes reaching past the left edge: IoU 0.44 as predicted (< 0.45, both kept by
    Ultralytics), 0.67 once clipped (the old clip-then-NMS order dropped one)."""
    rows = [(-20, 30, 80, 40, 0, 0.9),   # [-60, 10, 20, 50]
            (5, 30, 50, 40, 0, 0.8)]     # [-20, 10, 30, 50]
    path = yolo_model(tmp_path / "y.onnx", yolo_pred(rows))
    d = detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=path, nms_iou=0.45))
    assert d.boxes.tolist() == [[0, 10, 20, 50], [0, 10, 30, 50]]


def test_score_must_exceed_the_threshold(tmp_path):
    """Ultralytics keeps ``conf > conf_thres`` (torchvision ``scores > score_thresh``)."""
    path = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 10, 10, 0, 0.5)]))
    img = np.zeros((64, 64, 3), np.float32)
    assert len(detect(img, DetectorConfig(model=path, score_threshold=0.5))) == 0
    assert len(detect(img, DetectorConfig(model=path, score_threshold=0.4999))) == 1


def _greedy_nms64(boxes: np.ndarray, scores: np.ndarray, iou: float) -> list[int]:
    """torchvision/Ultralytics greedy NMS in float64: keep the best, drop IoU > iou, repeat."""
    order = list(np.argsort(-scores, kind="stable"))
    keep = []
    while order:
        i = order.pop(0)
        keep.append(i)
        rest = np.array(order, dtype=int)
        if not len(rest):
            break
        xx1 = np.maximum(boxes[i, 0], boxes[rest, 0])
        yy1 = np.maximum(boxes[i, 1], boxes[rest, 1])
        xx2 = np.minimum(boxes[i, 2], boxes[rest, 2])
        yy2 = np.minimum(boxes[i, 3], boxes[rest, 3])
        inter = np.clip(xx2 - xx1, 0, None) * np.clip(yy2 - yy1, 0, None)
        area = lambda b: (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1])  # noqa: E731
        ious = inter / (area(boxes[i]) + area(boxes[rest]) - inter)
        order = [int(j) for j, v in zip(rest, ious, strict=True) if v <= iou]
    return keep


def ultralytics_postprocess64(pred, canvas_hw, image_hw, conf, iou, classes, max_det=300):
    """Float64 re-implementation of Ultralytics' predictor postprocess for one image
    (``utils/nms.py`` ``non_max_suppression`` with ``agnostic=False, multi_label=False``, then
    ``utils/ops.py`` ``scale_boxes``): (K, 4) xyxy image boxes, (K,) scores, (K,) classes."""
    x = pred[0].T.astype(np.float64)  # (N, 4 + C)
    x = x[x[:, 4:].max(1) > conf]
    xy, wh = x[:, :2], x[:, 2:4]
    box = np.concatenate([xy - wh / 2, xy + wh / 2], 1)
    score, cls = x[:, 4:].max(1), x[:, 4:].argmax(1)
    ok = np.isin(cls, classes)
    box, score, cls = box[ok], score[ok], cls[ok]
    top = np.argsort(-score, kind="stable")[:30000]
    box, score, cls = box[top], score[top], cls[top]
    keep = _greedy_nms64(box + cls[:, None] * 7680.0, score, iou)[:max_det]
    box, score, cls = box[keep], score[keep], cls[keep]
    (h1, w1), (h0, w0) = canvas_hw, image_hw
    gain = min(h1 / h0, w1 / w0)
    new_h, new_w = max(round(h0 * gain), 1), max(round(w0 * gain), 1)
    pad_x, pad_y = round((w1 - new_w) / 2 - 0.1), round((h1 - new_h) / 2 - 0.1)
    box[:, [0, 2]] = (box[:, [0, 2]] - pad_x) / (new_w / w0)
    box[:, [1, 3]] = (box[:, [1, 3]] - pad_y) / (new_h / h0)
    box[:, [0, 2]] = box[:, [0, 2]].clip(0, w0)
    box[:, [1, 3]] = box[:, [1, 3]].clip(0, h0)
    return box, score, cls


def _random_pred(rng, n=600, n_cls=80, side=96):
    """Clustered candidates (so NMS has work), many reaching past the letterbox's content."""
    centres = rng.uniform(-10, side + 10, size=(12, 2))
    c = centres[rng.integers(0, 12, n)] + rng.normal(0, 4, (n, 2))
    wh = rng.uniform(4, 50, (n, 2))
    pred = np.zeros((1, 4 + n_cls, n), np.float32)
    pred[0, 0:2] = c.T
    pred[0, 2:4] = wh.T
    pred[0, 4:] = rng.uniform(0, 0.2, (n_cls, n))
    pred[0, 4 + rng.choice([0, 32, 2], n), np.arange(n)] = rng.uniform(0.1, 1.0, n)
    return pred


def _outward(box: np.ndarray) -> np.ndarray:
    eps = 1e-6
    return np.concatenate([np.floor(box[:, :2] + eps), np.ceil(box[:, 2:] - eps)], 1).astype(np.int64)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equals_a_float64_reimplementation_of_ultralytics(tmp_path, seed):
    rng = np.random.default_rng(seed)
    pred = _random_pred(rng)
    path = yolo_model(tmp_path / "y.onnx", pred, input_shape=(1, 3, 96, 96))
    image = np.zeros((60, 140, 3), np.float32)  # letterboxed: 96x41 content, 27 px pad above
    det = Detector(DetectorConfig(model=path))
    got = det(image)
    box, score, cls = ultralytics_postprocess64(pred, (96, 96), (60, 140), 0.25, 0.45, det.selected_ids)
    ib = _outward(box)
    ok = (ib[:, 2] > ib[:, 0]) & (ib[:, 3] > ib[:, 1])  # dynaeval drops boxes empty in the image
    assert len(got) > 20
    np.testing.assert_array_equal(got.boxes, ib[ok])
    np.testing.assert_allclose(got.scores, score[ok], rtol=1e-6)
    np.testing.assert_array_equal(got.class_ids, cls[ok])


def test_equals_ultralytics_itself(tmp_path):
    torch = pytest.importorskip("torch")
    nms_mod = pytest.importorskip("ultralytics.utils.nms")
    ops = pytest.importorskip("ultralytics.utils.ops")
    rng = np.random.default_rng(7)
    pred = _random_pred(rng)
    path = yolo_model(tmp_path / "y.onnx", pred, input_shape=(1, 3, 96, 96))
    det = Detector(DetectorConfig(model=path))
    got = det(np.zeros((60, 140, 3), np.float32))
    (out,) = nms_mod.non_max_suppression(torch.from_numpy(pred.copy()), 0.25, 0.45,
                                         classes=list(det.selected_ids), max_det=300)
    box = ops.scale_boxes((96, 96), out[:, :4].clone(), (60, 140)).double().numpy()
    ib = _outward(box)
    ok = (ib[:, 2] > ib[:, 0]) & (ib[:, 3] > ib[:, 1])
    assert len(got) > 20
    np.testing.assert_array_equal(got.class_ids, out[:, 5].numpy().astype(np.int64)[ok])
    np.testing.assert_allclose(got.scores, out[:, 4].numpy()[ok], rtol=1e-6)
    np.testing.assert_array_equal(got.boxes, ib[ok])  # Ultralytics in float32: equal after rounding


def test_clipping_before_nms_would_lose_boxes(tmp_path):
    """The old order (clip to the image, then NMS) on the same candidates keeps fewer boxes
    (docs/regions.md quotes the counts printed with ``pytest -s -k clipping_before``)."""
    from dynaeval.regions.detector import postprocess

    kept = []
    for seed in (0, 1, 2):
        pred = _random_pred(np.random.default_rng(seed))
        det = Detector(DetectorConfig(model=yolo_model(tmp_path / f"y{seed}.onnx", pred,
                                                       input_shape=(1, 3, 96, 96))))
        image = np.zeros((60, 140, 3), np.float32)
        boxes, scores, cls = det.raw(image)
        boxes[:, [0, 2]] = boxes[:, [0, 2]].clip(0, 140)
        boxes[:, [1, 3]] = boxes[:, [1, 3]].clip(0, 60)
        old = postprocess(boxes, scores, cls, det.config, det.selected_ids, det.class_names, 60, 140)
        kept.append((len(old), len(det(image))))
    print("(clip then NMS, NMS then clip) boxes kept per seed:", kept)
    assert all(old < new for old, new in kept)

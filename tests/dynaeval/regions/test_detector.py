"""ONNX detection end to end on tiny graphs built with ``onnx.helper`` whose outputs are known."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.regions import detector as det_mod
from dynaeval.regions.boxes_file import read_boxes_file, write_boxes_file
from dynaeval.regions.detector import (
    COCO80_NAMES,
    COCO91_NAMES,
    Detector,
    DetectorConfig,
    detect,
    detect_folder,
    file_sha256,
    letterbox,
    postprocess,
)

onnx = pytest.importorskip("onnx")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402

OPSET = [helper.make_opsetid("", 17)]


def _zero_from(input_name: str, nodes: list) -> str:
    """Nodes computing 0 * sum(input): makes constant outputs depend on the input."""
    nodes += [
        helper.make_node("ReduceSum", [input_name], ["_sum"], keepdims=0),
        helper.make_node("Mul", ["_sum", "_zero"], ["_z"]),
    ]
    return "_z"


def save_model(path: Path, graph, names: str | None = None) -> Path:
    model = helper.make_model(graph, opset_imports=OPSET)
    model.ir_version = 8
    if names is not None:
        helper.set_model_props(model, {"names": names})
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


def yolo_model(path: Path, pred: np.ndarray, input_shape=(1, 3, 64, 64), names: str | None = None) -> Path:
    """YOLO-style graph: input ``images`` -> output ``output0`` = ``pred`` (1, 4+C, N)."""
    nodes: list = []
    z = _zero_from("images", nodes)
    nodes.append(helper.make_node("Add", ["pred", z], ["output0"]))
    graph = helper.make_graph(
        nodes,
        "yolo",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, list(input_shape))],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(pred.shape))],
        initializer=[
            numpy_helper.from_array(pred.astype(np.float32), "pred"),
            numpy_helper.from_array(np.zeros((), np.float32), "_zero"),
        ],
    )
    return save_model(path, graph, names)


def tv_model(
    path: Path,
    boxes: np.ndarray,
    scores: np.ndarray,
    labels: np.ndarray,
    input_shape=(3, "H", "W"),
    out_names=("boxes", "scores", "labels"),
    batch: bool = False,
    order=("boxes", "scores", "labels"),
) -> Path:
    """torchvision-style graph: input ``image`` -> boxes (N, 4), scores (N,), labels (N,) int64,
    in ``order`` (Faster R-CNN: boxes, labels, scores), output ``k`` named ``out_names[k]``."""
    b, s, lab = boxes.astype(np.float32), scores.astype(np.float32), labels.astype(np.int64)
    if batch:
        b, s, lab = b[None], s[None], lab[None]
    nodes: list = []
    z = _zero_from("image", nodes)
    made = {"boxes": ("Add", ["c_boxes", z], TensorProto.FLOAT, b.shape),
            "scores": ("Add", ["c_scores", z], TensorProto.FLOAT, s.shape),
            "labels": ("Identity", ["c_labels"], TensorProto.INT64, lab.shape)}
    nodes += [helper.make_node(made[r][0], made[r][1], [n]) for r, n in zip(order, out_names, strict=True)]
    graph = helper.make_graph(
        nodes,
        "tv",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, list(input_shape))],
        [helper.make_tensor_value_info(n, made[r][2], list(made[r][3]))
         for r, n in zip(order, out_names, strict=True)],
        initializer=[
            numpy_helper.from_array(b, "c_boxes"),
            numpy_helper.from_array(s, "c_scores"),
            numpy_helper.from_array(lab, "c_labels"),
            numpy_helper.from_array(np.zeros((), np.float32), "_zero"),
        ],
    )
    return save_model(path, graph)


def yolo_pred(rows: list[tuple[float, float, float, float, int, float]], n_cls: int = 80) -> np.ndarray:
    """(1, 4+C, N) from rows (cx, cy, w, h, class, score); other class scores 0."""
    pred = np.zeros((1, 4 + n_cls, len(rows)), np.float32)
    for j, (cx, cy, w, h, c, s) in enumerate(rows):
        pred[0, :4, j] = cx, cy, w, h
        pred[0, 4 + c, j] = s
    return pred


IMG = np.full((100, 200, 3), 0.5, np.float32)  # H=100, W=200


# ------------------------------------------------------------------------------------------
# class lists


def test_coco_lists_match_torchvision_and_yolo_ids():
    tv_det = pytest.importorskip("torchvision.models.detection")
    cats = tv_det.RetinaNet_ResNet50_FPN_Weights.DEFAULT.meta["categories"]
    assert list(COCO91_NAMES) == list(cats)
    assert len(COCO80_NAMES) == 80
    assert (COCO80_NAMES.index("person"), COCO80_NAMES.index("sports ball")) == (0, 32)
    assert (COCO91_NAMES.index("person"), COCO91_NAMES.index("sports ball")) == (1, 37)


# ------------------------------------------------------------------------------------------
# YOLO convention


def test_yolo_letterbox_mapping_end_to_end(tmp_path):
    # 100x200 image into 64x64: scale 0.32, resized 64x32, pad top 16. Canvas box
    # (cx 32, cy 32, w 32, h 16) = xyxy [16, 24, 48, 40] -> original [50, 25, 150, 75].
    path = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 32, 16, 0, 0.9)]))
    d = detect(IMG, DetectorConfig(model=path))
    assert d.boxes.tolist() == [[50, 25, 150, 75]]
    assert d.classes == ("person",)
    np.testing.assert_allclose(d.scores, [0.9], rtol=1e-6)
    assert d.boxes.dtype == np.int64


def test_yolo_dynamic_input_uses_input_size(tmp_path):
    # Dynamic graph size: config.input_size=128 -> scale 0.64, pad top 32.
    # canvas [32, 48, 96, 80] -> x 32/0.64 = 50, 96/0.64 = 150; y (48-32)/0.64 = 25, (80-32)/0.64 = 75
    path = yolo_model(tmp_path / "y.onnx", yolo_pred([(64, 64, 64, 32, 0, 0.9)]), input_shape=(1, 3, "s", "s"))
    d = detect(IMG, DetectorConfig(model=path, input_size=128))
    assert d.boxes.tolist() == [[50, 25, 150, 75]]


def test_letterbox_moves_pixels_as_documented(rng):
    img = np.zeros((90, 160, 3), np.float32)
    img[40:50, 100:120] = 1.0  # block centre (110, 45) in original pixel-centre coords (x+0.5)
    canvas, (sx, sy), (ox, oy) = letterbox(img, (64, 64))
    assert canvas.shape == (64, 64, 3) and canvas.dtype == np.float32
    assert np.isclose(canvas[0, 0, 0], 114 / 255)  # padding
    ys, xs = np.nonzero(canvas[..., 0] > 0.5)
    np.testing.assert_allclose([xs.mean() + 0.5, ys.mean() + 0.5], [110 * sx + ox, 45 * sy + oy], atol=0.75)


def test_yolo_class_filter_threshold_and_nms(tmp_path):
    rows = [
        (32, 32, 20, 20, 0, 0.90),  # person kept
        (33, 32, 20, 20, 0, 0.80),  # person, IoU ~0.9 with the first -> suppressed
        (33, 32, 20, 20, 32, 0.70),  # sports ball overlapping: other class -> kept
        (10, 10, 6, 6, 2, 0.95),  # car: filtered out
        (50, 40, 8, 8, 0, 0.10),  # below threshold
    ]
    path = yolo_model(tmp_path / "y.onnx", yolo_pred(rows), input_shape=(1, 3, 64, 64))
    img = np.full((64, 64, 3), 0.2, np.float32)  # square: no letterbox padding, scale 1
    d = detect(img, DetectorConfig(model=path, score_threshold=0.25, nms_iou=0.5))
    assert d.classes == ("person", "ball")  # "sports ball" written as "ball"
    assert d.boxes.tolist() == [[22, 22, 42, 42], [23, 22, 43, 42]]
    d_all = detect(img, DetectorConfig(model=path, score_threshold=0.25, nms_iou=1.0))
    assert d_all.classes == ("person", "person", "ball")
    d_ids = detect(img, DetectorConfig(model=path, classes=(2,), score_threshold=0.0))
    assert d_ids.classes == ("car",) and d_ids.boxes.tolist() == [[7, 7, 13, 13]]


def test_yolo_argmax_over_all_classes(tmp_path):
    pred = yolo_pred([(32, 32, 20, 20, 2, 0.9)])
    pred[0, 4 + 0, 0] = 0.6  # person 0.6 but car 0.9 wins the arg-max -> not a person
    path = yolo_model(tmp_path / "y.onnx", pred)
    assert len(detect(np.zeros((64, 64, 3), np.uint8), DetectorConfig(model=path))) == 0


def test_yolo_names_metadata_with_alias(tmp_path):
    # A two-class model (like the shipped one) naming its classes in metadata.
    rows = [(20, 20, 10, 10, 1, 0.8), (40, 40, 10, 20, 0, 0.9)]
    path = yolo_model(tmp_path / "y.onnx", yolo_pred(rows, n_cls=2), names="{0: 'person', 1: 'ball'}")
    d = detect(np.zeros((64, 64, 3), np.uint8), DetectorConfig(model=path))
    assert d.classes == ("person", "ball")
    assert d.records() == [
        {"class": "person", "id": 0, "box": [35, 30, 45, 50], "score": pytest.approx(0.9)},
        {"class": "ball", "id": 1, "box": [15, 15, 25, 25], "score": pytest.approx(0.8)},
    ]


def test_clip_and_outward_rounding(tmp_path):
    rows = [(2.0, 30.0, 10.0, 9.0, 0, 0.9), (60.0, 60.0, 10.0, 10.0, 32, 0.8)]
    path = yolo_model(tmp_path / "y.onnx", yolo_pred(rows))
    d = detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=path))
    # [-3, 25.5, 7, 34.5] -> clip x to 0, floor/ceil y; [55, 55, 65, 65] -> clipped to 64
    assert d.boxes.tolist() == [[0, 25, 7, 35], [55, 55, 64, 64]]


def test_detector_session_is_cached_and_hash_recorded(tmp_path):
    path = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 20, 20, 0, 0.9)]))
    a, b = Detector(DetectorConfig(model=path)), Detector(DetectorConfig(model=path, score_threshold=0.5))
    assert a.session is b.session
    assert a.convention == "yolo"
    src = a.source()
    assert src["model_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert src["settings"]["score_threshold"] == 0.25


def test_detect_folder_roundtrips_through_boxes_file(tmp_path):
    path = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 20, 20, 0, 0.9)]))
    frames = [("cam00/000000", np.zeros((64, 64, 3), np.uint8)), ("cam01/000000", np.zeros((64, 64, 3), np.uint8))]
    mapping, source = detect_folder(frames, DetectorConfig(model=path))
    assert set(mapping) == {"cam00/000000", "cam01/000000"}
    out = write_boxes_file(tmp_path / "boxes.json", mapping, source)
    back = read_boxes_file(out)
    assert back.boxes["cam00/000000"][0]["box"] == [22, 22, 42, 42]
    assert back.source["model_sha256"] == file_sha256(path)


# ------------------------------------------------------------------------------------------
# torchvision convention


def test_torchvision_native_size(tmp_path):
    boxes = np.array([[10.2, 5.0, 20.0, 15.7], [100, 50, 150, 90], [0, 0, 5, 5]], np.float32)
    path = tv_model(tmp_path / "t.onnx", boxes, np.array([0.9, 0.8, 0.95]), np.array([1, 37, 3]))
    d = detect(IMG, DetectorConfig(model=path))
    assert d.classes == ("person", "ball")
    assert d.boxes.tolist() == [[10, 5, 20, 16], [100, 50, 150, 90]]


def test_torchvision_fixed_input_size_scales_back(tmp_path):
    boxes = np.array([[10, 5, 20, 15]], np.float32)
    path = tv_model(tmp_path / "t.onnx", boxes, np.array([0.9]), np.array([1]), input_shape=(3, 32, 48))
    d = detect(np.zeros((64, 96, 3), np.float32), DetectorConfig(model=path))
    assert d.boxes.tolist() == [[20, 10, 40, 30]]


def test_torchvision_input_size_resizes_longer_side(tmp_path):
    # 100x200 image, input_size 50: fed at 25x50, boxes in fed pixels scaled back by 4
    path = tv_model(tmp_path / "t.onnx", np.array([[5, 2, 10, 6]], np.float32), np.array([0.9]), np.array([1]))
    d = detect(IMG, DetectorConfig(model=path, input_size=50))
    assert d.boxes.tolist() == [[20, 8, 40, 24]]


def test_uint8_input_graph_is_fed_uint8(tmp_path):
    nodes = [
        helper.make_node("Cast", ["images"], ["f"], to=TensorProto.FLOAT),
        helper.make_node("ReduceMax", ["f"], ["m"], keepdims=0),
        helper.make_node("Mul", ["m", "unit"], ["score"]),  # score = max pixel value / 255
        helper.make_node("Reshape", ["score", "one"], ["score11"]),
        helper.make_node("Concat", ["geom", "score11"], ["col"], axis=1),
        helper.make_node("Reshape", ["col", "shape"], ["output0"]),
    ]
    graph = helper.make_graph(
        nodes,
        "yolo_u8",
        [helper.make_tensor_value_info("images", TensorProto.UINT8, [1, 3, 64, 64])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, [1, 5, 1])],
        initializer=[
            numpy_helper.from_array(np.array(1 / 255, np.float32), "unit"),
            numpy_helper.from_array(np.array([1, 1], np.int64), "one"),
            numpy_helper.from_array(np.array([[32, 32, 10, 10]], np.float32), "geom"),
            numpy_helper.from_array(np.array([1, 5, 1], np.int64), "shape"),
        ],
    )
    path = save_model(tmp_path / "u8.onnx", graph, names="['person']")
    img = np.zeros((64, 64, 3), np.float32)
    img[0, 0, 0] = 0.6  # fed as round(0.6 * 255) = 153 -> score 0.6
    d = detect(img, DetectorConfig(model=path, classes=("person",)))
    np.testing.assert_allclose(d.scores, [153 / 255], rtol=1e-6)
    assert d.boxes.tolist() == [[27, 27, 37, 37]]


@pytest.mark.parametrize("batch", [False, True])
def test_torchvision_outputs_matched_by_type_when_names_say_nothing(tmp_path, batch):
    boxes = np.array([[1, 2, 11, 12], [3, 3, 9, 9]], np.float32)
    path = tv_model(
        tmp_path / "t.onnx",
        boxes,
        np.array([0.9, 0.3]),
        np.array([1, 1]),
        input_shape=(1, 3, "H", "W") if batch else (3, "H", "W"),
        out_names=("out_a", "out_b", "out_c"),
        batch=batch,
    )
    d = detect(np.zeros((32, 32, 3), np.float32), DetectorConfig(model=path, convention="torchvision"))
    assert d.boxes.tolist() == [[1, 2, 11, 12], [3, 3, 9, 9]]
    np.testing.assert_allclose(d.scores, [0.9, 0.3], rtol=1e-6)


def test_torchvision_empty_output(tmp_path):
    path = tv_model(tmp_path / "t.onnx", np.zeros((0, 4)), np.zeros(0), np.zeros(0, np.int64))
    d = detect(IMG, DetectorConfig(model=path))
    assert len(d) == 0 and d.boxes.shape == (0, 4)


# ------------------------------------------------------------------------------------------
# NMS against torchvision as oracle

def test_postprocess_max_detections_keeps_best():
    b = np.array([[0, 0, 5, 5], [10, 10, 15, 15], [20, 20, 25, 25]], float)
    cfg = DetectorConfig(max_detections=2)
    d = postprocess(b, np.array([0.5, 0.9, 0.7]), np.array([0, 0, 0]), cfg, [0], {0: "person"}, 30, 30)
    assert d.boxes.tolist() == [[10, 10, 15, 15], [20, 20, 25, 25]]


# ------------------------------------------------------------------------------------------
# errors


def test_missing_model(tmp_path):
    with pytest.raises(InputError, match="detector model not found"):
        Detector(DetectorConfig(model=tmp_path / "nope.onnx"))


def test_missing_default_detector(tmp_path, monkeypatch):
    monkeypatch.setattr(det_mod, "DEFAULT_DETECTOR", tmp_path / "detector.onnx")
    with pytest.raises(InputError, match="no default detector.*--detector FILE.onnx"):
        detect(IMG)


def test_invalid_onnx_file(tmp_path):
    p = tmp_path / "bad.onnx"
    p.write_bytes(b"this is not a protobuf")
    with pytest.raises(InputError, match="not a valid ONNX model"):
        Detector(DetectorConfig(model=p))


def test_outputs_in_neither_convention(tmp_path):
    nodes: list = []
    z = _zero_from("image", nodes)
    nodes += [helper.make_node("Add", ["c", z], ["a"]), helper.make_node("Add", ["c", z], ["b"])]
    graph = helper.make_graph(
        nodes,
        "two",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 8, 8])],
        [helper.make_tensor_value_info(n, TensorProto.FLOAT, [2, 4]) for n in ("a", "b")],
        initializer=[numpy_helper.from_array(np.zeros((2, 4), np.float32), "c"),
                     numpy_helper.from_array(np.zeros((), np.float32), "_zero")],
    )
    p = save_model(tmp_path / "two.onnx", graph)
    with pytest.raises(InputError, match="fit neither convention"):
        Detector(DetectorConfig(model=p))


def test_convention_asked_does_not_fit(tmp_path):
    p = tv_model(tmp_path / "t.onnx", np.zeros((1, 4)), np.zeros(1), np.ones(1, np.int64))
    with pytest.raises(InputError, match="asked for 'yolo'"):
        Detector(DetectorConfig(model=p, convention="yolo"))


def test_yolo_output_too_few_rows(tmp_path):
    p = yolo_model(tmp_path / "y.onnx", np.zeros((1, 4, 5), np.float32), names="['person']")
    with pytest.raises(InputError, match=r"\(1, 4\+C, N\)"):
        detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=p, classes=("person",)))


def test_yolo_class_count_mismatch(tmp_path):
    # Names metadata lists 80 classes, the output has 2: COCO ids 32 can never be predicted.
    names = repr(dict(enumerate(COCO80_NAMES)))
    p = yolo_model(tmp_path / "y.onnx", yolo_pred([(3, 3, 2, 2, 0, 0.9)], n_cls=2), names=names)
    with pytest.raises(InputError, match=r"predicts 2 classes .* class ids \[32\] were selected"):
        detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=p))


def test_yolo_without_names_and_not_coco_selects_by_id_only(tmp_path):
    p = yolo_model(tmp_path / "y.onnx", yolo_pred([(32, 32, 10, 10, 1, 0.9)], n_cls=2))
    with pytest.raises(InputError, match="has no 'names' metadata and is not a COCO model"):
        Detector(DetectorConfig(model=p))
    d = detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=p, classes=(1,)))
    assert d.classes == ("1",) and d.boxes.tolist() == [[27, 27, 37, 37]]
    named = detect(np.zeros((64, 64, 3), np.float32), DetectorConfig(model=p, class_names=("person", "ball")))
    assert named.classes == ("ball",)


def test_unknown_class_name(tmp_path):
    p = yolo_model(tmp_path / "y.onnx", yolo_pred([(3, 3, 2, 2, 0, 0.9)]))
    with pytest.raises(InputError, match="'referee' is not among"):
        Detector(DetectorConfig(model=p, classes=("person", "referee")))


def test_torchvision_outputs_disagree(tmp_path):
    p = tv_model(tmp_path / "t.onnx", np.zeros((3, 4)), np.zeros(2), np.ones(2, np.int64))
    with pytest.raises(InputError, match="outputs disagree"):
        detect(IMG, DetectorConfig(model=p))


def test_torchvision_outputs_unidentifiable(tmp_path):
    # Float labels and names that say nothing: cannot tell scores from labels.
    nodes: list = []
    z = _zero_from("image", nodes)
    nodes += [helper.make_node("Add", [c, z], [o]) for c, o in (("cb", "o1"), ("cs", "o2"), ("cl", "o3"))]
    graph = helper.make_graph(
        nodes,
        "anon",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, [3, "H", "W"])],
        [helper.make_tensor_value_info("o1", TensorProto.FLOAT, [2, 4]),
         helper.make_tensor_value_info("o2", TensorProto.FLOAT, [2]),
         helper.make_tensor_value_info("o3", TensorProto.FLOAT, [2])],
        initializer=[numpy_helper.from_array(np.zeros((2, 4), np.float32), "cb"),
                     numpy_helper.from_array(np.zeros(2, np.float32), "cs"),
                     numpy_helper.from_array(np.ones(2, np.float32), "cl"),
                     numpy_helper.from_array(np.zeros((), np.float32), "_zero")],
    )
    p = save_model(tmp_path / "anon.onnx", graph)
    with pytest.raises(InputError, match="cannot find torchvision-style outputs"):
        detect(IMG, DetectorConfig(model=p))


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((10, 10, 2), np.float32), r"\(H, W, 3\) RGB"),
        (np.full((10, 10, 3), 2.0, np.float32), r"must be in \[0, 1\]"),
        (np.full((10, 10, 3), np.nan, np.float32), "NaN"),
        (np.zeros((10, 10, 3), np.int32), "uint8 or float"),
    ],
)
def test_bad_images(tmp_path, image, match):
    p = yolo_model(tmp_path / "y.onnx", yolo_pred([(3, 3, 2, 2, 0, 0.9)]))
    with pytest.raises(InputError, match=match):
        detect(image, DetectorConfig(model=p))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"convention": "detr"}, "convention must be one of"),
        ({"device": "tpu"}, "device must be"),
        ({"score_threshold": 1.5}, "score_threshold"),
        ({"nms_iou": -0.1}, "nms_iou"),
        ({"input_size": 8}, "input_size"),
        ({"max_detections": 0}, "max_detections"),
        ({"classes": ()}, "classes is empty"),
    ],
)
def test_bad_config(kwargs, match):
    with pytest.raises(InputError, match=match):
        DetectorConfig(**kwargs)


# ------------------------------------------------------------------------------------------
# a real torchvision export (random weights: no network here), against the torch model itself


@pytest.mark.slow
def test_exported_torchvision_retinanet_matches_torch(tmp_path):
    torch = pytest.importorskip("torch")
    tvd = pytest.importorskip("torchvision.models.detection")
    torch.manual_seed(0)
    model = tvd.retinanet_resnet50_fpn(
        weights=None, weights_backbone=None, min_size=160, max_size=160, score_thresh=0.0, detections_per_img=50
    ).eval()
    x = torch.rand(3, 90, 160)
    path = tmp_path / "retinanet.onnx"
    torch.onnx.export(
        model, ([x],), str(path), opset_version=17, dynamo=False,
        input_names=["image"], output_names=["boxes", "scores", "labels"],
        dynamic_axes={"image": {1: "height", 2: "width"}, "boxes": {0: "n"}, "scores": {0: "n"}, "labels": {0: "n"}},
    )
    with torch.no_grad():
        ref = model([x])[0]
    image = x.permute(1, 2, 0).numpy()
    det = Detector(DetectorConfig(model=path, classes=tuple(range(91)), score_threshold=0.0, nms_iou=1.0))
    assert det.convention == "torchvision"
    boxes, scores, labels = det.raw(image)
    np.testing.assert_allclose(boxes, ref["boxes"].numpy(), rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(scores, ref["scores"].numpy(), rtol=1e-4, atol=1e-5)
    np.testing.assert_array_equal(labels, ref["labels"].numpy())


@pytest.mark.parametrize("grey", [np.full((10, 10), 0.5, np.float32),
                                  np.full((10, 10, 1), 128, np.uint8)])
def test_grayscale_is_fed_as_grey_rgb(tmp_path, grey):
    """Issue 16 item 10: a grey frame under the default detector focus is scored, not refused;
    the detector sees what it sees of the grey replicated to RGB."""
    p = yolo_model(tmp_path / "y.onnx", yolo_pred([(3, 3, 2, 2, 0, 0.9)]))
    rgb = np.repeat(grey.reshape(10, 10, 1), 3, axis=2)
    det = Detector(DetectorConfig(model=p))
    got, want = det(grey), det(rgb)
    np.testing.assert_array_equal(got.boxes, want.boxes)
    assert len(got) == 1


@pytest.mark.parametrize("batch", [False, True])
@pytest.mark.parametrize("order", [("boxes", "scores", "labels"), ("boxes", "labels", "scores")])
def test_torchvision_both_output_orders_named_retinanet_style(tmp_path, order, batch):
    """RetinaNet returns boxes, scores, labels; Faster R-CNN boxes, labels, scores. Exported with
    the names ``boxes, scores, labels`` (the old recipe), Faster R-CNN's labels are called
    "scores": the dtypes decide, and the source says which output was taken as what."""
    boxes = np.array([[1, 2, 11, 12], [3, 3, 9, 9]], np.float32)
    path = tv_model(tmp_path / "t.onnx", boxes, np.array([0.9, 0.3]), np.array([1, 37]),
                    order=order, batch=batch, input_shape=(1, 3, "H", "W") if batch else (3, "H", "W"))
    det = Detector(DetectorConfig(model=path))
    d = det(np.zeros((32, 32, 3), np.float32))
    assert d.boxes.tolist() == [[1, 2, 11, 12], [3, 3, 9, 9]] and d.classes == ("person", "ball")
    np.testing.assert_allclose(d.scores, [0.9, 0.3], rtol=1e-6)
    src = det.source()
    if order[1] == "scores":
        assert src["outputs"] == {"boxes": "boxes", "scores": "scores", "labels": "labels"}
        assert "outputs_note" not in src
    else:
        assert src["outputs"] == {"boxes": "boxes", "scores": "labels", "labels": "scores"}
        assert "took 'boxes' (tensor(float)) as boxes, 'labels' (tensor(float)) as scores, " \
               "'scores' (tensor(int64)) as labels" in src["outputs_note"]


@pytest.mark.slow
def test_exported_faster_rcnn_read_right_under_either_naming(tmp_path):
    """Faster R-CNN returns boxes, labels, scores. The recipe of docs/regions.md names the
    outputs in the model's own order; the old recipe named them boxes, scores, labels (RetinaNet's),
    which failed with "labels must be integer class ids": now the dtypes decide, with a note.
    Both files give the graph's own outputs in the model's order. (Against the torch model only
    the count: with random weights many scores tie and the exported RPN keeps other proposals.)"""
    torch = pytest.importorskip("torch")
    tvd = pytest.importorskip("torchvision.models.detection")
    torch.manual_seed(0)
    model = tvd.fasterrcnn_mobilenet_v3_large_320_fpn(
        weights=None, weights_backbone=None, box_score_thresh=0.0, box_detections_per_img=50).eval()
    x = torch.rand(3, 90, 160)
    with torch.no_grad():
        ref = model([x])[0]
    assert list(ref) == ["boxes", "labels", "scores"]
    image = x.permute(1, 2, 0).numpy()
    got = {}
    for label, names in (("own", list(ref)), ("retinanet", ["boxes", "scores", "labels"])):
        path = tmp_path / f"frcnn-{label}.onnx"
        torch.onnx.export(model, ([x],), str(path), opset_version=17, dynamo=False,
                          input_names=["image"], output_names=names,
                          dynamic_axes={"image": {1: "height", 2: "width"}, **{n: {0: "n"} for n in names}})
        det = Detector(DetectorConfig(model=path, classes=tuple(range(91)), score_threshold=0.0, nms_iou=1.0))
        assert det.convention == "torchvision" and (det.outputs_note is None) == (label == "own")
        graph = det.session.run(None, {"image": x.numpy()})  # positions: boxes, labels, scores
        got[label] = det.raw(image)
        np.testing.assert_array_equal(got[label][0], graph[0])
        np.testing.assert_array_equal(got[label][1], graph[2])
        np.testing.assert_array_equal(got[label][2], graph[1])
        assert len(got[label][0]) == len(ref["boxes"]) > 0
    for a, b in zip(got["own"], got["retinanet"], strict=True):
        np.testing.assert_array_equal(a, b)

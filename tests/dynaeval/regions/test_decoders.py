"""The output decoders on hand-made arrays (no ONNX model): one module per convention."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.regions import torchvision_onnx, yolo
from dynaeval.regions.detector import DECODERS

TV_ROLES = {"boxes": 0, "scores": 1, "labels": 2}


def _info(shape, name="out", type="tensor(float)"):
    return SimpleNamespace(shape=shape, name=name, type=type)


@pytest.mark.parametrize("module", list(DECODERS.values()))
def test_every_decoder_offers_the_interface(module):
    for name in ("fits", "default_names", "output_roles", "prepare", "decode", "to_image", "n_classes"):
        assert callable(getattr(module, name))


def test_fits_tells_the_conventions_apart():
    one_3d = [_info([1, 84, "N"])]
    three = [_info(["N", 4]), _info(["N"]), _info(["N"])]
    assert yolo.fits(one_3d) and not yolo.fits(three)
    assert torchvision_onnx.fits(three) and not torchvision_onnx.fits(one_3d)
    assert yolo.default_names([_info([1, 6, "N"])]) == {}  # 2 classes, not COCO
    assert yolo.default_names(one_3d)[32] == "sports ball"
    assert torchvision_onnx.default_names(three)[37] == "sports ball"


def test_yolo_decode_maps_back_through_the_letterbox():
    img = np.zeros((100, 200, 3), np.float32)
    canvas, geometry = yolo.prepare(img, (64, 64), None)
    assert canvas.shape == (64, 64, 3)
    out = np.zeros((1, 6, 1), np.float32)
    out[0, :, 0] = [32, 32, 32, 16, 0.2, 0.9]  # canvas xyxy [16, 24, 48, 40]
    boxes, scores, cls = yolo.decode([out], {"output": 0})
    np.testing.assert_allclose(boxes, [[16, 24, 48, 40]])  # input (letterbox) pixels
    np.testing.assert_allclose(yolo.to_image(boxes, geometry), [[50, 25, 150, 75]])
    assert scores.tolist() == pytest.approx([0.9]) and cls.tolist() == [1]
    assert yolo.n_classes([out]) == 2
    with pytest.raises(InputError, match=r"YOLO-style output must be \(1, 4\+C, N\), got \(1, 4, 1\)"):
        yolo.decode([out[:, :4]], {"output": 0})


def test_torchvision_decode_by_name_and_by_type_and_scaled_back():
    img = np.zeros((50, 100, 3), np.float32)
    fed, geometry = torchvision_onnx.prepare(img, (None, None), 200)
    assert fed.shape == (100, 200, 3)
    outs = [np.array([[0.5]], np.float32), np.array([[[20, 10, 40, 30]]], np.float32), np.array([[7]], np.int64)]
    boxes, scores, labels = torchvision_onnx.decode(outs, {"scores": 0, "boxes": 1, "labels": 2})
    np.testing.assert_allclose(torchvision_onnx.to_image(boxes, geometry), [[10, 5, 20, 15]])
    assert scores.tolist() == [0.5] and labels.tolist() == [7]
    again = torchvision_onnx.decode(outs, None)  # matched by dtype and shape
    np.testing.assert_array_equal(again[0], boxes)
    assert torchvision_onnx.n_classes(outs) is None


def test_torchvision_decode_errors():
    f = np.zeros((2,), np.float32)
    with pytest.raises(InputError, match="cannot find torchvision-style outputs"):
        torchvision_onnx.decode([f, f, f], None)
    outs = [np.zeros((2, 4), np.float32), np.zeros(3, np.float32), np.zeros(2, np.int64)]
    with pytest.raises(InputError, match=r"outputs disagree: boxes \(2, 4\), scores \(3,\)"):
        torchvision_onnx.decode(outs, TV_ROLES)
    outs = [np.zeros((1, 4), np.float32), np.zeros(1, np.float32), np.full(1, 0.5, np.float32)]
    with pytest.raises(InputError, match="labels must be integer class ids"):
        torchvision_onnx.decode(outs, TV_ROLES)


FLOAT, INT = "tensor(float)", "tensor(int64)"


@pytest.mark.parametrize("batch", [False, True])
def test_torchvision_roles_by_name_when_names_and_dtypes_agree(batch):
    lead = [1] if batch else []
    outs = [_info([*lead, "N", 4], "boxes"), _info([*lead, "N"], "labels", INT), _info([*lead, "N"], "scores")]
    assert torchvision_onnx.output_roles(outs) == ({"boxes": 0, "scores": 2, "labels": 1}, None)
    # labels exported as float (no integer output at all): the names decide, no note
    outs[1] = _info([*lead, "N"], "labels")
    assert torchvision_onnx.output_roles(outs) == ({"boxes": 0, "scores": 2, "labels": 1}, None)


@pytest.mark.parametrize("batch", [False, True])
def test_torchvision_roles_by_dtype_when_names_disagree(batch):
    # Faster R-CNN returns boxes, labels, scores; exported with RetinaNet's names in RetinaNet's
    # order, its int64 labels are called "scores" and its float scores "labels"
    lead = [1] if batch else []
    outs = [_info([*lead, "N", 4], "boxes"), _info([*lead, "N"], "scores", INT), _info([*lead, "N"], "labels")]
    roles, note = torchvision_onnx.output_roles(outs)
    assert roles == {"boxes": 0, "scores": 2, "labels": 1}
    assert "'scores' (tensor(int64)) as labels" in note and "'labels' (tensor(float)) as scores" in note
    # boxes named "scores": the 4-column float output is the boxes
    outs = [_info([*lead, "N"], "boxes"), _info([*lead, "N", 4], "scores"), _info([*lead, "N"], "labels", INT)]
    assert torchvision_onnx.output_roles(outs)[0] == {"boxes": 1, "scores": 0, "labels": 2}


def test_torchvision_roles_undecided_from_the_graph():
    outs = [_info(["N"], "a"), _info(["N"], "b"), _info(["N"], "c")]
    assert torchvision_onnx.output_roles(outs) == (None, None)

"""The network's decoding into the YOLO convention, and the ONNX export read by the runtime."""

import numpy as np
import pytest
import torch

from dynaeval.regions.detector import Detector, DetectorConfig, _parse_names
from reference_models.detector.model import (
    CLASS_NAMES,
    INPUT_SIZE,
    STRIDE,
    CenterNetSmall,
    Decoded,
    count_parameters,
    export_onnx,
    widen_heads,
)


class _Fixed(torch.nn.Module):
    """Stands in for the network: returns given raw maps."""

    def __init__(self, heat, size, offset):
        super().__init__()
        self.maps = (heat, size, offset)

    def forward(self, x):
        return self.maps


def test_decoded_reads_cell_offset_size_and_keeps_only_peaks():
    g = 8
    heat = torch.full((1, 2, g, g), -10.0)
    heat[0, 0, 3, 5] = 2.0  # a person peak at row 3, col 5
    heat[0, 0, 3, 6] = 1.0  # its weaker neighbour: suppressed (not a 3x3 maximum)
    heat[0, 1, 6, 1] = 0.0  # a ball at row 6, col 1 with score 0.5
    heat[0, 1, 3, 5] = 1.0  # and a ball on the person's centre cell (in front of the body)
    size = torch.zeros(1, 4, g, g)
    size[0, 0:2, 3, 5] = torch.tensor([np.log(2.0), np.log(5.0)])  # person: 8 x 20 px
    offset = torch.zeros(1, 4, g, g)  # sigmoid(0) = 0.5: the cell centre
    offset[0, 3, 3, 5] = 20.0  # the ball's y offset: sigmoid -> 1
    out = Decoded(_Fixed(heat, size, offset))(torch.zeros(1, 3, g * STRIDE, g * STRIDE))
    assert out.shape == (1, 6, 2 * g * g)
    person = out[0, :, 3 * g + 5]
    np.testing.assert_allclose(person.numpy(), [5.5 * STRIDE, 3.5 * STRIDE, 2 * STRIDE, 5 * STRIDE,
                                                1 / (1 + np.exp(-2.0)), 0.0], rtol=1e-6)
    assert float(out[0, 4, 3 * g + 6]) == 0.0
    ball = out[0, :, g * g + 3 * g + 5]  # same cell, its own candidate, box and score
    np.testing.assert_allclose(ball.numpy(), [5.5 * STRIDE, 4 * STRIDE, STRIDE, STRIDE, 0.0,
                                              1 / (1 + np.exp(-1.0))], rtol=1e-6)
    np.testing.assert_allclose(float(out[0, 5, g * g + 6 * g + 1]), 0.5, rtol=1e-6)
    assert int((out[0, 4:] > 0.01).sum()) == 3


def test_shared_head_checkpoint_widens_to_per_class_heads():
    old = CenterNetSmall().state_dict()
    old["size.weight"], old["size.bias"] = old["size.weight"][:2], old["size.bias"][:2]
    new = widen_heads(old)
    assert new["size.weight"].shape == (4, *old["size.weight"].shape[1:])
    assert torch.equal(new["size.weight"][2:], old["size.weight"])
    CenterNetSmall().load_state_dict(new)  # loads without a shape error


def test_network_shapes_and_size():
    net = CenterNetSmall().eval()
    heat, size, offset = net(torch.zeros(1, 3, 64, 96))
    assert heat.shape == (1, len(CLASS_NAMES), 16, 24) and size.shape == offset.shape == (1, 4, 16, 24)
    assert 100_000 < count_parameters(net) < 750_000  # a few hundred K: a file of ~1.5 MB


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    torch.manual_seed(0)
    net = CenterNetSmall().eval()
    for m in net.modules():  # non-trivial batch-norm statistics, so folding them is exercised
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.1, 0.1)
            m.running_var.uniform_(0.5, 1.5)
    path = tmp_path_factory.mktemp("onnx") / "det.onnx"
    export_onnx(net, path, {"trained_by": "test"})
    return net, path


def test_export_matches_torch_and_carries_names(exported):
    import onnxruntime as ort

    net, path = exported
    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    (inp,) = sess.get_inputs()
    assert inp.shape == [1, 3, INPUT_SIZE, INPUT_SIZE]
    x = np.random.default_rng(0).random((1, 3, INPUT_SIZE, INPUT_SIZE), dtype=np.float32)
    (got,) = sess.run(None, {inp.name: x})
    with torch.no_grad():
        want = Decoded(net)(torch.from_numpy(x)).numpy()
    assert got.shape == (1, 6, 2 * (INPUT_SIZE // STRIDE) ** 2)
    np.testing.assert_allclose(got[0, :4], want[0, :4], rtol=1e-4, atol=1e-3)  # px
    both = (got[0, 4:] > 0) & (want[0, 4:] > 0)
    np.testing.assert_allclose(got[0, 4:][both], want[0, 4:][both], rtol=1e-4, atol=1e-5)
    # an untrained net's heat map is nearly flat: a few 3x3 peaks flip on float ties, no more
    assert ((got[0, 4:] > 0) != (want[0, 4:] > 0)).mean() < 0.005
    meta = sess.get_modelmeta().custom_metadata_map
    assert _parse_names(meta["names"]) == {0: "person", 1: "ball"}
    assert meta["trained_by"] == "test"


def test_runtime_reads_export_as_yolo_and_selects_both_classes(exported):
    _, path = exported
    det = Detector(DetectorConfig(model=path))  # default classes: person, sports ball (-> ball)
    assert det.convention == "yolo"
    assert det.selected_ids == (0, 1)
    out = det(np.zeros((36, 64, 3), dtype=np.uint8))
    assert out.boxes.shape[1] == 4


def test_fp16_weights_halve_the_file_and_agree(exported, tmp_path):
    import onnxruntime as ort

    net, path = exported
    half = tmp_path / "half.onnx"
    export_onnx(net, half, fp16=True)
    assert half.stat().st_size < 0.6 * path.stat().st_size
    x = np.random.default_rng(1).random((1, 3, INPUT_SIZE, INPUT_SIZE), dtype=np.float32)
    outs = []
    for p in (path, half):
        sess = ort.InferenceSession(str(p), providers=["CPUExecutionProvider"])
        outs.append(sess.run(None, {"images": x})[0])
    np.testing.assert_allclose(outs[1][0, :4], outs[0][0, :4], rtol=2e-2, atol=0.5)  # px

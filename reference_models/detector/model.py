"""A small anchor-free (CenterNet-style) detector for person and ball, and its ONNX export.

Network: a plain conv backbone down to stride 32 (ReLU, batch norm), a top-down path (FPN-like)
back to stride 4, and one head at stride 4 predicting per cell and per class: a heat-map logit,
the box size ``log(w / 4), log(h / 4)`` and the sub-cell centre offset in [0, 1] (sigmoid). Stride 4
keeps a ball of 4-8 input px on its own cell; sizes and offsets per class let a ball in front of a
player's body share the player's centre cell without taking over its box.

``Decoded`` (the exported graph) turns the raw maps into the YOLO convention the runtime decodes:
one output ``(1, 4 + C, N)`` with ``N = C * (H / 4) * (W / 4)`` candidates (class 0's cells, then
class 1's), rows ``cx, cy, w, h`` in input pixels then the C class scores in [0, 1], of which only
the candidate's own class is non-zero (so the runtime's arg-max over classes never hides one class
behind another at the same cell). Scores are zero except at 3 x 3 local maxima of each class map
(CenterNet's peak extraction), so the runtime's NMS sees about one candidate per object.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

CLASS_NAMES = ("person", "ball")
"""Class id -> name; written to the ONNX ``names`` metadata."""
STRIDE = 4
"""Output stride of the head (input px per cell)."""
INPUT_SIZE = 416
"""Letterbox side in px: the exported graph's input is fixed to ``(1, 3, 416, 416)``, so the runtime
letterboxes every image to it (a ball 1.4 % of the image width, as in the broadcast views, is then
~6 px)."""


def _conv(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout),
                         nn.ReLU(inplace=True))


class CenterNetSmall(nn.Module):
    """Backbone widths ``(12, 16, 32, 64, 96)`` at strides 2..32, 16 channels at the head.

    ``forward(x)``: ``x`` ``(B, 3, H, W)`` float32 RGB in [0, 1] (H, W multiples of 32 for
    training; any size for inference) -> ``(heat_logits (B, C, H/4, W/4), size (B, 2C, ...),
    offset_logits (B, 2C, ...))``; channels ``2k, 2k + 1`` of size and offset are class k's x, y.
    """

    def __init__(self, widths: tuple[int, ...] = (12, 16, 32, 64, 96), head: int = 16) -> None:
        super().__init__()
        w1, w2, w3, w4, w5 = widths
        self.s2 = _conv(3, w1, 2)
        self.s4 = nn.Sequential(_conv(w1, w2, 2), _conv(w2, w2))
        self.s8 = nn.Sequential(_conv(w2, w3, 2), _conv(w3, w3))
        self.s16 = nn.Sequential(_conv(w3, w4, 2), _conv(w4, w4))
        self.s32 = nn.Sequential(_conv(w4, w5, 2), _conv(w5, w5), _conv(w5, w5))
        self.lat16 = nn.Conv2d(w4, w5, 1)
        self.fuse16 = _conv(w5, w4)
        self.lat8 = nn.Conv2d(w3, w4, 1)
        self.fuse8 = _conv(w4, w3)
        self.lat4 = nn.Conv2d(w2, w3, 1)
        self.fuse4 = _conv(w3, head)
        self.head = _conv(head, head)
        self.heat = nn.Conv2d(head, len(CLASS_NAMES), 1)
        self.size = nn.Conv2d(head, 2 * len(CLASS_NAMES), 1)
        self.offset = nn.Conv2d(head, 2 * len(CLASS_NAMES), 1)
        nn.init.constant_(self.heat.bias, -4.6)  # prior 0.01 (focal-loss init)

    @staticmethod
    def _up(x: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
        return F.interpolate(x, size=like.shape[-2:], mode="nearest")

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        c4 = self.s4(self.s2(x))
        c8 = self.s8(c4)
        c16 = self.s16(c8)
        c32 = self.s32(c16)
        p16 = self.fuse16(self._up(c32, c16) + self.lat16(c16))
        p8 = self.fuse8(self._up(p16, c8) + self.lat8(c8))
        p4 = self.fuse4(self._up(p8, c4) + self.lat4(c4))
        h = self.head(p4)
        return self.heat(h), self.size(h), self.offset(h)


class Decoded(nn.Module):
    """Wraps a trained ``CenterNetSmall`` into the YOLO output convention (see module docstring)."""

    def __init__(self, net: CenterNetSmall) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        heat, size, offset = self.net(x)
        prob = torch.sigmoid(heat)
        peak = F.max_pool2d(prob, 3, stride=1, padding=1)
        prob = prob * (prob >= peak).to(prob.dtype)
        b, n_cls, gh, gw = prob.shape
        ys = torch.arange(gh, dtype=x.dtype).view(1, 1, gh, 1).expand(b, 1, gh, gw)
        xs = torch.arange(gw, dtype=x.dtype).view(1, 1, 1, gw).expand(b, 1, gh, gw)
        off = torch.sigmoid(offset)
        wh = torch.exp(size.clamp(-4.0, 6.0)) * STRIDE
        per_class = []
        for k in range(n_cls):
            cx = (xs + off[:, 2 * k : 2 * k + 1]) * STRIDE
            cy = (ys + off[:, 2 * k + 1 : 2 * k + 2]) * STRIDE
            scores = [prob[:, k : k + 1] if j == k else torch.zeros_like(cx) for j in range(n_cls)]
            per_class.append(torch.cat([cx, cy, wh[:, 2 * k : 2 * k + 2], *scores], dim=1).flatten(2))
        return torch.cat(per_class, dim=2)


def widen_heads(state: dict) -> dict:
    """A checkpoint whose size / offset heads are shared by the classes (2 output channels) made
    loadable into the per-class heads (2C channels) by copying the shared head to every class."""
    out = dict(state)
    for name in ("size.weight", "size.bias", "offset.weight", "offset.bias"):
        if name in out and out[name].shape[0] == 2:
            out[name] = out[name].repeat(len(CLASS_NAMES), *([1] * (out[name].dim() - 1)))
    return out


def count_parameters(net: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)


def export_onnx(net: CenterNetSmall, path, metadata: dict[str, str] | None = None, fp16: bool = False) -> None:
    """Write the YOLO-convention graph (input ``images`` ``(1, 3, 416, 416)`` float32 RGB in [0, 1];
    output ``output0`` ``(1, 6, N)``, N = 2 * 104 * 104) with ``names`` metadata ``{0: 'person', 1: 'ball'}``.

    ``fp16`` stores the weights as float16 (half the file) with float32 compute kept by casting
    them back inside the graph.
    """
    import io

    import onnx

    net = net.eval()
    model = Decoded(net).eval()
    dummy = torch.zeros(1, 3, INPUT_SIZE, INPUT_SIZE)
    buf = io.BytesIO()
    with torch.no_grad():
        torch.onnx.export(model, (dummy,), buf, input_names=["images"], output_names=["output0"], opset_version=17, do_constant_folding=True, dynamo=False)
    proto = onnx.load_from_string(buf.getvalue())
    if fp16:
        proto = _weights_to_fp16(proto)
    meta = {"names": str(dict(enumerate(CLASS_NAMES))), "stride": str(STRIDE),
            "imgsz": str([INPUT_SIZE, INPUT_SIZE]), **(metadata or {})}
    del proto.metadata_props[:]
    for k, v in meta.items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = k, str(v)
    onnx.checker.check_model(proto)
    onnx.save(proto, str(path))


def _weights_to_fp16(proto):
    """Store float32 initialisers with more than 16 values as float16 + a Cast back to float32."""
    import numpy as np
    import onnx
    from onnx import helper, numpy_helper

    graph = proto.graph
    new_inits, casts = [], []
    for init in graph.initializer:
        arr = numpy_helper.to_array(init)
        if arr.dtype == np.float32 and arr.size > 16:
            half = numpy_helper.from_array(arr.astype(np.float16), init.name + "_fp16")
            new_inits.append(half)
            casts.append(helper.make_node("Cast", [half.name], [init.name], to=onnx.TensorProto.FLOAT))
        else:
            new_inits.append(init)
    del graph.initializer[:]
    graph.initializer.extend(new_inits)
    nodes = list(graph.node)
    del graph.node[:]
    graph.node.extend(casts + nodes)
    return proto

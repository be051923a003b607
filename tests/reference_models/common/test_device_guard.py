"""No tensor of the reference models' code is made without saying on which device.

A run on a CPU-only machine cannot show that a tensor made in a hot path lands on the CPU
while the model is on CUDA (everything is on the CPU here), so this reads the source: every
call of a torch constructor (``torch.zeros``, ``ones``, ``full``, ``empty``, ``arange``,
``linspace``, ``tensor``, ``as_tensor``, ``rand`` ...) and ``torch.Generator`` must pass
``device=``, and ``torch.load`` must pass ``map_location=``; in a module's ``__init__`` a tensor
that becomes a parameter or buffer (``nn.Parameter(...)``, ``register_buffer(...)``) moves with
the model and needs none. The rest is listed below with the reason it is right.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3] / "reference_models"
FILES = sorted([*(ROOT / "common").glob("*.py"), ROOT / "kplanes" / "field.py",
                ROOT / "nerfplayer" / "field.py"])
CONSTRUCTORS = {"zeros", "ones", "full", "empty", "arange", "linspace", "logspace", "eye",
                "tensor", "as_tensor", "rand", "randn", "randint", "randperm", "Generator"}
MOVES_WITH_THE_MODULE = {"Parameter", "register_buffer"}

ALLOWED = {
    ("common/importance.py", "RaySampler.__init__", "Generator"):
        "the sampler draws on the CPU on every device: the same rays wherever the model runs",
    ("common/importance.py", "RaySampler.sample", "randint"):
        "index draws by the sampler's CPU generator; they gather from the CPU images",
    ("common/importance.py", "RaySampler.sample", "rand"):
        "drawn by the sampler's CPU generator for its CPU CDF search",
    ("common/sampling.py", "stratified_edges", "rand"):
        "jitter drawn by the (CPU) generator and moved with .to(device): the same on every device",
    ("common/sampling.py", "resample_edges", "rand"):
        "jitter drawn by the (CPU) generator and moved to the edges' device",
    ("common/footprint.py", "pixel_samples", "as_tensor"):
        "the footprint rule runs once when a run starts, on the CPU's numpy views; it returns ints",
    ("common/footprint.py", "pixel_samples", "arange"):
        "the footprint rule's pixel grid, on the CPU like its views (once per run, not per step)",
    ("common/footprint.py", "camera_asks", "as_tensor"):
        "the footprint rule's coverage: the CPU's numpy views and points, once per run",
    ("common/footprint.py", "_face_steps", "ones"):
        "the footprint rule's mask, on the CPU like its views (once per run, not per step)",
    ("common/encodings.py", "PlaneEncoding.__init__", "ones"):
        "a plane's initial values, made an nn.Parameter (moved with the model)",
    ("common/encodings.py", "PlaneEncoding.__init__", "empty"):
        "a plane's initial values, made an nn.Parameter (moved with the model)",
    ("common/plane_kernels.py", "_PlaneTV.forward", "tensor"):
        "the compiled plane TV's value: plane_tv takes CPU planes only (torch's path elsewhere)",
    ("common/plane_kernels.py", "_PlaneTV.backward", "empty"):
        "the compiled plane TV's gradient, on the CPU like the planes plane_tv accepts",
    ("common/plane_kernels.py", "_PlaneProduct.forward", "empty"):
        "the compiled look-up runs for CPU tensors only (uses_fused_lookup); its outputs are CPU",
    ("common/plane_kernels.py", "_PlaneProduct.backward", "empty"):
        "the compiled look-up's plane gradients, CPU like the planes it runs for",
    ("common/train.py", "_loop", "arange"):
        "reorders the CPU sampler's indices; the batch moves to the device after",
    ("common/train.py", "build_model", "tensor"):
        "the scene box, registered as the model's buffer (moved with the model)",
    ("kplanes/field.py", "DynamicBoxEncoding.__init__", "as_tensor"):
        "the moving box, of which the buffers centre and half_size are made",
    ("kplanes/field.py", "build_encoding", "tensor"):
        "CPU arithmetic on the scene's boxes, turned into numpy before the model exists",
    ("nerfplayer/field.py", "TemporalHashEncoding.__init__", "zeros"):
        "0-dim placeholder of window_l1, replaced by every training forward (and a 0-dim CPU "
        "tensor combines with CUDA ones as a scalar)",
}


def _qualname(stack: list[ast.AST]) -> str:
    return ".".join(n.name for n in stack if isinstance(n, (ast.ClassDef, ast.FunctionDef)))


def _torch_attr(call: ast.Call) -> str | None:
    f = call.func
    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "torch":
        return f.attr
    return None


def _called_name(call: ast.Call) -> str | None:
    f = call.func
    return f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None


def unplaced_tensors(source: str) -> list[tuple[str, str, int]]:
    """(function qualname, constructor, line) of every torch constructor in ``source`` made
    without ``device=`` (``torch.load`` without ``map_location=``), except a parameter or
    buffer made in an ``__init__``."""
    found: list[tuple[str, str, int]] = []

    def visit(node: ast.AST, stack: list[ast.AST]) -> None:
        if isinstance(node, ast.Call):
            name, keys = _torch_attr(node), {k.arg for k in node.keywords}
            in_init = any(isinstance(n, ast.FunctionDef) and n.name == "__init__" for n in stack)
            kept = in_init and any(isinstance(n, ast.Call) and _called_name(n) in
                                   MOVES_WITH_THE_MODULE for n in stack)
            if name == "load" and "map_location" not in keys:
                found.append((_qualname(stack), name, node.lineno))
            elif name in CONSTRUCTORS and "device" not in keys and not kept:
                found.append((_qualname(stack), name, node.lineno))
        for child in ast.iter_child_nodes(node):
            visit(child, [*stack, node])

    visit(ast.parse(source), [])
    return found


def _all_found() -> dict[tuple[str, str, str], list[int]]:
    out: dict[tuple[str, str, str], list[int]] = {}
    for path in FILES:
        rel = path.relative_to(ROOT).as_posix()
        for qual, name, line in unplaced_tensors(path.read_text()):
            out.setdefault((rel, qual, name), []).append(line)
    return out


def test_every_tensor_of_the_hot_paths_names_its_device():
    unlisted = {k: v for k, v in _all_found().items() if k not in ALLOWED}
    assert not unlisted, ("tensors made without device= (pass the input's device, or add them "
                          f"to ALLOWED with the reason they are right): {unlisted}")


def test_every_allowed_entry_is_still_there():
    stale = set(ALLOWED) - set(_all_found())
    assert not stale, f"ALLOWED lists constructors the code no longer has: {stale}"


@pytest.mark.parametrize(("source", "expected"), [
    ("def f(x):\n    return torch.zeros(3)\n", [("f", "zeros", 2)]),
    ("def f(x):\n    return torch.zeros(3, device=x.device)\n", []),
    ("class M:\n    def forward(self, x):\n        return torch.arange(4) + x\n",
     [("M.forward", "arange", 3)]),
    ("def f(p):\n    return torch.load(p, weights_only=False)\n", [("f", "load", 2)]),
    ("def f(p):\n    return torch.load(p, map_location='cpu')\n", []),
    ("class M:\n    def __init__(self):\n        self.w = nn.Parameter(torch.ones(3))\n"
     "        self.register_buffer('b', torch.tensor([1]).cumsum(0))\n"
     "        self.loose = torch.zeros(())\n", [("M.__init__", "zeros", 5)]),
    ("def g():\n    return nn.Parameter(torch.ones(3))\n", [("g", "ones", 2)]),  # not __init__
    ("def f(x):\n    return torch.zeros_like(x), torch.Generator()\n", [("f", "Generator", 2)]),
])
def test_the_guard_flags_what_it_should(source, expected):
    assert unplaced_tensors(source) == expected

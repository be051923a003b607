"""The layers of docs/architecture.md hold: who imports whom, function sizes, no reference models.

Imports are read from the source with ``ast`` (also those inside functions, which run later), so
a lazy import that crosses a layer is caught too.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "dynaeval"

FLOOR = ("dynaeval.errors", "dynaeval.boxes", "dynaeval.runtime", "dynaeval.validation",
         "dynaeval.progress")
"""The ground floor: every layer may import it; it imports nothing of dynaeval above it."""

LAYERS = {
    "io": ("dynaeval.io",),
    "regions": ("dynaeval.regions",),
    "metrics": ("dynaeval.metrics",),
    "evaluate": ("dynaeval.config", "dynaeval.plan", "dynaeval.executor", "dynaeval.stages",
                 "dynaeval.scoring", "dynaeval.evaluate", "dynaeval.distributed",
                 "dynaeval.prepare", "dynaeval.suite"),
    "report": ("dynaeval.report",),
    "cli": ("dynaeval.cli", "dynaeval.__main__", "dynaeval.suite_cli"),
}
MAY_IMPORT = {
    "floor": {"floor"},
    "io": {"floor", "io"},
    "regions": {"floor", "io", "regions"},
    "metrics": {"floor", "io", "metrics"},  # never regions
    "evaluate": {"floor", "io", "regions", "metrics", "evaluate", "report"},
    "report": {"floor", "io", "metrics", "report"},
    "cli": {"floor", "io", "regions", "metrics", "evaluate", "report", "cli"},
}
"""Which layers each layer may import (evaluate assembles its results with report.results)."""


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _layer(module: str) -> str | None:
    if module in ("dynaeval", "dynaeval.__init__"):
        return None  # the package itself: lazy re-exports only
    if any(module == f or module.startswith(f + ".") for f in FLOOR):
        return "floor"
    for layer, prefixes in LAYERS.items():
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return layer
    return "unknown"


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
            # ``from dynaeval import metrics`` imports the sub-package
            if node.module == "dynaeval":
                found += [(node.lineno, f"dynaeval.{a.name}") for a in node.names
                          if a.name not in ("__version__",)]
    return found


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_every_module_belongs_to_a_layer():
    unknown = [_module_name(p) for p in _sources() if _layer(_module_name(p)) == "unknown"]
    assert not unknown, f"modules outside every layer of docs/architecture.md: {unknown}"


def test_layers_import_only_what_they_may():
    bad = []
    for path in _sources():
        me = _layer(_module_name(path))
        if me is None:
            continue
        for line, target in _imports(path):
            if not target.startswith("dynaeval.") and target != "dynaeval":
                continue
            other = _layer(target)
            if other is not None and other not in MAY_IMPORT[me]:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line} ({me}) imports {target} ({other})")
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_dynaeval_never_imports_reference_models_or_benchmarks():
    bad = [f"{p.relative_to(PACKAGE.parent)}:{line} {t}" for p in _sources()
           for line, t in _imports(p) if t.split(".")[0] in ("reference_models", "benchmarks")]
    assert not bad, bad


def test_no_function_longer_than_100_lines():
    long = []
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > 100:
                    long.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {node.name} {n}")
    assert not long, f"functions over 100 lines: {long}"


_NO_TORCH = """
import importlib.abc, sys

class NoTorch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("torch", "torchvision", "lpips"):
            raise ImportError(f"No module named {name!r} (blocked: a torch-free environment)")
        return None

sys.meta_path.insert(0, NoTorch())
import warnings
import dynaeval
from dynaeval.cli import sample_dir

root = sample_dir()
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    res = dynaeval.score(root / "pred", root / "gt", progress=False,
                         focus=dynaeval.ScoreConfig().focus.__class__(
                             source="boxes", boxes_file=str(root / "boxes.json")))
assert res["settings"]["lpips"]["enabled"] is False, res["settings"]["lpips"]
assert "dynaeval[lpips]" in res["settings"]["lpips"]["unavailable"]
assert any("LPIPS not computed" in str(w.message) for w in caught), [str(w.message) for w in caught]
assert res["summary"]["psnr"] > 20 and res["summary"]["focused_ssim"] > 0.5
assert "lpips" not in res["summary"] and res["summary"]["tlp"] is None
assert not any(m.split(".")[0] in ("torch", "reference_models") for m in sys.modules)
print("ok")
"""


def test_score_works_without_torch():
    """``import dynaeval`` and ``dynaeval.score`` in an interpreter where torch cannot be
    imported: LPIPS (and tLP) are reported unavailable with the install hint, nothing else
    changes, and neither torch nor reference_models is ever imported."""
    out = subprocess.run([sys.executable, "-c", _NO_TORCH], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("ok")


@pytest.mark.parametrize("module", ["dynaeval", "dynaeval.cli", "dynaeval.metrics",
                                    "dynaeval.regions", "dynaeval.report", "dynaeval.runtime",
                                    "dynaeval.boxes", "dynaeval.validation"])
def test_importing_the_toolkit_stays_light(module):
    """Heavy dependencies load inside the functions that use them, never at import."""
    heavy = ("torch", "onnxruntime", "onnx", "cv2", "scipy", "pandas", "matplotlib",
             "reference_models")
    code = f"import sys, {module}; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"import {module} loads {out.stdout.strip()}"


def _internal_graph() -> tuple[dict[str, set[str]], list[tuple[str, int, str]]]:
    """dynaeval's import graph (every import, module level and inside functions) and the
    internal imports made inside functions, ``(module, line, target)``.

    ``from P import a`` is an edge to ``P.a`` where that is a module, else to ``P``; the
    package's own lazy re-export (``dynaeval.score`` in ``dynaeval/__init__.py``, which keeps
    ``import dynaeval`` light), ``from dynaeval import __version__`` and the imports under
    ``if TYPE_CHECKING:`` (never run) are not edges.
    """
    modules = {_module_name(p): p for p in _sources()}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    lazy = []
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        inside = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef,
                                                                  ast.AsyncFunctionDef))
                  for n in ast.walk(f) if n is not f}
        typing_only = {id(n) for f in ast.walk(tree) if isinstance(f, ast.If)
                       and "TYPE_CHECKING" in ast.unparse(f.test) for n in ast.walk(f)}
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            if isinstance(node, ast.Import):
                found = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                subs = [f"{node.module}.{a.name}" for a in node.names]
                found = [s for s in subs if s in modules]
                if len(found) < len(subs) and not (node.module == "dynaeval" and all(
                        a.name == "__version__" for a in node.names)):
                    found.append(node.module)
            else:
                continue
            targets = {t for t in found if t in modules and t != module}
            if module == "dynaeval" or not targets:
                continue
            graph[module] |= targets
            if id(node) in inside:
                lazy += [(module, node.lineno, t) for t in sorted(targets)]
    return graph, lazy


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                group = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    group.append(w)
                    if w == v:
                        break
                if len(group) > 1:
                    groups.append(sorted(group))
    return groups


def test_no_import_cycle():
    """No two dynaeval modules import each other, directly or round a loop, counting the imports
    inside functions too (issue 31: three lazy cycles hid in them)."""
    assert _cycles(_internal_graph()[0]) == []


LAZY_INTERNAL = {
    "dynaeval.metrics.flicker_kernels": "compiles its numba kernels at import",
    "dynaeval.metrics.structural_kernels": "compiles its numba kernels at import",
}
"""The dynaeval modules imported inside functions, and why: only those heavy at import."""


def test_internal_imports_are_at_module_level():
    """An import inside a function hides the graph; dynaeval's own modules are imported at the
    top of the module, but those ``LAZY_INTERNAL`` names (heavy at import)."""
    _, lazy = _internal_graph()
    hidden = [f"{m}:{line} imports {t}" for m, line, t in lazy if t not in LAZY_INTERNAL]
    assert hidden == []

"""The layers of docs/architecture.md hold: the tree is the architecture (each layer one folder,
the package root its public face only), who imports whom (type-only imports included), no import
circle, function sizes, no reference models.

Imports are read from the source with ``ast`` (also those inside functions, which run later, and
those under ``if TYPE_CHECKING:``), so a lazy or a type-only import that crosses a layer or closes
a circle is caught too.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "dynaeval"

LAYERS = {
    "core": "dynaeval.core",
    "io": "dynaeval.io",
    "regions": "dynaeval.regions",
    "metrics": "dynaeval.metrics",
    "run": "dynaeval.run",
    "report": "dynaeval.report",
    "cli": "dynaeval.cli",
}
"""Each layer of docs/architecture.md and the one package (a folder of ``dynaeval/``) it is."""

MAY_IMPORT = {
    "core": {"core"},  # the ground floor: numpy only, nothing of dynaeval above it
    "io": {"core", "io"},
    "regions": {"core", "io", "regions"},
    "metrics": {"core", "io", "metrics"},  # never regions
    "run": {"core", "io", "regions", "metrics", "run", "report"},  # report.results: the document
    "report": {"core", "io", "metrics", "regions", "report"},  # regions.sources: focus kinds
    "cli": {"core", "io", "regions", "metrics", "run", "report", "cli"},
}
"""Which layers each layer may import (design.md's layout table); nothing imports cli."""

FACE = {
    "dynaeval": "the public names, loaded on first use (score, ScoreConfig, FocusConfig, ...)",
    "dynaeval.__main__": "python -m dynaeval: the CLI",
    "dynaeval.errors": "the exceptions a caller catches (reference_models imports InputError here)",
}
"""The modules of the package root, and why each is there: its public face, nothing else. No
module of a layer imports them (the version too is the ground floor's: ``core.version``)."""

ROOT_DATA = {"data", "models", "schemas", "py.typed"}
"""Package data beside the face: the sample, the bundled detector, the JSON schemas."""


def _module_name(path: Path, package: Path = PACKAGE) -> str:
    rel = path.relative_to(package.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _layer(module: str) -> str | None:
    """The layer of a dynaeval module, None for the root's face, ``"unknown"`` outside both."""
    if module in FACE:
        return None
    for layer, package in LAYERS.items():
        if module == package or module.startswith(package + "."):
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


def _sources(package: Path = PACKAGE) -> list[Path]:
    return sorted(package.rglob("*.py"))


def test_every_layer_is_one_folder_and_the_root_holds_only_the_face():
    """The tree is the architecture: each layer a package folder of ``dynaeval/``, and at the
    root only the ``FACE`` modules and the package data (issue 41: the orchestration and the
    ground floor were 16 modules and a folder beside the layers)."""
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert {f"dynaeval.{n}" for n in packages} == set(LAYERS.values())
    rest = {p.name for p in PACKAGE.iterdir() if p.name not in packages | {"__pycache__"}}
    face = {f"{m.removeprefix('dynaeval').lstrip('.') or '__init__'}.py" for m in FACE}
    assert rest - ROOT_DATA == face, f"at the root beside the face: {sorted(rest - ROOT_DATA - face)}"


def test_every_module_belongs_to_a_layer():
    unknown = [_module_name(p) for p in _sources() if _layer(_module_name(p)) == "unknown"]
    assert not unknown, f"modules outside every layer of docs/architecture.md: {unknown}"


def test_the_face_defines_nothing():
    """The root's modules hand names on; what they name is defined in a layer: ``errors`` only
    imports from ``dynaeval.core``, and every public name of ``dynaeval`` comes from a layer
    module and is that module's object."""
    import importlib

    import dynaeval

    tree = ast.parse((PACKAGE / "errors.py").read_text(encoding="utf-8"))
    kinds = {type(n).__name__ for n in tree.body[1:]}
    assert kinds <= {"ImportFrom", "Assign"}, kinds
    assert all(n.module.startswith("dynaeval.core.") for n in tree.body
               if isinstance(n, ast.ImportFrom))
    public = [n for n in dynaeval.__all__ if n != "__version__"]
    assert {"score", "ScoreConfig", "FocusConfig", "ImageMetrics"} <= set(public)
    for name in public:
        value = getattr(dynaeval, name)
        home = importlib.import_module(value.__module__)
        assert _layer(value.__module__) not in (None, "unknown") and getattr(home, name) is value


def test_layers_import_only_what_they_may():
    bad = []
    for path in _sources():
        me = _layer(_module_name(path))
        if me in (None, "unknown"):  # the face; modules of no layer fail the test above
            continue
        for line, target in _imports(path):
            if not target.startswith("dynaeval.") and target != "dynaeval":
                continue
            other = _layer(target)
            if other is None:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line} ({me}) imports the face "
                           f"{target}")
            elif other is not None and other not in MAY_IMPORT[me]:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line} ({me}) imports {target} ({other})")
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_dynaeval_never_imports_reference_models_or_benchmarks():
    bad = [f"{p.relative_to(PACKAGE.parent)}:{line} {t}" for p in _sources()
           for line, t in _imports(p) if t.split(".")[0] in ("reference_models", "benchmarks")]
    assert not bad, bad


SCREEN_LINES = 50
"""The most lines a function may have besides its docstring (signature and body; issue 41:
functions that fit on a screen). A docstring of shapes, units and ranges is not held against it."""


def _long_functions(path: Path, limit: int = SCREEN_LINES) -> list[str]:
    """``"line name lines"`` of each function of ``path`` (methods and nested ones too) with more
    than ``limit`` lines besides its docstring."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        n = node.end_lineno - node.lineno + 1
        first = node.body[0]
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(
                first.value.value, str):
            n -= first.end_lineno - first.lineno + 1
        if n > limit:
            found.append(f"{node.lineno} {node.name} {n}")
    return found


def test_every_function_fits_on_a_screen():
    """Issue 41 split the longest (``merge_results`` 85 lines besides its docstring,
    ``ScoreConfig.__post_init__`` 75, ``find_frames`` 68, ``build_results`` 65, ``pair_frames``
    62, ``build_leaderboard`` 57, ``prepare`` 56, ``_camera_regions`` 53, ``detect_layout`` 52)
    into short functions and named helpers."""
    long = [f"{path.relative_to(PACKAGE.parent)}:{found}"
            for path in _sources() for found in _long_functions(path)]
    assert not long, f"functions over {SCREEN_LINES} lines besides the docstring: {long}"


def test_the_screen_rule_counts_code_not_docstrings(tmp_path):
    code = tmp_path / "m.py"
    lines = "".join(f"    x{i} = {i}\n" for i in range(SCREEN_LINES))  # + the def: one over
    doc = '    """' + "words\n" * 30 + '    """\n'
    short = "".join(lines.splitlines(keepends=True)[1:])
    code.write_text(f"def short():\n{doc}{short}def long():\n{lines}")
    assert [f.split(maxsplit=1)[1] for f in _long_functions(code)] == [f"long {SCREEN_LINES + 1}"]


CLI = PACKAGE / "cli"
CLI_MODULE_LINES = 250
"""The most lines a module of the CLI may have (issue 31: cli.py had grown to 658)."""


def _cli_sources() -> list[Path]:
    return sorted(CLI.rglob("*.py")) if CLI.is_dir() else [PACKAGE / "cli.py"]


def test_the_cli_is_one_small_module_per_command():
    """``dynaeval/cli/`` is a package of modules of at most ``CLI_MODULE_LINES`` lines, and every
    command ``dynaeval --help`` lists is its own module ``cli/<NAME>.py``, registered in
    ``COMMANDS`` (a new command: one module and one entry there)."""
    import argparse

    import dynaeval.cli as cli

    long = [f"{p.relative_to(PACKAGE.parent)}: {n} lines" for p in _cli_sources()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > CLI_MODULE_LINES]
    assert CLI.is_dir() and long == []
    sub = next(a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    commands = getattr(cli, "COMMANDS", ())
    assert list(sub.choices) == [c.NAME for c in commands]
    assert [c.__name__ for c in commands] == [f"dynaeval.cli.{c.NAME}" for c in commands]


def test_no_getattr_list_in_the_cli():
    """The CLI reads a command's settings back from the option table (``cli/options.py``), not
    name by name: no ``getattr(args, ...)`` in it (issue 31: ``config_from_args`` had ~25)."""
    calls = []
    for path in _cli_sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id == "getattr" and node.args
                    and isinstance(node.args[0], ast.Name) and node.args[0].id == "args"):
                calls.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    assert calls == []


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
                                    "dynaeval.regions", "dynaeval.report", "dynaeval.core.runtime",
                                    "dynaeval.core.boxes", "dynaeval.core.validation"])
def test_importing_the_toolkit_stays_light(module):
    """Heavy dependencies load inside the functions that use them, never at import."""
    heavy = ("torch", "onnxruntime", "onnx", "cv2", "scipy", "pandas", "matplotlib",
             "reference_models")
    code = f"import sys, {module}; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"import {module} loads {out.stdout.strip()}"


def _internal_graph(package: Path = PACKAGE) -> tuple[dict[str, set[str]],
                                                     list[tuple[str, int, str]]]:
    """The package's import graph (every import: module level, inside functions and under
    ``if TYPE_CHECKING:``) and the internal imports made inside functions, ``(module, line,
    target)``.

    ``from P import a`` is an edge to ``P.a`` where that is a module, else to ``P``; the
    package's own lazy re-exports (``dynaeval/__init__.py``, which keeps ``import dynaeval``
    light) are not edges. A type-only import is an
    edge: it does not run, but it ties the two modules as much as a real one (issue 41: one
    closed a 9-module circle, plan -> prepare -> scoring -> plan).
    """
    root = package.name
    modules = {_module_name(p, package): p for p in _sources(package)}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    lazy = []
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        inside = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef,
                                                                  ast.AsyncFunctionDef))
                  for n in ast.walk(f) if n is not f}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                subs = [f"{node.module}.{a.name}" for a in node.names]
                found = [s for s in subs if s in modules]
                if len(found) < len(subs):
                    found.append(node.module)
            else:
                continue
            targets = {t for t in found if t in modules and t != module}
            if module == root or not targets:
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
    inside functions (issue 31: three lazy cycles hid in them) and under ``TYPE_CHECKING``
    (issue 41: plan -> prepare -> scoring -> plan, regions.focus <-> regions.summary)."""
    assert _cycles(_internal_graph()[0]) == []


def test_the_cycle_rule_counts_type_only_and_lazy_imports(tmp_path):
    """A circle closed only by a type-only import, or only by one inside a function, is found."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "plan.py").write_text("from typing import TYPE_CHECKING\n"
                                 "if TYPE_CHECKING:\n    from pkg.prepare import Prepared\n")
    (pkg / "prepare.py").write_text("from pkg.plan import RunPlan\n")
    (pkg / "a.py").write_text("from pkg import b\n")
    (pkg / "b.py").write_text("def f():\n    import pkg.a\n")
    (pkg / "c.py").write_text("from pkg.plan import RunPlan\n")
    assert sorted(_cycles(_internal_graph(pkg)[0])) == [["pkg.a", "pkg.b"],
                                                        ["pkg.plan", "pkg.prepare"]]


LAZY_INTERNAL = {
    "dynaeval.metrics.flicker_kernels": "compiles its numba kernels at import",
    "dynaeval.metrics.flow_kernels": "compiles its numba kernels at import",
    "dynaeval.metrics.gather_kernels": "compiles its numba kernels at import",
    "dynaeval.metrics.structural_kernels": "compiles its numba kernels at import",
    "dynaeval.regions.motion_kernels": "compiles its numba kernels at import",
    "dynaeval.cli": "the command line, loaded by the entry point (dynaeval.__main__) inside a "
                    "guard: Ctrl-C while it loads is exit 130, not a traceback (issue 43)",
}
"""The dynaeval modules imported inside functions, and why: only those heavy at import."""


def test_internal_imports_are_at_module_level():
    """An import inside a function hides the graph; dynaeval's own modules are imported at the
    top of the module, but those ``LAZY_INTERNAL`` names (heavy at import)."""
    _, lazy = _internal_graph()
    hidden = [f"{m}:{line} imports {t}" for m, line, t in lazy if t not in LAZY_INTERNAL]
    assert hidden == []


def test_optional_packages_are_imported_only_by_deps():
    """Whether an optional package (torch, lpips, flip_evaluator, ...) is installed is found once,
    at import, by ``dynaeval.core.deps``; no other module imports one itself (``deps.load`` does, and
    turns a missing install into ``MissingDependency`` with its install line), and none probes
    for one with ``find_spec`` or ``try: import``."""
    from dynaeval.core.deps import DEPENDENCIES

    found = []
    for path in _sources():
        if path.name == "deps.py" and path.parent == PACKAGE / "core":
            continue
        rel = path.relative_to(PACKAGE.parent)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif isinstance(node, ast.Attribute) and node.attr == "find_spec":
                found.append(f"{rel}:{node.lineno} find_spec")
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                  and node.func.attr == "import_module" and node.args
                  and isinstance(node.args[0], ast.Constant)):
                names = [str(node.args[0].value)]
            found += [f"{rel}:{node.lineno} import {n}" for n in names
                      if n.split(".")[0] in DEPENDENCIES]
    assert not found, f"optional packages imported outside dynaeval.core.deps: {found}"


PROTOCOL_MODULES = ("dynaeval/metrics/protocols.py", "dynaeval/metrics/protocol_*.py")
"""The protocol classes and their registry: the only modules that read a protocol's settings."""


def _protocol_settings() -> set[str]:
    """The setting attributes of a protocol (``protocol_base.SETTINGS``), read from the source."""
    tree = ast.parse((PACKAGE / "metrics" / "protocol_base.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "SETTINGS"
                                                for t in node.targets):
            return set(ast.literal_eval(node.value))
    raise AssertionError("protocol_base.py has no SETTINGS")


def _protocol_flag_reads(source: str, flags: set[str]) -> list[tuple[int, str]]:
    """``(line, text)`` of every read of a protocol setting in ``source``: ``X.flag`` or
    ``getattr(X, "flag", ...)`` where X is a protocol: a name or attribute called ``*protocol*``,
    a call of ``get_protocol``/``whole`` (``FrameContext.whole``), a parameter annotated
    ``Protocol``, or a name assigned from one of those."""
    tree = ast.parse(source)
    names: set[str] = set()

    def is_protocol(node: ast.AST) -> bool:
        if isinstance(node, ast.Name):
            return "protocol" in node.id.lower() or node.id in names
        if isinstance(node, ast.Attribute):
            return "protocol" in node.attr.lower()
        if isinstance(node, ast.Call):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            return called in ("get_protocol", "whole")
        return False

    for _ in range(3):  # names assigned from protocols, and from those
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and is_protocol(node.value):
                names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
            elif isinstance(node, ast.arg) and node.annotation is not None \
                    and "Protocol" in ast.unparse(node.annotation):
                names.add(node.arg)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in flags and is_protocol(node.value):
            found.append((node.lineno, ast.unparse(node)))
        elif (isinstance(node, ast.Call) and getattr(node.func, "id", "") == "getattr"
              and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
              and node.args[1].value in flags and is_protocol(node.args[0])):
            found.append((node.lineno, ast.unparse(node)))
    return sorted(found)


def test_protocol_flag_reads_are_found():
    """The check below finds each form of a settings read, and only those."""
    source = ("p = get_protocol(name)\nq = p\nq.decode\nplan.protocol.masks\n"
              "getattr(ctx.whole(), 'clip', False)\nconfig.metrics\nprotocol.describe()\n"
              "def f(x: Protocol):\n    return x.quantize\nctx.whole().whole_psnr\n")
    assert [line for line, _ in _protocol_flag_reads(source, _protocol_settings())] == [3, 4, 5, 9]


def test_no_protocol_setting_read_outside_the_protocol_classes():
    """Issue 31: a protocol is one class whose methods say what it does; no other module reads
    its settings (``quantize``, ``masks``, ``decode``, ...) to decide for it."""
    flags = _protocol_settings()
    inside = {p for pattern in PROTOCOL_MODULES for p in PACKAGE.parent.glob(pattern)}
    reads = [f"{path.relative_to(PACKAGE.parent)}:{line}: {text}"
             for path in _sources() if path not in inside
             for line, text in _protocol_flag_reads(path.read_text(encoding="utf-8"), flags)]
    assert reads == []


PROTOCOL_LABELS = {"psnr", "ssim", "ssim_data_range", "lpips_input", "lpips_reduce", "masks",
                   "msssim", "family", "reference", "choices"}
"""The settings that only name a protocol's choices in the results: its methods implement them."""


def test_protocol_labels_are_read_by_describe_only():
    """Inside the protocol classes too, a label is never dispatched on (the old
    ``if self.ssim == "dm_pix"`` chains): the behaviour is the overriding method, the label
    what ``describe`` writes."""
    reads = []
    for path in sorted({p for pattern in PROTOCOL_MODULES for p in PACKAGE.parent.glob(pattern)}):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef) or fn.name == "describe":
                continue
            reads += [f"{path.name}:{node.lineno} {fn.name}: {ast.unparse(node)}"
                      for node in ast.walk(fn) if isinstance(node, ast.Attribute)
                      and node.attr in PROTOCOL_LABELS and getattr(node.value, "id", "") == "self"]
    assert reads == []


TEXT_NAMES = {"reason", "message", "msg", "detail", "err", "exc", "error"}
"""Names (variables, attributes, dict keys) that hold the words of a warning or an error."""

READS_OLD_TEXT = {("dynaeval.report.results", "_v1_status"),
                  ("dynaeval.report.results", "_upgrade_v1")}
"""The one place that may read warning text: the reader of ``dynaeval/results/v1`` files, which
gives their warnings the statuses they lack, once, at load."""


def _holds_text(node: ast.AST) -> bool:
    """``node`` reads the words of a warning or an error: ``w["reason"]``, ``w.get("reason")``,
    ``reason``, ``err.message``, ``str(err)``, ``note.reason.lower()`` ..."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.Constant) and sub.value in TEXT_NAMES:
            return True  # a key: w["reason"], w.get("reason", "")
        if isinstance(sub, ast.Name) and sub.id in TEXT_NAMES:
            return True
        if isinstance(sub, ast.Attribute) and sub.attr in TEXT_NAMES:
            return True
    return False


def _text_matches(path: Path) -> list[tuple[str, int, str]]:
    """``(function, line, code)`` of every ``x in <text>``, ``<text>.startswith(...)``,
    ``<text>.endswith(...)`` and ``re.match/search(..., <text>)`` in a module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []

    def visit(node: ast.AST, function: str) -> None:
        for child in ast.iter_child_nodes(node):
            name = (child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
                    else function)
            hit = False
            if isinstance(child, ast.Compare) and any(
                    isinstance(op, ast.In | ast.NotIn) for op in child.ops):
                hit = any(_holds_text(c) for c in child.comparators)
            elif isinstance(child, ast.Call) and isinstance(child.func, ast.Attribute):
                attr = child.func.attr
                if attr in ("startswith", "endswith"):
                    hit = _holds_text(child.func.value)
                elif attr in ("match", "search", "fullmatch", "findall") and child.args[1:]:
                    hit = _holds_text(child.args[1])
            if hit:
                found.append((name, child.lineno, ast.unparse(child)[:80]))
            visit(child, name)

    visit(tree, "<module>")
    return found


def test_no_code_decides_by_reading_a_warning_or_an_error_message():
    """Issue 31: meaning travels as a status (``dynaeval.core.outcome.Status``) or an exception type,
    never in words: no ``"pip install" not in str(err)``, no ``w["reason"].startswith(...)``
    outside the v1 reader (``READS_OLD_TEXT``)."""
    bad = [f"{_module_name(p)}:{line} ({fn}): {code}" for p in _sources()
           for fn, line, code in _text_matches(p)
           if (_module_name(p), fn) not in READS_OLD_TEXT]
    assert bad == []


def test_the_text_rule_catches_what_main_did(tmp_path):
    """The rule fails on the text matching main had (scoring.py's ``REGIONLESS_REASONS``,
    merge.py's "summary is null" prefix, registry.py's "pip install" check)."""
    old = ('def a(w, err, entry):\n'
           '    if w["reason"].startswith(("summary is null", "no focus box")):\n'
           '        return 1\n'
           '    if "pip install" not in str(err):\n'
           '        return 2\n'
           '    reason = entry.get("reason") or ""\n'
           '    return reason.startswith(("no pair of consecutive frames has a region",))\n')
    path = tmp_path / "old.py"
    path.write_text(old, encoding="utf-8")
    assert [line for _, line, _ in _text_matches(path)] == [2, 4, 7]


def _layout_name(node: ast.AST) -> bool:
    """``layout.name`` (a ``RenderLayout``'s name), ``layout["name"]`` or
    ``layout.get("name")`` (the results' ``inputs.layout`` read back)."""
    if isinstance(node, ast.Attribute):
        return node.attr == "name" and getattr(node.value, "id", "") == "layout"
    if isinstance(node, ast.Subscript):
        return (getattr(node.value, "id", "") == "layout" and isinstance(node.slice, ast.Constant)
                and node.slice.value == "name")
    return (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
            and node.func.attr == "get" and getattr(node.func.value, "id", "") == "layout"
            and bool(node.args) and isinstance(node.args[0], ast.Constant)
            and node.args[0].value == "name")


def _source_literal_compares(path: Path, named=None) -> list[str]:  # noqa: ANN001
    """``x.source == "motion"``, ``source in ("detector", "boxes")`` and the like in ``path``:
    a focus source (a name ending in ``source``; or what ``named`` accepts) compared with string
    literals."""
    def named_source(node: ast.AST) -> bool:
        if named is not None:
            return named(node)
        name = node.attr if isinstance(node, ast.Attribute) else getattr(node, "id", "")
        return name.endswith("source")

    def literal(node: ast.AST) -> bool:
        if isinstance(node, ast.Constant):
            return isinstance(node.value, str)
        return isinstance(node, ast.Tuple | ast.List | ast.Set) and any(
            isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts)

    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(named_source(s) for s in sides) and any(literal(s) for s in sides):
                found.append(f"{path}:{node.lineno}")
    return found


def test_no_focus_source_is_told_apart_by_its_name():
    """Issue 41: the focus source was compared as a string literal at ~17 sites; each kind is a
    class of ``dynaeval.regions.sources`` whose facts (``gives_boxes``, ``detects``,
    ``reads_file``, ``from_motion``, ``classed``) the code reads instead."""
    bad = [hit for p in _sources() if p.name != "sources.py" for hit in _source_literal_compares(p)]
    assert not bad, "a focus source compared with a string literal:\n" + "\n".join(bad)


def test_the_source_rule_catches_what_main_did(tmp_path):
    code = tmp_path / "dynaeval" / "x.py"
    code.parent.mkdir()
    code.write_text('if focus.source == "none" or src.source in ("detector", "boxes"):\n    pass\n'
                    'ok = config.source == other\n')
    assert len(_source_literal_compares(code)) == 2  # not the third: no literal
    code.write_text('a = cfg.source != "motion"\nb = source not in ("detector",)\n')
    assert len(_source_literal_compares(code)) == 2


def test_no_input_layout_is_told_apart_by_its_name_in_the_run():
    """Issue 41: ``layout.name == "kplanes"`` (and ``dycheck``, ``3dgs``, ``folders``) at 7 sites
    of ``run/evaluate.py``, and the results' ``layout["name"] == "kplanes"`` / ``"3dgs"`` read
    back in ``cli/score.py`` and ``report/gaussian_splatting.py``; each kind is a
    ``dynaeval.io.layouts.LayoutKind`` (``layout_kind(name)``) the code asks. Only
    ``io/layouts.py``, which defines the kinds, names them."""
    bad = [hit for p in sorted(PACKAGE.rglob("*.py")) if p != PACKAGE / "io" / "layouts.py"
           for hit in _source_literal_compares(p, _layout_name)]
    assert not bad, "a layout told apart by its name:\n" + "\n".join(bad)


def test_the_layout_name_rule_sees_the_results_read_back(tmp_path):
    code = tmp_path / "m.py"
    code.write_text('a = layout["name"] == "kplanes"\nb = layout.get("name") in ("3dgs",)\n'
                    'c = layout.name != "dycheck"\nd = layout["root"] == "x"\n')
    assert len(_source_literal_compares(code, _layout_name)) == 3


SOURCE_NAMES = frozenset({"detector", "motion", "boxes", "none", "bundled"})


def _keyed_dicts(path: Path) -> tuple[list[str], list[str]]:
    """Dict literals in ``path`` that stand for a type: ``(by focus source, value and reason)``:
    those keyed by two or more focus-source names (``{"detector": ..., "motion": ...}``: what
    each kind says, outside its class), and those with a ``"value"`` key beside ``"status"`` or
    ``"reason"`` (a value and why it is missing, outside ``Outcome``)."""
    by_source, value_reason = [], []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Dict):
            continue
        keys = {k.value for k in node.keys if isinstance(k, ast.Constant)}
        if len(keys & SOURCE_NAMES) >= 2:
            by_source.append(f"{path}:{node.lineno}")
        if "value" in keys and keys & {"status", "reason"}:
            value_reason.append(f"{path}:{node.lineno}")
    return by_source, value_reason


def test_what_a_focus_source_says_is_said_by_its_class():
    """Issue 41: a frame's no-box words (``regions/focus.py``) and the run's no-box headline
    (``core/outcome.py``) were dicts keyed by source name, which a new kind did not have (a
    KeyError); each is a fact of the kind's class in ``regions/sources.py``."""
    bad = [hit for p in _sources() if p.name != "sources.py" for hit in _keyed_dicts(p)[0]]
    assert not bad, "a dict keyed by focus-source names:\n" + "\n".join(bad)


def test_a_value_and_its_reason_travel_as_an_outcome_until_the_results_document():
    """Issue 41: one shape for a value and why it is missing (``core.outcome.Outcome``, a camera's
    ``CameraTerm``) from the metric to the results document: no ``{"value", "status", "reason"}``
    dict outside the layer that writes the document (``report/``) and the module that makes its
    warnings (``core/outcome.py``). The temporal engine returned such dicts until then."""
    allowed = {PACKAGE / "core" / "outcome.py"}
    bad = [hit for p in _sources() if p not in allowed and PACKAGE / "report" not in p.parents
           for hit in _keyed_dicts(p)[1]]
    assert not bad, "a value with its reason in a dict, not an Outcome:\n" + "\n".join(bad)


def test_the_keyed_dict_rules_catch_what_main_did(tmp_path):
    code = tmp_path / "m.py"
    code.write_text(  # regions/focus.py, core/outcome.py and metrics/temporal.py before
        '_NO_BOX_REASON = {"detector": "a", "boxes": "b", "motion": "c"}\n'
        '_NO_BOX_WHO = {"bundled": "a", "detector": "b"}\n'
        'e = {"value": None, "status": s.value, "reason": r, "per_pair": []}\n'
        'ok = {"detector": 1, "x": 2}\nalso = {"value": 1, "signed": 2}\n')
    by_source, value_reason = _keyed_dicts(code)
    assert len(by_source) == 2 and len(value_reason) == 1

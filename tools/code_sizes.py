"""code_sizes.py [ROOT] [--write-docs]: the sizes of dynaeval/ as docs/architecture.md states them.

Prints the modules and lines, the largest modules, every function over 60 lines, and the
internal imports (at module level, inside functions). With ``--write-docs`` it rewrites the
section of ROOT/docs/architecture.md between ``<!-- begin sizes -->`` and ``<!-- end sizes -->``
from the same figures, so the table is made, not typed. Used for the before/after of the
issue-15 and issue-31 refactors (``python tools/code_sizes.py`` here and in an older checkout).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

BEGIN, END = "<!-- begin sizes -->", "<!-- end sizes -->"


def _module(path: Path, pkg: Path) -> str:
    parts = list(path.relative_to(pkg.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def measure(root: Path) -> dict:
    """Modules, lines, the largest modules, functions over 60 lines, internal imports."""
    pkg = root / "dynaeval"
    files = sorted(pkg.rglob("*.py"))
    modules = {_module(p, pkg) for p in files}
    total, longest, top, inside = 0, [], 0, 0
    for path in files:
        text = path.read_text(encoding="utf-8")
        total += text.count("\n")
        tree = ast.parse(text)
        in_functions = {id(n) for f in ast.walk(tree)
                        if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
                        for n in ast.walk(f) if n is not f}
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > 60:
                    longest.append((n, f"{path.relative_to(root)}:{node.name}"))
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module \
                    and node.module.split(".")[0] == "dynaeval" and node.module in modules:
                if id(node) in in_functions:
                    inside += 1
                else:
                    top += 1
    big = sorted(((p.read_text(encoding="utf-8").count("\n"), str(p.relative_to(root)))
                  for p in files), reverse=True)[:8]
    return {"modules": len(files), "lines": total, "largest": big,
            "longest": sorted(longest, reverse=True), "imports": (top, inside)}


def markdown(m: dict, commit: str) -> str:
    """The docs section of figures ``m`` measured at ``commit``."""
    top, inside = m["imports"]
    rows = [
        f"Sizes today (`python tools/code_sizes.py --write-docs`, at {commit}):",
        "",
        "| | |",
        "|---|---|",
        f"| modules in `dynaeval/` | {m['modules']}, {m['lines']:,} lines |",
        "| largest modules | " + ", ".join(f"`{name}` {n}" for n, name in m["largest"]) + " |",
        f"| functions over 60 lines | {len(m['longest'])}: "
        + ", ".join(f"`{name.split(':')[-1]}` {n}" for n, name in m["longest"])
        + " (none over 100: a test holds it) |",
        f"| internal imports (`from dynaeval.X import ...`) | {top + inside}: {top} at module "
        f"level, {inside} inside functions |",
    ]
    return "\n".join(rows) + "\n"


def main(argv: list[str]) -> None:
    write = "--write-docs" in argv
    args = [a for a in argv if a != "--write-docs"]
    root = Path(args[0]) if args else Path(__file__).resolve().parents[1]
    m = measure(root)
    print(f"{m['modules']} modules, {m['lines']} lines; largest: "
          + ", ".join(f"{name} {n}" for n, name in m["largest"]))
    print(f"functions over 60 lines: {len(m['longest'])}")
    for n, name in m["longest"]:
        print(f"  {n:4d} {name}")
    print("internal imports: {} at module level, {} inside functions".format(*m["imports"]))
    if write:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True).stdout.strip() or "?"
        doc = root / "docs" / "architecture.md"
        text = doc.read_text(encoding="utf-8")
        head, _, rest = text.partition(BEGIN)
        _, _, tail = rest.partition(END)
        if not rest:
            raise SystemExit(f"{doc}: no {BEGIN} ... {END} section to fill")
        doc.write_text(f"{head}{BEGIN}\n{markdown(m, commit)}{END}{tail}", encoding="utf-8")
        print(f"wrote the sizes into {doc}")


if __name__ == "__main__":
    main(sys.argv[1:])

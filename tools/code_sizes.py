"""code_sizes.py [ROOT]: lines per module of dynaeval/ and every function over 60 lines.

Used for the before/after sizes of the issue-15 refactor (docs/architecture.md):
``python tools/code_sizes.py`` here and in a checkout of the older commit."""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def main(root: Path) -> None:
    pkg = root / "dynaeval"
    files = sorted(pkg.rglob("*.py"))
    total = 0
    longest = []
    for path in files:
        text = path.read_text(encoding="utf-8")
        total += text.count("\n")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > 60:
                    longest.append((n, f"{path.relative_to(root)}:{node.name}"))
    big = sorted(((p.read_text(encoding="utf-8").count("\n"), str(p.relative_to(root)))
                  for p in files), reverse=True)[:8]
    print(f"{len(files)} modules, {total} lines; largest: "
          + ", ".join(f"{name} {n}" for n, name in big))
    print(f"functions over 60 lines: {len(longest)}")
    for n, name in sorted(longest, reverse=True):
        print(f"  {n:4d} {name}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1])

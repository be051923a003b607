"""compare_results.py [--statuses-added] BEFORE AFTER [ROOT_BEFORE ROOT_AFTER]: every results
JSON of BEFORE against AFTER, number for number.

With two checkout roots, paths under ROOT_BEFORE in BEFORE count as equal to the same paths under
ROOT_AFTER (``dynaeval demo`` scores the sample inside its own checkout).

Compares every field exactly (floats with ``==``) except ``created`` and ``timing``, checks that
``summary``, ``metrics`` and ``counts`` keep their key order (the order of the printed tables),
and that the printed tables (``*.txt`` beside the JSON) are the same text. Prints every
difference; exits 1 when there is one. Written for the before/after check of a refactor
(``tools/score_sample_configs.sh``, docs/architecture.md).

``--statuses-added``: BEFORE is ``dynaeval/results/v1``, AFTER ``v2`` (issue 31); the fields v2
adds (``schema``, ``summary_status``, each warning's ``status``) are counted and shown apart,
and every other field must be the same.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

IGNORED = ("created", "timing")
ORDERED = ("summary", "metrics", "counts")
ADDED_BY_V2 = re.compile(r"^/schema: 'dynaeval/results/v1' != 'dynaeval/results/v2'$"
                         r"|^/summary_status: only after: "
                         r"|^/warnings\[\d+\]/status: only after: ")
"""The differences a v1 -> v2 comparison expects (``--statuses-added``)."""


def differences(a: object, b: object, path: str = "") -> list[str]:
    """Every place where two JSON values differ, as ``path: before != after`` lines."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in [*a, *(k for k in b if k not in a)]:
            if not path and k in IGNORED:
                continue
            if k not in a or k not in b:
                side = "after" if k not in a else "before"
                out.append(f"{path}/{k}: only {side}: {str(b.get(k, a.get(k)))[:120]}")
            else:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{path}[{i}]")]
    return [] if a == b else [f"{path}: {str(a)[:150]!r} != {str(b)[:150]!r}"]


def main(before: Path, after: Path, roots: tuple[str, str] | None = None,
         statuses_added: bool = False) -> int:
    bad = 0
    for f in sorted(before.glob("*.json")):
        g = after / f.name
        if not g.exists():
            print(f"{f.name}: missing after")
            bad += 1
            continue
        text = f.read_text()
        if roots:
            text = text.replace(json.dumps(roots[0])[1:-1], json.dumps(roots[1])[1:-1])
        a, b = json.loads(text), json.loads(g.read_text())
        out = differences(a, b)
        out += [f"/{s}: key order differs" for s in ORDERED
                if s in a and list(a[s]) != list(b.get(s, {}))]
        added = [d for d in out if statuses_added and ADDED_BY_V2.match(d)]
        out = [d for d in out if d not in added]
        note = f" ({len(added)} status fields added)" if added else ""
        print(f"{f.name}: {'same' if not out else f'{len(out)} differences'}{note}")
        for line in out[:30]:
            print("   ", line)
        bad += bool(out)
    for f in sorted(before.glob("*.txt")):
        g = after / f.name
        if g.exists() and g.read_text() != f.read_text():
            print(f"{f.name}: printed table differs")
            bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    args = sys.argv[1:]
    added = "--statuses-added" in args
    args = [a for a in args if a != "--statuses-added"]
    if len(args) not in (2, 4):
        sys.exit(__doc__)
    roots = (args[2], args[3]) if len(args) == 4 else None
    sys.exit(main(Path(args[0]), Path(args[1]), roots, added))

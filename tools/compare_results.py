"""compare_results.py BEFORE AFTER [ROOT_BEFORE ROOT_AFTER]: every results JSON of BEFORE against
AFTER, number for number.

With two checkout roots, paths under ROOT_BEFORE in BEFORE count as equal to the same paths under
ROOT_AFTER (``dynaeval demo`` scores the sample inside its own checkout).

Compares every field exactly (floats with ``==``) except ``created`` and ``timing``, checks that
``summary``, ``metrics`` and ``counts`` keep their key order (the order of the printed tables),
and that the printed tables (``*.txt`` beside the JSON) are the same text. A BEFORE file of
results schema v1 against an AFTER file of v2 may differ only by v2's additions: the ``schema``
string and the ``status`` / ``summary_status`` fields (counted and printed, not differences).
Prints every
difference; exits 1 when there is one. Written for the before/after check of a refactor
(``tools/score_sample_configs.sh``, docs/architecture.md).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

IGNORED = ("created", "timing")
V2_ADDED = ("status", "summary_status")
"""Keys results schema v2 adds beside the values of v1 (docs/results-format.md)."""
ADDED = ("temporal_parts",)
"""Top-level keys a later v2 writer adds (issue 41: the sides of the temporal terms): present
only after, they are counted and printed, not differences."""
ORDERED = ("summary", "metrics", "counts")


def differences(a: object, b: object, path: str = "", added: list[str] | None = None,
                v1_to_v2: bool = False) -> list[str]:
    """Every place where two JSON values differ, as ``path: before != after`` lines. With
    ``added`` (a list), top-level keys of ``ADDED`` present only after (and with ``v1_to_v2``
    the keys of ``V2_ADDED``) are appended to it instead."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in [*a, *(k for k in b if k not in a)]:
            if not path and k in IGNORED:
                continue
            if added is not None and not path and k not in a and k in ADDED:
                added.append(f"/{k}")
                continue
            if v1_to_v2 and added is not None and k not in a and k in V2_ADDED:
                added.append(f"{path}/{k}")
                continue
            if v1_to_v2 and not path and k == "schema":
                continue
            if k not in a or k not in b:
                side = "after" if k not in a else "before"
                out.append(f"{path}/{k}: only {side}: {str(b.get(k, a.get(k)))[:120]}")
            else:
                out += differences(a[k], b[k], f"{path}/{k}", added, v1_to_v2)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{path}[{i}]", added, v1_to_v2)]
    return [] if a == b else [f"{path}: {str(a)[:150]!r} != {str(b)[:150]!r}"]


def main(before: Path, after: Path, roots: tuple[str, str] | None = None) -> int:
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
        v1_to_v2 = (a.get("schema") == "dynaeval/results/v1"
                    and b.get("schema") == "dynaeval/results/v2")
        added: list[str] = []
        out = differences(a, b, "", added, v1_to_v2)
        out += [f"/{s}: key order differs" for s in ORDERED
                if s in a and list(a[s]) != list(b.get(s, {}))]
        note = (f" (schema v1 -> v2: {len(added)} status fields added)" if v1_to_v2
                else f" (added: {', '.join(added)})" if added else "")
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
    if len(sys.argv) not in (3, 5):
        sys.exit(__doc__)
    roots = (sys.argv[3], sys.argv[4]) if len(sys.argv) == 5 else None
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2]), roots))

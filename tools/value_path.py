"""value_path.py [ROOT] [--key focused_ssim|ssim|warp_error] [--prepared]: the files and functions
one reported number crosses, input to JSON key, and which of them only pass it on.

Scores the bundled sample through the CLI (``dynaeval score pred gt --focus boxes:boxes.json
--no-lpips --workers 1``) with the checkout at ROOT (default: this one) and follows the
``focused_ssim`` (or the whole-frame ``ssim``, or the temporal ``warp_error`` of the pair ending
at that frame; ``--prepared``: with the ground truth prepared first) of ``cam07/0003``. A
dynaeval function counts when it is on the call stack

1. when the prediction ``pred/cam07/0003.png`` is decoded (``io.images.decode_file``),
2. when that frame's value is computed (``metrics.structural.ssim`` with boxes, without;
   ``metrics.temporal_pairs.pair_terms`` of the pair), or
3. when it is called with, or returns, the value itself (in its arguments or return value, up
   to three levels into dicts, lists and tuples): the row, the rows, the summary, the document.

Prints the number of files and of distinct named functions (``file:function``; comprehensions and
lambdas not counted), then the list: first the path from the input to the JSON key (everything
until the library's ``score`` returns, then what leads to writing the results text), then the
console output that reads the finished document (the table, the warnings printed). A function
marked ``*`` only passes things on: each of its calls returned the very object one of its own
calls returned, and it called at most ``MAX_CALLS`` dynaeval functions itself (the one it forwards
to and bookkeeping such as progress). Used for the before/after of issues 31 and 41
(``python tools/value_path.py`` here and in an older checkout).
"""

from __future__ import annotations

import json
import sys
import tempfile
import threading
from pathlib import Path

CAMERA, FRAME = "cam07", "0003"
WRITERS = ("results_text", "write_json_atomic")
"""The functions that make the results file's text (now; before issue 31's refactor)."""
KEYS = {
    "focused_ssim": ("structural.py", "ssim", "boxes"),
    "ssim": ("structural.py", "ssim", None),
    "warp_error": ("temporal_pairs.py", "pair_terms", "index"),
}
"""The values it can follow: result key -> (file, function, what marks the target frame's call):
``boxes`` given (focused), no ``boxes`` (whole frame), ``index`` the frame's position (a pair
ending at the frame)."""
MAX_CALLS = 3
"""A pass-through function calls at most this many dynaeval functions itself: the one it
forwards to and its bookkeeping (progress, timing)."""


def _holds(obj: object, value: float, depth: int = 3) -> bool:
    if isinstance(obj, float):
        return obj == value
    if depth == 0:
        return False
    if isinstance(obj, dict):
        return len(obj) < 2000 and any(_holds(v, value, depth - 1) for v in obj.values())
    if isinstance(obj, list | tuple):
        return len(obj) < 2000 and any(_holds(v, value, depth - 1) for v in obj)
    return False


def _run(root: Path, sample: Path, out: Path, extra: list[str], hook: object = None) -> dict:
    sys.path.insert(0, str(root))
    from dynaeval.cli import main

    args = ["score", str(sample / "pred"), str(sample / "gt"), "--focus",
            f"boxes:{sample / 'boxes.json'}", "--no-lpips", "--workers", "1", "-q", "-o",
            str(out), "--overwrite", *extra]
    if hook is not None:
        threading.setprofile(hook)
        sys.setprofile(hook)
    import contextlib
    import io

    try:
        with contextlib.redirect_stdout(io.StringIO()):
            main(args)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    return json.loads(out.read_text())


def _prepare(root: Path, sample: Path, folder: Path) -> list[str]:
    """``dynaeval prepare`` of the sample's ground truth (not traced); the run's extra options."""
    sys.path.insert(0, str(root))
    import contextlib
    import io

    from dynaeval.cli import main

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        main(["prepare", str(sample / "gt"), "-o", str(folder), "--focus",
              f"boxes:{sample / 'boxes.json'}", "-q"])
    return ["--prepared", str(folder)]


class _Forwarding:
    """Finds the pass-through functions: an invocation forwards when it returns the very object
    one of its direct dynaeval callees returned and called at most ``MAX_CALLS`` dynaeval
    functions itself; a function passes things on when every invocation of it seen forwards."""

    def __init__(self, pkg: str) -> None:
        self.pkg = pkg
        self.live: dict[int, tuple[list, set]] = {}  # frame id -> (callees' results, callees)
        self.verdicts: dict[tuple[str, str], set[bool]] = {}

    def call(self, frame: object) -> None:
        self.live[id(frame)] = ([], set())
        back = frame.f_back
        if back is not None and id(back) in self.live:
            self.live[id(back)][1].add(frame.f_code)

    def ret(self, frame: object, value: object, name: tuple[str, str]) -> None:
        results, callees = self.live.pop(id(frame), ([], set()))
        back = frame.f_back
        if back is not None and id(back) in self.live:
            self.live[id(back)][0].append(value)
        forwards = (value is not None and len(callees) <= MAX_CALLS
                    and any(value is r for r in results))
        self.verdicts.setdefault(name, set()).add(forwards)

    def passes_on(self, name: tuple[str, str]) -> bool:
        return self.verdicts.get(name) == {True}


def main(root: Path, key: str = "focused_ssim", prepared: bool = False) -> dict:
    pkg = str(root / "dynaeval")
    sample = root / "dynaeval" / "data" / "sample"
    target = str(sample / "pred" / CAMERA / f"{FRAME}.png")
    file_, func, mark = KEYS[key]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.json"
        extra = _prepare(root, sample, Path(tmp) / "prep") if prepared else []
        doc = _run(root, sample, out, extra)
        frames = doc["frames"]
        value = next(f[key] for f in frames if f["camera"] == CAMERA and f["frame"] == FRAME)
        position = next(f["index"] for f in frames
                        if f["camera"] == CAMERA and f["frame"] == FRAME)
        seen: set[tuple[str, str]] = set()
        console: set[tuple[str, str]] = set()
        scored = [False]  # the library's score has returned: the document is complete
        forwarding = _Forwarding(pkg)

        def name_of(frame: object) -> tuple[str, str]:
            return frame.f_code.co_filename[len(str(root)) + 1:], frame.f_code.co_name

        def stack(frame: object) -> None:
            found, writes = [], False
            while frame is not None:
                if frame.f_code.co_filename.startswith(pkg) and not frame.f_code.co_name.startswith("<"):
                    found.append(name_of(frame))
                    writes |= frame.f_code.co_name in WRITERS
                frame = frame.f_back
            (seen if writes or not scored[0] else console).update(found)

        def on_target(frame: object) -> bool:
            while frame is not None:
                loc = frame.f_locals
                pair = loc.get("pair")
                if pair is not None and str(getattr(pair, "pred", "")).endswith(
                        f"{CAMERA}/{FRAME}.png"):
                    return True
                pairs = loc.get("pairs")
                if (mark == "index" and isinstance(pairs, list) and pairs
                        and getattr(pairs[0], "camera", None) == CAMERA):
                    return True
                frame = frame.f_back
            return False

        def is_target_call(code: object, loc: dict, frame: object) -> bool:
            if code.co_name != func or not code.co_filename.endswith(file_):
                return False
            if mark == "boxes" and loc.get("boxes") is None:
                return False
            if mark is None and loc.get("boxes") is not None:
                return False
            if mark == "index" and loc.get("index") != position:
                return False
            return on_target(frame)

        def hook(frame, event, arg):  # noqa: ANN001, ANN202
            code = frame.f_code
            if not code.co_filename.startswith(pkg):
                return
            if event == "call":
                forwarding.call(frame)
                loc = frame.f_locals
                if code.co_name == "decode_file" and str(loc.get("path")) == target:
                    stack(frame)
                elif is_target_call(code, loc, frame):
                    stack(frame)
                elif any(_holds(v, value) for v in list(loc.values())[:code.co_argcount + 4]):
                    stack(frame)
            elif event == "return":
                if _holds(arg, value):
                    stack(frame)
                forwarding.ret(frame, arg, name_of(frame))
            if (event == "return" and code.co_name == "score"
                    and code.co_filename.endswith("evaluate.py")):
                scored[0] = True

        _run(root, sample, out, extra, hook)
    console -= seen
    report = {}
    for title, group in (("input -> JSON key", seen), ("then printed by", console)):
        files = sorted({f for f, _ in group})
        passing = sorted(n for n in group if forwarding.passes_on(n))
        how = " with --prepared" if prepared else ""
        print(f"{key} of {CAMERA}/{FRAME}{how}, {title}: {len(files)} files, {len(group)} "
              f"functions, {len(passing)} pass things on (*)")
        for f in files:
            names = sorted(n + ("*" if forwarding.passes_on((f, n)) else "")
                           for g, n in group if g == f)
            print(f"  {f}: {', '.join(names)}")
        report[title] = {"files": len(files), "functions": len(group), "pass": passing}
    return report


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("root", nargs="?", type=Path, default=Path(__file__).resolve().parents[1])
    parser.add_argument("--key", choices=sorted(KEYS), default="focused_ssim")
    parser.add_argument("--prepared", action="store_true",
                        help="score with the ground truth prepared first (dynaeval prepare)")
    a = parser.parse_args()
    main(a.root.resolve(), a.key, a.prepared)

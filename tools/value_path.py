"""value_path.py [ROOT]: the files and functions one reported number crosses, input to JSON key.

Scores the bundled sample through the CLI (``dynaeval score pred gt --focus boxes:boxes.json
--no-lpips --workers 1``) with the checkout at ROOT (default: this one) and follows the
``focused_ssim`` of ``cam07/0003``. A dynaeval function counts when it is on the call stack

1. when the prediction ``pred/cam07/0003.png`` is decoded (``io.images.decode_file``),
2. when that frame's focused SSIM is computed (``metrics.structural.ssim`` with boxes), or
3. when it is called with, or returns, the value itself (in its arguments or return value, up
   to three levels into dicts, lists and tuples): the row, the rows, the summary, the document.

Prints the number of files and of distinct named functions (``file:function``; comprehensions and
lambdas not counted), then the list: first the path from the input to the JSON key (everything
until the library's ``score`` returns, then what leads to writing the results text), then the
console output that reads the finished document (the table, the warnings printed). Used for
the before/after of issue 31 (``python tools/value_path.py`` here and in an older checkout).
"""

from __future__ import annotations

import json
import sys
import tempfile
import threading
from pathlib import Path

KEY, CAMERA, FRAME = "focused_ssim", "cam07", "0003"
WRITERS = ("results_text", "write_json_atomic")
"""The functions that make the results file's text (now; before issue 31's refactor)."""


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


def _run(root: Path, sample: Path, out: Path, hook: object = None) -> dict:
    sys.path.insert(0, str(root))
    from dynaeval.cli import main

    args = ["score", str(sample / "pred"), str(sample / "gt"), "--focus",
            f"boxes:{sample / 'boxes.json'}", "--no-lpips", "--workers", "1", "-q", "-o",
            str(out), "--overwrite"]
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


def main(root: Path) -> None:
    pkg = str(root / "dynaeval")
    sample = root / "dynaeval" / "data" / "sample"
    target = str(sample / "pred" / CAMERA / f"{FRAME}.png")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.json"
        doc = _run(root, sample, out)
        value = next(f[KEY] for f in doc["frames"]
                     if f["camera"] == CAMERA and f["frame"] == FRAME)
        seen: set[tuple[str, str]] = set()
        console: set[tuple[str, str]] = set()
        scored = [False]  # the library's score has returned: the document is complete

        def stack(frame: object) -> None:
            found, writes = [], False
            while frame is not None:
                if frame.f_code.co_filename.startswith(pkg) and not frame.f_code.co_name.startswith("<"):
                    found.append((frame.f_code.co_filename[len(str(root)) + 1:],
                                  frame.f_code.co_name))
                    writes |= frame.f_code.co_name in WRITERS
                frame = frame.f_back
            (seen if writes or not scored[0] else console).update(found)

        def on_target_frame(frame: object) -> bool:
            while frame is not None:
                pair = frame.f_locals.get("pair")
                if pair is not None and str(getattr(pair, "pred", "")).endswith(
                        f"{CAMERA}/{FRAME}.png"):
                    return True
                frame = frame.f_back
            return False

        def hook(frame, event, arg):  # noqa: ANN001, ANN202
            code = frame.f_code
            if not code.co_filename.startswith(pkg):
                return
            if event == "call":
                loc = frame.f_locals
                if code.co_name == "decode_file" and str(loc.get("path")) == target:
                    stack(frame)
                elif (code.co_name == "ssim" and code.co_filename.endswith("structural.py")
                      and loc.get("boxes") is not None and on_target_frame(frame)):
                    stack(frame)
                elif any(_holds(v, value) for v in list(loc.values())[:code.co_argcount + 4]):
                    stack(frame)
            elif event == "return" and _holds(arg, value):
                stack(frame)
            if (event == "return" and code.co_name == "score"
                    and code.co_filename.endswith("evaluate.py")):
                scored[0] = True

        _run(root, sample, out, hook)
    console -= seen
    for title, group in (("input -> JSON key", seen), ("then printed by", console)):
        files = sorted({f for f, _ in group})
        print(f"{KEY} of {CAMERA}/{FRAME}, {title}: {len(files)} files, {len(group)} functions")
        for f in files:
            print(f"  {f}: {', '.join(sorted(n for g, n in group if g == f))}")


if __name__ == "__main__":
    main(Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else Path(__file__).resolve().parents[1])

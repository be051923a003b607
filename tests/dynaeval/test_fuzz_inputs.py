"""Fuzz: random valid and corrupted inputs never give a traceback, a NaN or a half file (issue 16);
a prepared folder with any file changed, cut or deleted is exit 2 naming it (issue 34).

Each example writes one camera (a flat folder of images, or one video) into ``pred/`` and ``gt/``:
PNG / JPEG / TIFF / EXR / MP4, sizes 1x1 to 10x10000, grey, RGB, RGBA, 8/16-bit and float, with
NaN, Inf, huge or out-of-range floats, truncated or random bytes, a PNG under a ``.jpg`` name,
and runs ``dynaeval.cli.main(["score", ...])``. Whatever comes: exit 0 or 2, no "Traceback" on
stderr, a strict-JSON results file with no NaN when 0, no results file when 2, and nothing but
the results file next to ``-o``.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dynaeval.cli import main  # noqa: E402

SIZES = [(1, 1), (2, 3), (7, 9), (11, 11), (16, 16), (24, 32), (10, 10000), (10000, 10)]
FORMATS = {
    ".png": ("uint8", "uint16"),
    ".jpg": ("uint8",),
    ".tif": ("uint8", "uint16", "float32", "float64", "int16", "int32"),  # int: exit 2 by name
    ".exr": ("float32",),
}
CORRUPTIONS = ["none", "none", "none", "truncate", "garbage", "nan", "inf", "huge", "negative",
               "png_as_jpg", "empty"]


@st.composite
def frame_spec(draw):  # noqa: ANN001, ANN201
    ext = draw(st.sampled_from(sorted(FORMATS)))
    return {
        "ext": ext,
        "dtype": draw(st.sampled_from(FORMATS[ext])),
        "channels": draw(st.sampled_from([1, 3, 4] if ext != ".exr" else [1, 3])),
        "size": draw(st.sampled_from(SIZES)),
        "corrupt": draw(st.sampled_from(CORRUPTIONS)),
        "side": draw(st.sampled_from(["pred", "gt"])),
    }


@st.composite
def scene_spec(draw):  # noqa: ANN001, ANN201
    video = draw(st.booleans()) and draw(st.booleans())  # a quarter of the scenes are MP4
    if video:
        frames = [{"corrupt": draw(st.sampled_from(["none", "bytes", "truncate", "garbage"])),
                   "side": draw(st.sampled_from(["pred", "gt"]))}]
    else:
        n = draw(st.integers(1, 3))
        first = draw(frame_spec())
        same = draw(st.booleans())  # a video-like camera, or unrelated photos
        frames = [first if same else draw(frame_spec()) for _ in range(n)]
        if same:  # only the first keeps its corruption: the others are valid frames
            frames = [first] + [{**first, "corrupt": "none"} for _ in range(n - 1)]
    return {"video": video, "frames": frames, "seed": draw(st.integers(0, 2**16)),
            "focus": draw(st.sampled_from(["none", "motion"])),
            "temporal": draw(st.booleans())}


def _pixels(rng: np.random.Generator, spec: dict) -> np.ndarray:
    h, w = spec["size"]
    c = spec["channels"]
    if spec["dtype"].startswith("float"):
        img = rng.random((h, w, c)).astype(spec["dtype"])
    else:
        top = np.iinfo(spec["dtype"]).max
        img = rng.integers(0, top, (h, w, c), endpoint=True).astype(spec["dtype"])
    if spec["corrupt"] in ("nan", "inf", "huge", "negative") and img.dtype.kind == "f":
        img.flat[rng.integers(img.size)] = {"nan": np.nan, "inf": np.inf, "huge": 1e30,
                                            "negative": -3.0}[spec["corrupt"]]
    return img[..., 0] if c == 1 else img


def _encode(img: np.ndarray, ext: str) -> bytes:
    if ext == ".exr":
        import OpenEXR

        hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        key = "Y" if img.ndim == 2 else "RGB"
        with tempfile.TemporaryDirectory() as d:
            with OpenEXR.File(hdr, {key: np.ascontiguousarray(img)}) as f:
                f.write(f"{d}/x.exr")
            return Path(f"{d}/x.exr").read_bytes()
    ok, buf = cv2.imencode(ext, img)
    assert ok
    return buf.tobytes()


def _damage(data: bytes, how: str, rng: np.random.Generator) -> bytes:
    if how == "truncate":
        return data[: max(1, len(data) // 2)]
    if how == "garbage":
        return rng.integers(0, 256, max(8, len(data) // 4), dtype=np.uint8).tobytes()
    if how == "bytes":  # damage in the middle
        b = bytearray(data)
        k = len(b) // 3
        b[k:k + 200] = rng.integers(0, 256, len(b[k:k + 200]), dtype=np.uint8).tobytes()
        return bytes(b)
    if how == "empty":
        return b""
    return data


def _write_images(root: Path, spec: dict, rng: np.random.Generator) -> None:
    for i, f in enumerate(spec["frames"]):
        gt = _pixels(rng, f)
        noise = rng.normal(0, 0.02, gt.shape)
        if gt.dtype.kind == "f":
            pred = np.clip(gt + noise, 0, 1).astype(gt.dtype) if np.isfinite(gt).all() and \
                gt.max() <= 1 and gt.min() >= 0 else gt.copy()
        else:
            top = np.iinfo(gt.dtype).max
            pred = np.clip(gt + noise * top, 0, top).astype(gt.dtype)
        for side, img in (("gt", gt), ("pred", pred)):
            ext = f["ext"]
            if side != f["side"] and f["corrupt"] in ("nan", "inf", "huge", "negative"):
                img = np.nan_to_num(np.clip(img, 0, 1)).astype(img.dtype)
            data = _encode(img, ext if f["corrupt"] != "png_as_jpg" else ".png")
            name = f"{i:04d}" + (".jpg" if f["corrupt"] == "png_as_jpg" else ext)
            if side == f["side"]:
                data = _damage(data, f["corrupt"], rng)
            (root / side / name).write_bytes(data)


def _write_video(root: Path, spec: dict, rng: np.random.Generator) -> None:
    f = spec["frames"][0]
    for side in ("gt", "pred"):
        path = root / side / "cam.mp4"
        w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (32, 24))
        for _ in range(4):
            w.write(rng.integers(0, 256, (24, 32, 3), dtype=np.uint8))
        w.release()
        if side == f["side"]:
            path.write_bytes(_damage(path.read_bytes(), f["corrupt"], rng))


def _strict(text: str) -> object:
    def refuse(token: str) -> None:
        raise ValueError(f"non-strict JSON token {token}")

    return json.loads(text, parse_constant=refuse)


@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(scene_spec())
def test_score_on_random_inputs_exits_0_or_2_without_traceback(spec):
    rng = np.random.default_rng(spec["seed"])
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        for side in ("gt", "pred", "out"):
            (root / side).mkdir()
        (_write_video if spec["video"] else _write_images)(root, spec, rng)
        out = root / "out" / "results.json"
        argv = ["score", str(root / "pred"), str(root / "gt"), "-o", str(out), "--no-lpips",
                "--focus", spec["focus"], "--allow-missing"]
        if not spec["temporal"]:
            argv.append("--no-temporal")
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        stderr = err.getvalue()
        assert code in (0, 2), stderr
        assert "Traceback" not in stderr, stderr
        written = sorted(p.name for p in (root / "out").iterdir())
        if code == 0:
            assert written == ["results.json"], written
            doc = _strict(out.read_text())
            assert "NaN" not in out.read_text()
            assert doc["frames"]
        else:
            assert written == [], written
            assert stderr.strip(), "exit 2 says why"


_PREPARED: dict[str, Path] = {}


def _prepared_sample() -> Path:
    """The bundled sample's ground truth prepared once per session (motion focus)."""
    if "path" not in _PREPARED:
        from dynaeval.cli import sample_dir
        from dynaeval.regions.focus import FocusConfig
        from dynaeval.run.prepare import prepare

        out = Path(tempfile.mkdtemp(prefix="dynaeval-fuzz-prep-")) / "prep"
        prepare(sample_dir() / "gt", out, focus=FocusConfig(source="motion"), progress=False)
        _PREPARED["path"] = out
    return _PREPARED["path"]


@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 10**6), st.sampled_from(["truncate", "garbage", "bytes", "empty", "delete",
                                               "same"]))
def test_score_with_a_mutated_prepared_folder_is_exit_2_naming_the_file(seed, how):
    """Issue 34 item 1: any prepared file (manifest included) changed, cut or deleted is exit 2
    naming it; an untouched copy scores as without ``--prepared``."""
    import shutil

    from dynaeval.cli import sample_dir

    rng = np.random.default_rng(seed)
    with tempfile.TemporaryDirectory() as d:
        prep = Path(d) / "prep"
        shutil.copytree(_prepared_sample(), prep)
        files = sorted(p for p in prep.rglob("*") if p.is_file())
        target = files[int(rng.integers(len(files)))]
        if how == "delete":
            target.unlink()
        elif how != "same":
            data = target.read_bytes()
            damaged = _damage(data, how, rng)
            if damaged == data:  # garbage of the same bytes cannot happen; keep it honest
                damaged = data + b"\0"
            target.write_bytes(damaged)
        out = Path(d) / "r.json"
        argv = ["score", str(sample_dir() / "pred"), str(sample_dir() / "gt"), "--focus",
                "motion", "--no-lpips", "-q", "--prepared", str(prep), "-o", str(out)]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        stderr = err.getvalue()
        assert "Traceback" not in stderr, stderr
        if how == "same":
            assert code == 0, stderr
            return
        assert code == 2, (target, how, stderr)
        named = str(target) if target.name != "manifest.json" else str(target.parent)
        assert named in stderr, (target, stderr)
        assert not out.exists()


_SHARDS: dict[str, list[str]] = {}


def _sample_shards() -> list[str]:
    """The texts of the bundled sample scored as two shards (``--shard 1/2``, ``2/2``), once per
    session: detector boxes, objects, temporal terms and their warnings, regions, the shard."""
    if "texts" not in _SHARDS:
        from dynaeval.cli import sample_dir

        out = Path(tempfile.mkdtemp(prefix="dynaeval-fuzz-shards-"))
        texts = []
        for i in (1, 2):
            argv = ["score", str(sample_dir() / "pred"), str(sample_dir() / "gt"), "--no-lpips",
                    "-q", "--shard", f"{i}/2", "-o", str(out / f"s{i}.json")]
            with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
                assert main(argv) == 0
            texts.append((out / f"s{i}.json").read_text())
        _SHARDS["texts"] = texts
    return _SHARDS["texts"]


def _places(value: object, where: tuple = ()) -> list[tuple]:
    """Every key path of a parsed document (dict keys and list positions), the root excluded."""
    items = (value.items() if isinstance(value, dict)
             else enumerate(value) if isinstance(value, list) else ())
    out = []
    for key, sub in items:
        out.append((*where, key))
        out.extend(_places(sub, (*where, key)))
    return out


SWAPS = ["31.5", "x", "", True, False, None, 0, -1, 1.5, 1e308, -1e300, 2**70, [], {}, [1, "a"],
         {"index": 1}, {"reason": 3}]
"""What a value is swapped for: the type mistakes of a hand edit and the edge values."""

TOKENS = ["1e999", "-1e999", "9" * 5000, "NaN", "Infinity", '"\\ud800"', "true", '"31.5"']
"""What a number of the text is replaced by."""


def _mutate(text: str, how: str, rng: np.random.Generator) -> str:
    import re

    doc = json.loads(text)
    places = _places(doc)
    place = places[int(rng.integers(len(places)))]
    parent = doc
    for key in place[:-1]:
        parent = parent[key]
    if how == "swap":
        parent[place[-1]] = SWAPS[int(rng.integers(len(SWAPS)))]
    elif how == "delete":
        del parent[place[-1]]
    elif how == "deep":
        parent[place[-1]] = None
        marker = json.dumps(doc)
        depth = int(rng.choice([65, 1000, 300_000]))
        return marker.replace("null", "[" * depth + "]" * depth, 1) if "null" in marker else marker
    elif how == "number":
        numbers = list(re.finditer(r"(?<=[:\[,] )-?\d+(\.\d+)?([eE][-+]?\d+)?", text))
        m = numbers[int(rng.integers(len(numbers)))]
        token = TOKENS[int(rng.integers(len(TOKENS)))]
        return text[:m.start()] + token + text[m.end():]
    elif how == "truncate":
        return text[: int(rng.integers(1, len(text)))]
    return json.dumps(doc, indent=1, ensure_ascii=False)


@settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 10**6), st.sampled_from(["swap", "swap", "delete", "deep", "number",
                                               "truncate"]), st.integers(0, 1))
def test_leaderboard_and_merge_of_a_mutated_results_file_exit_0_or_2(seed, how, which):
    """Issue 34 item 3: a shard's results file with a value swapped for another type, a key
    deleted, a value nested deep, a number made 1e999 / NaN / 5000 digits / a string, or the text
    cut: ``leaderboard`` and ``merge`` exit 0 or 2, never a traceback; on 2 nothing is written,
    on 0 the merged file reads back."""
    from dynaeval.report import load_results

    rng = np.random.default_rng(seed)
    texts = list(_sample_shards())
    texts[which] = _mutate(texts[which], how, rng)
    with tempfile.TemporaryDirectory() as d:
        paths = [Path(d) / f"s{i}.json" for i in (1, 2)]
        for path, text in zip(paths, texts, strict=True):
            path.write_text(text, encoding="utf-8", errors="surrogatepass")
        merged = Path(d) / "merged.json"
        for argv in (["leaderboard", str(paths[which])],
                     ["merge", *map(str, paths), "-o", str(merged)]):
            err, out = io.StringIO(), io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                code = main(argv)
            stderr = err.getvalue()
            assert code in (0, 2), (how, argv[0], stderr)
            assert "Traceback" not in stderr, (how, argv[0], stderr)
            if code == 2:
                assert str(paths[which]) in stderr or "shard" in stderr, (how, stderr)
                assert argv[0] != "merge" or not merged.exists()
            elif argv[0] == "leaderboard":
                assert out.getvalue().startswith("| method"), out.getvalue()
        if merged.exists():
            assert load_results(merged)["summary"]["n_frames"] >= 0

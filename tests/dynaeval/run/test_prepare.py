"""``dynaeval prepare``: a prepared ground truth gives the numbers of a run without it, bit for bit,
and is refused (exit 2, naming the file or the setting) when the ground truth or a setting changed."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from dynaeval import score
from dynaeval.cli import main, sample_dir
from dynaeval.errors import InputError
from dynaeval.regions.focus import FocusConfig
from dynaeval.run.prepare import prepare

SAMPLE = sample_dir()
FAST = {"metrics": ("psnr", "ssim"), "progress": False}
VOLATILE = ("timing", "created")


def _comparable(results: dict) -> dict:
    """The results without what may differ between equal runs (timing, date) and the record of
    the prepared ground truth itself."""
    doc = json.loads(json.dumps(results))
    for key in VOLATILE:
        doc.pop(key, None)
    doc["settings"].pop("prepared", None)
    return doc


@pytest.fixture(scope="module")
def prepared_motion(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("prep") / "motion"
    prepare(SAMPLE / "gt", out, focus=FocusConfig(source="motion"), progress=False)
    return out


@pytest.mark.parametrize("source", ["motion", "detector", "boxes"])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_prepared_results_are_bit_identical(tmp_path, prepared_motion, source, workers):
    focus = (FocusConfig.parse(f"boxes:{SAMPLE / 'boxes.json'}") if source == "boxes" else
             FocusConfig(source=source))
    if source == "motion":
        prep = prepared_motion
    else:
        prep = tmp_path / "prep"
        prepare(SAMPLE / "gt", prep, focus=focus, progress=False, workers=workers)
    plain = score(SAMPLE / "pred", SAMPLE / "gt", focus=focus, workers=workers, **FAST)
    fast = score(SAMPLE / "pred", SAMPLE / "gt", focus=focus, workers=workers, prepared=str(prep),
                 **FAST)
    assert _comparable(fast) == _comparable(plain)
    used = fast["settings"]["prepared"]
    assert used["path"] == str(prep) and not any("computed again" in w["reason"]
                                                 for w in fast["warnings"])
    assert used["id"] == json.loads((prep / "manifest.json").read_text())["id"]
    assert "prepared" not in plain["settings"]


def test_shards_with_prepared_merge_into_the_unprepared_numbers(tmp_path, prepared_motion):
    from dynaeval.report import write_json_atomic
    from dynaeval.report.merge import merge_results

    kw = {"focus": FocusConfig(source="motion"), **FAST}
    whole = score(SAMPLE / "pred", SAMPLE / "gt", **kw)
    parts = []
    for i in (1, 2):
        part = score(SAMPLE / "pred", SAMPLE / "gt", shard=(i, 2), prepared=str(prepared_motion),
                     **kw)
        parts.append(write_json_atomic(tmp_path / f"s{i}.json", part))
    merged = merge_results(parts)
    for key in ("frames", "cameras", "summary"):
        assert merged[key] == _comparable(whole)[key]


def test_prepared_flows_are_read_not_computed(prepared_motion, monkeypatch):
    """The ground-truth flows come from the folder: only the predictions' flows are computed."""
    from dynaeval.metrics import flow

    calls = []
    real = flow.flow_from_gray
    monkeypatch.setattr(flow, "flow_from_gray", lambda *a: calls.append(1) or real(*a))
    score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"),
          prepared=str(prepared_motion), **FAST)
    assert len(calls) == 14  # 2 cameras x 7 pairs, one prediction flow each (GT: 2 x 14 read)


def _count_calls(monkeypatch, module, name: str) -> list:
    calls: list = []
    real = getattr(module, name)
    monkeypatch.setattr(module, name, lambda *a, **k: calls.append(1) or real(*a, **k))
    return calls


def test_a_prepared_run_computes_no_ground_truth_half_of_a_pair(prepared_motion, monkeypatch):
    """Issue 33: the ground truth's gray images (and their hashes), the visibility of its
    flows, its warp and its warping errors are read from the prepared folder: a prepared run
    makes the predictions' gray images only and warps the predictions only."""
    from dynaeval.metrics import pair_kernels, temporal_pairs

    visible = _count_calls(monkeypatch, temporal_pairs, "visibility")
    gray = _count_calls(monkeypatch, pair_kernels, "gray_of_checked")
    warps = _count_calls(monkeypatch, pair_kernels, "warp_on_grid")
    kw = {"focus": FocusConfig(source="motion"), **FAST}
    fast = score(SAMPLE / "pred", SAMPLE / "gt", prepared=str(prepared_motion), **kw)
    assert (len(visible), len(gray), len(warps)) == (0, 16, 14)  # 2 cameras x 8 frames, 7 pairs
    plain = score(SAMPLE / "pred", SAMPLE / "gt", **kw)
    assert (len(visible), len(gray), len(warps)) == (14, 16 + 32, 14 + 28)
    assert _comparable(fast) == _comparable(plain)


def _boxes_with_gaps(tmp_path: Path) -> Path:
    """The sample's boxes with none for some of cam07's frames and for all of eval00's."""
    boxes = json.loads((SAMPLE / "boxes.json").read_text())
    for key in boxes:
        cam, frame = key.split("/")
        if cam == "eval00" or frame in ("0002", "0005", "0006"):
            boxes[key] = []
    path = tmp_path / "boxes.json"
    path.write_text(json.dumps(boxes))
    return path


def test_every_temporal_term_and_status_equals_the_plain_run(tmp_path, monkeypatch):
    """Frames without boxes (focused pairs null, a camera without any: no-region), a camera
    missing a frame (not-consecutive pairs, computed again): every temporal entry, whole and
    focused, with its per-pair values, parts and statuses, is the plain run's bit for bit."""
    from dynaeval.metrics import temporal_pairs

    focus = FocusConfig.parse(f"boxes:{_boxes_with_gaps(tmp_path)}")
    prep = tmp_path / "prep"
    prepare(SAMPLE / "gt", prep, focus=focus, progress=False)
    manifest = json.loads((prep / "manifest.json").read_text())
    eval00 = manifest["cameras"]["eval00"]["gt_pairs"]
    assert all(p["warp_error"][1] is None and p["warp_error"][0] > 0 for p in eval00)
    visible = _count_calls(monkeypatch, temporal_pairs, "visibility")
    fast = score(SAMPLE / "pred", SAMPLE / "gt", focus=focus, prepared=str(prep), **FAST)
    assert not visible
    plain = score(SAMPLE / "pred", SAMPLE / "gt", focus=focus, **FAST)
    assert _comparable(fast) == _comparable(plain)  # per-pair values in the frames, statuses
    cams = plain["cameras"]
    assert cams["eval00"]["focused_warp_error"] is None is cams["eval00"]["focused_flicker"]
    assert cams["cam07"]["focused_warp_error"] is not None and cams["eval00"]["warp_error"] > 0
    assert any(r.get("focused_warp_error", 0) is None and r.get("warp_error") is not None
               for r in plain["frames"] if r["camera"] == "cam07")
    pred = tmp_path / "pred"
    shutil.copytree(SAMPLE / "pred", pred)
    for frame in ("0001", "0003", "0005", "0007"):  # no two eval00 frames left are consecutive
        (pred / "eval00" / f"{frame}.png").unlink()
    kw = {"focus": focus, "allow_missing": True, **FAST}
    fast = score(pred, SAMPLE / "gt", prepared=str(prep), **kw)
    plain = score(pred, SAMPLE / "gt", **kw)
    assert plain["cameras"]["eval00"]["warp_error"] is None
    assert "not-consecutive" in json.dumps(plain)
    fast["warnings"] = [w for w in fast["warnings"] if "computed again" not in w["reason"]]
    assert _comparable(fast) == _comparable(plain)


def test_a_prepared_folder_of_the_previous_format_is_exit_2_saying_prepare_again(
        tmp_path, prepared_motion, capsys):
    """Format 3 held no ground-truth pair terms: refused naming its manifest and the fix."""
    from dynaeval.io.prepared import manifest_id

    prep = tmp_path / "prep"
    shutil.copytree(prepared_motion, prep)
    manifest = json.loads((prep / "manifest.json").read_text())
    manifest["format_version"] = 3
    for cam in manifest["cameras"].values():
        del cam["gt_pairs"]
    manifest["id"] = manifest_id(manifest)
    (prep / "manifest.json").write_text(json.dumps(manifest))
    code = main(["score", str(SAMPLE / "pred"), str(SAMPLE / "gt"), "--focus", "motion",
                 "--prepared", str(prep), "-o", str(tmp_path / "r.json"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and str(prep / "manifest.json") in err and "format version 3" in err
    assert "dynaeval prepare" in err and "Traceback" not in err
    assert not (tmp_path / "r.json").exists()


def _copy_gt(tmp_path: Path) -> Path:
    gt = tmp_path / "gt"
    shutil.copytree(SAMPLE / "gt", gt)
    return gt


def test_changed_gt_file_refused_with_exit_2_naming_it(tmp_path, capsys):
    gt = _copy_gt(tmp_path)
    prep = tmp_path / "prep"
    assert main(["prepare", str(gt), "-o", str(prep), "--focus", "motion", "-q"]) == 0
    victim = sorted((gt / "cam07").iterdir())[3]
    other = sorted((gt / "cam07").iterdir())[4]
    victim.write_bytes(other.read_bytes())  # same size, other content
    out = tmp_path / "r.json"
    code = main(["score", str(SAMPLE / "pred"), str(gt), "--focus", "motion", "--no-lpips", "-q",
                 "--prepared", str(prep), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and str(victim) in err and "changed since it was prepared" in err
    assert not out.exists()


def test_added_gt_file_refused(tmp_path, prepared_motion):
    gt = _copy_gt(tmp_path)
    pred = tmp_path / "pred"
    shutil.copytree(SAMPLE / "pred", pred)
    for root in (gt, pred):
        shutil.copy(root / "cam07" / "0007.png", root / "cam07" / "0008.png")
    with pytest.raises(InputError, match="not in the prepared ground truth") as err:
        score(pred, gt, focus=FocusConfig(source="motion"), prepared=str(prepared_motion), **FAST)
    assert err.value.path is not None and str(err.value.path).endswith("0008.png")


@pytest.mark.parametrize(("override", "setting"), [
    ({"focus": FocusConfig(source="motion", expand="margin")}, "focus.expand.rule"),
    ({"focus": FocusConfig(source="motion"), "flow": "farneback"}, "flow.method"),
    ({"focus": FocusConfig(source="motion"), "background": "black"}, "background"),
    ({"focus": FocusConfig(source="motion"), "protocol": "nerfbaselines"}, "quantize"),
])
def test_mismatched_setting_refused_naming_it(prepared_motion, override, setting):
    with pytest.raises(InputError, match=f"setting '{setting}' differs"):
        score(SAMPLE / "pred", SAMPLE / "gt", prepared=str(prepared_motion), **FAST, **override)


def test_mismatched_setting_exit_2(prepared_motion, capsys):
    code = main(["score", str(SAMPLE / "pred"), str(SAMPLE / "gt"), "--focus", "detector",
                 "--no-lpips", "-q", "--prepared", str(prepared_motion)])
    err = capsys.readouterr().err
    assert code == 2 and """setting 'focus.source' differs from the prepared ground truth's: """ \
        """prepared "motion", this run "detector";""" in err


def test_edited_manifest_refused(tmp_path, prepared_motion):
    prep = tmp_path / "prep"
    shutil.copytree(prepared_motion, prep)
    manifest = json.loads((prep / "manifest.json").read_text())
    manifest["settings"]["focus"]["expand"]["scale_x"] = 6.0
    (prep / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(InputError, match="changed after it was written"):
        score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"),
              prepared=str(prep), **FAST)


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000, '{"format_version": 1e999}',
                                  "{not json"])
def test_a_damaged_manifest_is_exit_2_naming_it(tmp_path, prepared_motion, capsys, text):
    """A manifest nested 100,000 deep (a RecursionError traceback before), holding a number out
    of range, or not JSON: exit 2 naming manifest.json, no traceback."""
    prep = tmp_path / "prep"
    shutil.copytree(prepared_motion, prep)
    (prep / "manifest.json").write_text(text)
    code = main(["score", str(SAMPLE / "pred"), str(SAMPLE / "gt"), "--prepared", str(prep),
                 "--focus", "motion", "--no-lpips", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "manifest.json" in err and "Traceback" not in err, err


def test_no_clobber_and_atomic(tmp_path, prepared_motion, monkeypatch, capsys):
    prep = tmp_path / "prep"
    prep.mkdir()
    (prep / "mine.txt").write_text("keep")
    code = main(["prepare", str(SAMPLE / "gt"), "-o", str(prep), "--focus", "motion", "-q"])
    assert code == 2 and "pass --overwrite" in capsys.readouterr().err
    assert [p.name for p in prep.iterdir()] == ["mine.txt"]
    from dynaeval.run import prepare as module

    def boom(*a, **k):
        raise RuntimeError("interrupted")

    monkeypatch.setattr(module, "_save_flows", boom)  # fails halfway through the first camera
    with pytest.raises(RuntimeError):
        prepare(SAMPLE / "gt", prep, focus=FocusConfig(source="motion"), progress=False,
                overwrite=True)
    assert [p.name for p in prep.iterdir()] == ["mine.txt"]  # untouched
    assert [p.name for p in tmp_path.iterdir()] == ["prep"]  # no temporary folder left
    monkeypatch.undo()
    prepare(SAMPLE / "gt", prep, focus=FocusConfig(source="motion"), progress=False,
            overwrite=True)
    assert (prep / "manifest.json").is_file() and not (prep / "mine.txt").exists()


def test_cli_round_trip(tmp_path, capsys):
    prep, a, b = tmp_path / "prep", tmp_path / "a.json", tmp_path / "b.json"
    assert main(["prepare", str(SAMPLE / "gt"), "-o", str(prep), "--focus", "motion", "-q",
                 "--workers", "2"]) == 0
    assert "28 flows prepared" in capsys.readouterr().out
    flows = list((prep / "flows").glob("*.npy"))
    assert len(flows) == 28 and np.load(flows[0]).dtype == np.float32
    args = [str(SAMPLE / "pred"), str(SAMPLE / "gt"), "--focus", "motion", "--no-lpips", "-q"]
    assert main(["score", *args, "-o", str(a)]) == 0
    assert main(["score", *args, "--prepared", str(prep), "-o", str(b)]) == 0
    ra, rb = (json.loads(p.read_text()) for p in (a, b))
    assert rb["settings"]["prepared"]["path"] == str(prep)
    assert _comparable(ra) == _comparable(rb)
    rb["method"] = "other"  # a leaderboard combines runs against two prepared copies
    ra["settings"]["prepared"] = {"path": "/elsewhere/prep", "id": "0" * 20}
    a.write_text(json.dumps(ra))
    b.write_text(json.dumps(rb))
    capsys.readouterr()
    assert main(["leaderboard", str(a), str(b)]) == 0
    assert "differing setting" not in capsys.readouterr().err


def test_missing_prepared_folder_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="dynaeval prepare"):
        score(SAMPLE / "pred", SAMPLE / "gt", prepared=str(tmp_path / "nope"), **FAST)


def test_camera_with_other_frames_gets_its_regions_computed_again(tmp_path, prepared_motion):
    """--allow-missing with a prediction missing: the camera's motion masks depend on its frames,
    so the prepared ones are not used for it (a warning says so); same numbers as without."""
    pred = tmp_path / "pred"
    shutil.copytree(SAMPLE / "pred", pred)
    (pred / "cam07" / "0007.png").unlink()
    kw = {"focus": FocusConfig(source="motion"), "allow_missing": True, **FAST}
    plain = score(pred, SAMPLE / "gt", **kw)
    fast = score(pred, SAMPLE / "gt", prepared=str(prepared_motion), **kw)
    again = [w for w in fast["warnings"] if "computed again" in w["reason"]]
    assert [w["camera"] for w in again] == ["cam07"]
    fast["warnings"].remove(again[0])
    assert _comparable(fast) == _comparable(plain)


def test_given_masks_apply_on_top_of_prepared_regions(tmp_path, prepared_motion):
    import cv2

    masks = tmp_path / "masks"
    for f in sorted((SAMPLE / "gt").rglob("*.png")):
        img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        m = np.zeros_like(img)
        m[: img.shape[0] // 2, : img.shape[1] // 3] = 255
        target = masks / f.relative_to(SAMPLE / "gt")
        target.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(target), m)
    kw = {"focus": FocusConfig(source="motion"), "masks": str(masks), **FAST}
    plain = score(SAMPLE / "pred", SAMPLE / "gt", **kw)
    fast = score(SAMPLE / "pred", SAMPLE / "gt", prepared=str(prepared_motion), **kw)
    assert "masks" in plain["settings"]
    assert _comparable(fast) == _comparable(plain)
    unmasked = score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"), **FAST)
    assert fast["summary"]["masked_psnr"] != unmasked["summary"]["masked_psnr"]


def _count_std_updates(monkeypatch) -> list:
    from dynaeval.metrics import static_flicker

    calls = []
    real = static_flicker.TemporalStd.update
    monkeypatch.setattr(static_flicker.TemporalStd, "update",
                        lambda self, frame: calls.append(1) or real(self, frame))
    return calls


def test_prepared_static_std_is_read_not_accumulated(prepared_motion, monkeypatch):
    """Flicker accumulates the predictions only: the ground truth's temporal std is prepared."""
    manifest = json.loads((prepared_motion / "manifest.json").read_text())
    assert all(c["flicker"] for c in manifest["cameras"].values())
    calls = _count_std_updates(monkeypatch)
    score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"),
          prepared=str(prepared_motion), **FAST)
    assert len(calls) == 16  # 2 cameras x 8 prediction frames
    calls.clear()
    score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"), **FAST)
    assert len(calls) == 32


def test_given_masks_change_the_static_pixels_so_their_std_is_computed_again(
        tmp_path, prepared_motion, monkeypatch):
    import cv2

    masks = tmp_path / "masks"
    for f in sorted((SAMPLE / "gt").rglob("*.png")):
        m = np.zeros(cv2.imread(str(f), cv2.IMREAD_GRAYSCALE).shape, np.uint8)
        m[:20, :20] = 255
        (masks / f.relative_to(SAMPLE / "gt")).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(masks / f.relative_to(SAMPLE / "gt")), m)
    calls = _count_std_updates(monkeypatch)
    kw = {"focus": FocusConfig(source="motion"), "masks": str(masks), **FAST}
    fast = score(SAMPLE / "pred", SAMPLE / "gt", prepared=str(prepared_motion), **kw)
    assert len(calls) == 32
    assert fast["summary"]["flicker"] is not None
    assert _comparable(fast) == _comparable(score(SAMPLE / "pred", SAMPLE / "gt", **kw))


def test_prepared_ground_truth_images_are_not_decoded_again(prepared_motion, monkeypatch):
    """8-bit ground-truth images are read from their prepared decoding (their digests are still
    checked): a prepared run decodes the predictions only."""
    from dynaeval.io import images

    decoded = []
    real = images.decode_file
    monkeypatch.setattr(images, "decode_file", lambda path: decoded.append(Path(path)) or real(path))
    manifest = json.loads((prepared_motion / "manifest.json").read_text())
    assert len(manifest["decoded"]) == 16
    score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"),
          prepared=str(prepared_motion), **FAST)
    assert decoded and all((SAMPLE / "pred") in p.parents for p in decoded)
    assert len(set(decoded)) == 16


def _kinds(prep: Path) -> dict[str, Path]:
    """One prepared file of each kind: a flow, a decoded frame, a camera's regions, a pair's
    visibility mask."""
    def first(pattern):
        found = sorted(prep.glob(pattern))
        assert found, pattern
        return found[0]
    return {"flow": first("flows/*.npy"), "frame": first("frames/*.npy"),
            "regions": first("regions/*.npz"), "visible": first("visible/*.npy")}


def _flip_values(path: Path) -> None:
    """Change the values, keep the size (the case of issue 34: 30.20 dB instead of 9.26)."""
    if path.suffix == ".npz":
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
        key = next(k for k in arrays if k.startswith("boxes"))
        arrays[key] = arrays[key] // 2
        np.savez_compressed(path, **arrays)
        return
    arr = np.load(path)
    arr = (255 - arr) if arr.dtype == np.uint8 else arr * 1.5 + 0.25
    np.save(path, arr)


@pytest.mark.parametrize("kind", ["flow", "frame", "regions", "visible"])
@pytest.mark.parametrize("damage", ["changed", "truncated", "deleted"])
def test_a_prepared_file_changed_truncated_or_deleted_is_exit_2_naming_it(
        tmp_path, prepared_motion, capsys, kind, damage):
    """Issue 34 item 1: each was read as it was (other numbers, exit 0) or ended in a
    traceback; every prepared file is in the manifest's ``hashes`` and checked when read."""
    prep = tmp_path / "prep"
    shutil.copytree(prepared_motion, prep)
    target = _kinds(prep)[kind]
    if damage == "changed":
        _flip_values(target)
    elif damage == "truncated":
        target.write_bytes(target.read_bytes()[: target.stat().st_size // 2])
    else:
        target.unlink()
    code = main(["score", str(SAMPLE / "pred"), str(SAMPLE / "gt"), "--focus", "motion",
                 "--no-lpips", "-q", "--prepared", str(prep), "-o", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert code == 2, err
    word = {"changed": "was changed or truncated", "truncated": "was changed or truncated",
            "deleted": "is missing"}[damage]
    assert f"{target}: this prepared file {word}" in err and "dynaeval prepare GT -o PREP " \
        "--overwrite" in err and "Traceback" not in err
    assert not (tmp_path / "r.json").exists()


def test_prepared_folder_of_the_format_without_hashes_is_refused(tmp_path, prepared_motion):
    prep = tmp_path / "prep"
    shutil.copytree(prepared_motion, prep)
    manifest = json.loads((prep / "manifest.json").read_text())
    manifest["format_version"] = 1
    del manifest["hashes"]
    from dynaeval.io.prepared import manifest_id

    manifest["id"] = manifest_id(manifest)
    (prep / "manifest.json").write_text(json.dumps(manifest))
    from dynaeval.io.prepared import FORMAT_VERSION

    with pytest.raises(InputError, match=f"format version 1; this dynaeval reads version "
                                         f"{FORMAT_VERSION}: prepare it again"):
        score(SAMPLE / "pred", SAMPLE / "gt", focus=FocusConfig(source="motion"),
              prepared=str(prep), **FAST)


def test_every_prepared_file_is_in_the_manifest(prepared_motion):
    from dynaeval.io.prepared import folder_digests

    manifest = json.loads((prepared_motion / "manifest.json").read_text())
    assert manifest["hashes"] == folder_digests(prepared_motion)
    assert set(_kinds(prepared_motion)) and all(
        p.relative_to(prepared_motion).as_posix() in manifest["hashes"]
        for p in _kinds(prepared_motion).values())


def test_prepare_decodes_each_ground_truth_image_once(tmp_path, prepared_motion, monkeypatch):
    """The decoding that is saved is the one the regions and flows read (issue 33: each file
    was decoded twice); the prepared folder is the same, byte for byte."""
    from dynaeval.io import images
    from dynaeval.run import prepare as module

    decoded = []
    real = images.decode_file
    counted = lambda path: decoded.append(Path(path)) or real(path)  # noqa: E731
    monkeypatch.setattr(images, "decode_file", counted)  # read_image's
    monkeypatch.setattr(module, "decode_file", counted)  # prepare's own
    prepare(SAMPLE / "gt", tmp_path / "p", focus=FocusConfig(source="motion"), progress=False)
    assert len(decoded) == len(set(decoded)) == 16
    files = sorted(p.relative_to(prepared_motion) for p in prepared_motion.rglob("*"))
    assert files == sorted(p.relative_to(tmp_path / "p") for p in (tmp_path / "p").rglob("*"))
    for rel in files:
        if (prepared_motion / rel).is_file():
            assert (prepared_motion / rel).read_bytes() == (tmp_path / "p" / rel).read_bytes(), rel


@pytest.mark.parametrize("after", [3, 20, 40])
def test_a_disk_that_fills_during_prepare_leaves_nothing(tmp_path, monkeypatch, capsys, after):
    """The prepared files are written in a background thread: a full disk at the first frame,
    among the flows or at the last of them is the same exit 2 ("no space left"), with nothing
    left behind."""
    import errno
    import os

    calls = {"n": 0}
    real = np.save

    def save(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > after:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(*args, **kwargs)

    monkeypatch.setattr(np, "save", save)
    out = tmp_path / "out" / "prep"
    code = main(["prepare", str(SAMPLE / "gt"), "-o", str(out), "--focus", "motion", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "no space left on the device" in err and "nothing was written" in err
    assert "Traceback" not in err and calls["n"] == after + 1
    assert not (tmp_path / "out").exists()


def test_an_interrupt_during_prepare_leaves_nothing_while_files_are_written(tmp_path,
                                                                             monkeypatch):
    from dynaeval.run import prepare as module

    real = module._save_pair

    def interrupted(*a, **k):
        real(*a, **k)  # its file queued behind the pair's flows
        raise KeyboardInterrupt

    monkeypatch.setattr(module, "_save_pair", interrupted)
    with pytest.raises(KeyboardInterrupt):
        prepare(SAMPLE / "gt", tmp_path / "prep", focus=FocusConfig(source="motion"),
                progress=False)
    assert list(tmp_path.iterdir()) == []

"""Sharded scoring merged back equals the unsharded run, bit for bit."""

from __future__ import annotations

import json

import pytest

from dynaeval.cli import main
from dynaeval.errors import InputError
from dynaeval.io.frames import pair_frames, parse_shard, select_shard
from dynaeval.report.merge import merge_results

from ..helpers import three_camera_scene

NUMBERS = ("frames", "cameras", "summary", "summary_status", "counts", "metrics")


@pytest.fixture
def scene(tmp_path):
    return three_camera_scene(tmp_path)


def test_shards_are_whole_cameras_round_robin(scene):
    pred, gt = scene
    pairing = pair_frames(pred, gt)
    parts = [select_shard(pairing, i, 2) for i in (1, 2)]
    assert sorted({p.camera for p in parts[0].pairs}) == ["cam0", "cam2"]
    assert sorted({p.camera for p in parts[1].pairs}) == ["cam1"]
    assert select_shard(pairing, 4, 4).pairs == []  # more shards than cameras: an empty one


@pytest.mark.parametrize("spec,message", [("1", "must be I/N"), ("0/2", "1 <= I <= N"),
                                          ("3/2", "1 <= I <= N"), ("a/b", "must be I/N")])
def test_bad_shard_spec(spec, message):
    with pytest.raises(InputError, match=message):
        parse_shard(spec)


def test_merged_shards_equal_unsharded_bit_for_bit(tmp_path, scene, capsys):
    pred, gt = scene
    common = ["--no-lpips", "-q", "--focus", "motion"]
    assert main(["score", str(pred), str(gt), "-o", str(tmp_path / "all.json"), *common]) == 0
    parts = []
    for i in (1, 2, 3, 4):
        out = tmp_path / f"part{i}.json"
        assert main(["score", str(pred), str(gt), "-o", str(out), "--shard", f"{i}/4",
                     *common]) == 0
        parts.append(str(out))
    assert main(["merge", *parts, "-o", str(tmp_path / "merged.json")]) == 0
    whole = json.loads((tmp_path / "all.json").read_text())
    merged = json.loads((tmp_path / "merged.json").read_text())
    for key in NUMBERS:
        assert merged[key] == whole[key], key
    assert "shard" not in merged["inputs"]
    assert sorted(map(json.dumps, merged["warnings"])) == sorted(map(json.dumps, whole["warnings"]))
    capsys.readouterr()


def test_merge_refuses_incomplete_or_mixed(tmp_path, scene, capsys):
    pred, gt = scene
    common = ["--no-lpips", "-q", "--focus", "none", "--no-temporal"]
    for i in (1, 2):
        main(["score", str(pred), str(gt), "-o", str(tmp_path / f"p{i}.json"), "--shard",
              f"{i}/2", *common])
    main(["score", str(pred), str(gt), "-o", str(tmp_path / "q.json"), "--shard", "2/2",
          "--quantize", "round", *common])
    main(["score", str(pred), str(gt), "-o", str(tmp_path / "whole.json"), *common])
    with pytest.raises(InputError, match=r"shards missing: 2/2"):
        merge_results([tmp_path / "p1.json"])
    with pytest.raises(InputError, match=r"q\.json: shards of different runs: 'settings' differs"):
        merge_results([tmp_path / "p1.json", tmp_path / "q.json"])
    with pytest.raises(InputError, match=r"shard 1/2 given twice"):
        merge_results([tmp_path / "p1.json", tmp_path / "p1.json"])
    with pytest.raises(InputError, match=r"whole\.json: not a shard"):
        merge_results([tmp_path / "whole.json"])
    capsys.readouterr()


def _whole_and_merged(tmp_path, pred, gt, common: list[str]) -> tuple[dict, dict]:
    """The unsharded results and the merge of its two shards, scored with ``common`` options."""
    assert main(["score", str(pred), str(gt), "-o", str(tmp_path / "all.json"), *common]) == 0
    parts = [str(tmp_path / f"part{i}.json") for i in (1, 2)]
    for i, out in enumerate(parts, 1):
        assert main(["score", str(pred), str(gt), "-o", out, "--shard", f"{i}/2", *common]) == 0
    assert main(["merge", *parts, "-o", str(tmp_path / "merged.json")]) == 0
    return (json.loads((tmp_path / "all.json").read_text()),
            json.loads((tmp_path / "merged.json").read_text()))


def test_merge_equals_unsharded_when_a_frame_equals_its_ground_truth(tmp_path, scene, capsys):
    """Issue 16 item 1: a shard stores PSNR +inf as null (like an undefined value); merge
    averaged over the nulls (a number instead of null, counts one short, warnings gone)."""
    import shutil

    pred, gt = scene
    shutil.copy(gt / "cam1" / "0002.png", pred / "cam1" / "0002.png")  # PSNR = +inf there
    common = ["--no-lpips", "-q", "--focus", "motion", "--no-presence"]
    whole, merged = _whole_and_merged(tmp_path, pred, gt, common)
    assert whole["summary"]["psnr"] is None and whole["cameras"]["cam1"]["psnr"] is None
    assert whole["counts"]["psnr"] == whole["summary"]["n_frames"]
    for key in NUMBERS:
        assert merged[key] == whole[key], key
    assert sorted(map(json.dumps, merged["warnings"])) == sorted(map(json.dumps, whole["warnings"]))
    assert any("summary is null" in w["reason"] and w["metric"] == "psnr"
               for w in merged["warnings"])
    capsys.readouterr()


def _two_shards(tmp_path, scene) -> None:
    """Shards 1/2 and 2/2 of ``scene`` (no regions, masks or temporal terms) as p1.json, p2.json."""
    pred, gt = scene
    common = ["--no-lpips", "-q", "--focus", "none", "--no-temporal", "--no-masked"]
    for i in (1, 2):
        assert main(["score", str(pred), str(gt), "-o", str(tmp_path / f"p{i}.json"), "--shard",
                     f"{i}/2", *common]) == 0


def test_merge_refuses_overlapping_shards_naming_both_files(tmp_path, scene, capsys):
    """Issue 16 item 2: the same camera in two files was merged (frames twice, exit 0)."""
    _two_shards(tmp_path, scene)
    doc = json.loads((tmp_path / "p1.json").read_text())
    doc["inputs"]["shard"]["index"] = 2  # shard 1's cameras under shard 2's name
    (tmp_path / "copy.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"copy\.json: camera 'cam0' is in two shards: "
                                         r".*p1\.json and .*copy\.json"):
        merge_results([tmp_path / "p1.json", tmp_path / "copy.json"])
    code = main(["merge", str(tmp_path / "p1.json"), str(tmp_path / "copy.json"), "-o",
                 str(tmp_path / "m.json")])
    assert code == 2 and "is in two shards" in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_merge_of_allow_missing_shards_equals_unsharded(tmp_path, scene, capsys):
    """Issue 32 item 6: shards of an --allow-missing run merge into the unsharded run's numbers,
    ``inputs.temporal_pairs`` and its one warning naming the missing frames."""
    pred, gt = scene
    (pred / "cam0" / "0001.png").unlink()
    (pred / "cam2" / "0002.png").unlink()
    common = ["--no-lpips", "-q", "--focus", "none", "--no-presence", "--allow-missing"]
    whole, merged = _whole_and_merged(tmp_path, pred, gt, common)
    assert whole["inputs"]["temporal_pairs"] == {"cam0": {"scored": 1, "expected": 3},
                                                 "cam2": {"scored": 1, "expected": 3}}
    assert merged["inputs"]["temporal_pairs"] == whole["inputs"]["temporal_pairs"]
    for key in NUMBERS:
        assert merged[key] == whole[key], key
    assert sorted(map(json.dumps, merged["warnings"])) == sorted(map(json.dumps, whole["warnings"]))
    capsys.readouterr()


@pytest.mark.parametrize("damage,message", [
    ("duplicate", r"p1\.json: frame cam0/0002 has two rows"),
    ("remove", r"p1\.json: camera 'cam0' has 3 frame rows but cameras\.cam0\.n_frames says 4"),
    ("stray", r"p1\.json: frame camX/0002: its camera is not in 'cameras'"),
])
def test_merge_checks_a_shards_rows_against_its_own_counts(tmp_path, scene, capsys, damage,
                                                           message):
    """Issue 42 item 1: a duplicated frame row was counted twice (the summary over 13 frames
    where 12 were scored), a removed one merged as a frame fewer; exit 2 names file and frame."""
    _two_shards(tmp_path, scene)
    doc = json.loads((tmp_path / "p1.json").read_text())
    rows = doc["frames"]
    if damage == "duplicate":
        rows.insert(3, dict(rows[2]))
    elif damage == "remove":
        del rows[2]
    else:
        rows[2]["camera"] = "camX"
    (tmp_path / "p1.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message):
        merge_results([tmp_path / "p1.json", tmp_path / "p2.json"])
    code = main(["merge", str(tmp_path / "p1.json"), str(tmp_path / "p2.json"), "-o",
                 str(tmp_path / "m.json")])
    assert code == 2 and not (tmp_path / "m.json").exists()
    capsys.readouterr()


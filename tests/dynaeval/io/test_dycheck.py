"""DyCheck's ground-truth layout: the predictions of one split paired with that split only."""

from __future__ import annotations

import pytest

from dynaeval.errors import InputError
from dynaeval.io.dycheck import dycheck_splits, pair_dycheck
from tests.dynaeval.mask_layouts import dycheck_dataset

pytest.importorskip("skimage")


def test_splits_read_from_the_dataset(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    splits = dycheck_splits(gt)
    assert splits == {"train": {"0_00000", "0_00001", "0_00002"},
                      "val": {"1_00000", "1_00001", "1_00002"}}
    assert dycheck_splits(pred) == {}  # not rgb/<factor>x
    (gt.parent.parent / "splits" / "broken.json").write_text("{not json")
    with pytest.raises(InputError, match=r"splits/broken\.json: this DyCheck split file is not "
                                         "valid JSON"):
        dycheck_splits(gt)  # was ignored (issue 34 item 4)


def test_pairing_one_split(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    pairing = pair_dycheck(pred, gt)
    assert [p.frame for p in pairing.pairs] == ["1_00000", "1_00001", "1_00002"]
    assert pairing.skipped == []
    assert pair_dycheck(pred, pred) is None  # no DyCheck ground truth: ordinary rules
    (gt.parent.parent / "splits" / "val.json").write_text('{"frame_names": ["1_00000"]}')
    assert pair_dycheck(pred, gt) is None  # the predictions fit no split


def test_missing_frame_of_the_split(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    (pred / "1_00002.png").unlink()
    with pytest.raises(InputError, match=r"DyCheck split 'val': 1 of its frames have no prediction: 1_00002"):
        pair_dycheck(pred, gt)
    pairing = pair_dycheck(pred, gt, allow_missing=True)
    assert pairing.skipped == [{"camera": ".", "frame": "1_00002"}]


# ------------------------------------------- DyCheck's render folder (issue 32 item 11)


def _dycheck_renders(work, rng, split="val", n=3, h=24, w=30, masked=True):
    """WORK/renders/novel_view/<split>/<frame>.png as DyCheck's NovelView.finalize writes them:
    gt | pred | cov * pred + (1 - cov) * (1 + pred) / 2, uint8 by truncation; (preds, gts)."""
    import cv2
    import numpy as np

    folder = work / "renders" / "novel_view" / split
    (folder / "checkpoints").mkdir(parents=True)
    cov = np.zeros((h, w, 1), np.float32)
    cov[:, : w // 2] = 1
    preds, gts = [], []
    for i in range(n):
        gt = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        pred = np.clip(gt.astype(int) + rng.integers(-20, 21, gt.shape), 0, 255).astype(np.uint8)
        p = pred / np.float32(255)
        panels = [gt, pred] + ([((cov * p + (1 - cov) * (1 + p) / 2) * 255).astype(np.uint8)]
                               if masked else [])
        cv2.imwrite(str(folder / f"1_{i:05d}.png"), np.concatenate(panels, axis=1)[..., ::-1])
        preds.append(pred)
        gts.append(gt)
    cv2.imwrite(str(folder / "checkpoints" / "0000100.png"), np.zeros((h, 7, 3), np.uint8))
    (folder / "mean_metrics_dict.json").write_text('{"psnr": 1.0}')
    return folder, preds, gts


@pytest.mark.parametrize("masked", [True, False])
def test_dycheck_render_folder_is_scored_panel_2_against_panel_1(tmp_path, masked, capsys):
    """DyCheck's renders/novel_view/<split>/ was refused ("no known render layout"). Each PNG
    is gt | pred | masked pred (3 panels; 2 without covisibility masks): the prediction panel is
    scored against the ground-truth panel, at every level of the folder, CLI = library = psnr of
    the panels; checkpoints/ is no frame."""
    import json

    import numpy as np

    import dynaeval
    from dynaeval.cli import main
    from dynaeval.io.layouts import detect_layout
    from dynaeval.metrics import psnr
    from dynaeval.regions.focus import FocusConfig

    split, preds, gts = _dycheck_renders(tmp_path / "work", np.random.default_rng(0),
                                         masked=masked)
    for level in (tmp_path / "work", split.parent.parent, split.parent, split):
        lay = detect_layout(level)
        assert (lay.name, lay.pred, lay.gt, lay.sequence) == ("dycheck", split, split, False)
    out = tmp_path / "r.json"
    assert main(["score", str(tmp_path / "work"), "--no-lpips", "--focus", "none", "-q",
                 "-o", str(out)]) == 0
    assert "dycheck render folder" in capsys.readouterr().err
    doc = json.loads(out.read_text())
    want = [psnr(p / np.float32(255), g / np.float32(255)) for p, g in zip(preds, gts, strict=True)]
    assert [r["frame"] for r in doc["frames"]] == ["1_00000", "1_00001", "1_00002"]
    assert [r["psnr"] for r in doc["frames"]] == pytest.approx(want, rel=1e-6)
    assert doc["inputs"]["layout"]["split"] == "val"
    assert "(prediction)" in doc["frames"][0]["pred"] and "(ground truth)" in doc["frames"][0]["gt"]
    lib = dynaeval.score(split, metrics=("psnr",), focus=FocusConfig(source="none"),
                         progress=False)
    assert [r["psnr"] for r in lib["frames"]] == [r["psnr"] for r in doc["frames"]]
    # named after the experiment folder above renders/novel_view/<split>, not its split
    # (the console said "val against val"; issue 43)
    assert doc["method"] == doc["scene"] == lib["method"] == "work"


def test_dycheck_render_of_a_width_not_3_panels_or_another_width_is_exit_2(tmp_path, capsys):
    import cv2
    import numpy as np

    from dynaeval.cli import main

    split, _, _ = _dycheck_renders(tmp_path / "work", np.random.default_rng(1))
    args = ["score", str(split), "--no-lpips", "--focus", "none", "--no-masked", "-q"]
    cv2.imwrite(str(split / "1_00001.png"), np.zeros((24, 88, 3), np.uint8))  # 88 != 90
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "1_00001.png" in err and "this one is 88 px wide" in err
    cv2.imwrite(str(split / "1_00000.png"), np.zeros((24, 91, 3), np.uint8))  # first file
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "1_00000.png" in err and "this file is 91 px wide, not a multiple of 3" in err
    _dycheck_renders(tmp_path / "work", np.random.default_rng(2), split="test")
    with pytest.raises(InputError, match="DyCheck render folder with several splits: test, val"):
        from dynaeval.io.layouts import detect_layout

        detect_layout(tmp_path / "work")


def test_dycheck_render_report_reads_the_panels_back(tmp_path):
    """The report reads the worst frames from the results' ``pred``/``gt`` text, which for a
    panel is ``"FILE (prediction)"``: read back as that panel (was: "frame ... is gone")."""
    import numpy as np

    from dynaeval.cli import main
    from dynaeval.io.layouts import part_ref_from_text

    split, preds, gts = _dycheck_renders(tmp_path / "work", np.random.default_rng(3), h=40, w=48)
    ref = part_ref_from_text(f"{split / '1_00001.png'} (prediction)")
    assert np.array_equal(ref.read(), preds[1] / np.float32(255))
    assert part_ref_from_text(f"{split / '1_00001.png'} (error map)") is None
    assert part_ref_from_text(str(split / "nope.png (prediction)")) is None
    assert main(["score", str(split), "--no-lpips", "--focus", "none", "-q",
                 "--report", str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "index.html").is_file()


def test_dycheck_render_with_the_datasets_covisible_masks_gives_the_masked_numbers(tmp_path):
    """``--masks DATA/covisible/2x/val`` on a render folder: the masks are the panels' size
    (was: "mask is 30x24 px but its frame ... is 90x24 px")."""
    import cv2
    import numpy as np

    import dynaeval
    from dynaeval.metrics import psnr
    from dynaeval.regions.focus import FocusConfig

    split, preds, gts = _dycheck_renders(tmp_path / "work", np.random.default_rng(4))
    cov = tmp_path / "covisible" / "2x" / "val"
    cov.mkdir(parents=True)
    for f in sorted(split.glob("*.png")):
        m = np.zeros((24, 30), np.uint8)
        m[:, :15] = 255
        cv2.imwrite(str(cov / f.name), m)
    res = dynaeval.score(split, masks=str(cov), protocol="dycheck", metrics=("psnr",),
                         focus=FocusConfig(source="none"), progress=False)
    want = [psnr(p[:, :15] / np.float32(255), g[:, :15] / np.float32(255))
            for p, g in zip(preds, gts, strict=True)]
    assert [r["masked_psnr"] for r in res["frames"]] == pytest.approx(want, rel=1e-6)
    assert res["summary"]["mpsnr"] is not None


# ------------------------------------------- issue 34 item 4: a broken DyCheck split file

BROKEN_SPLITS = {
    "not JSON": ("{\"frame_names\": [\"1_00000\",", "is not valid JSON"),
    "a list": ('["1_00000", "1_00001", "1_00002"]', "holds a JSON list, not an object"),
    "no frame_names": ('{"frames": ["1_00000"]}', 'has no "frame_names" (keys: frames)'),
    "frame_names a string": ('{"frame_names": "1_00000"}', 'a str, not a list'),
    "empty frame_names": ('{"frame_names": []}', '"frame_names" that is an empty list'),
    "numbers as names": ('{"frame_names": [1, 2]}', 'lists 1 in "frame_names", not a frame name'),
    "a name twice": ('{"frame_names": ["1_00000", "1_00000"]}', "frame names twice"),
    "time_ids of another length": ('{"frame_names": ["1_00000", "1_00001", "1_00002"], '
                                   '"time_ids": [0, 1]}', '"time_ids" that is not 3 whole numbers'),
    "frames not in rgb/2x": ('{"frame_names": ["1_00000", "1_00001", "1_00002", "1_00007"]}',
                             "lists 1 frame(s) that"),
}


@pytest.mark.parametrize("case", sorted(BROKEN_SPLITS))
def test_broken_split_file_is_exit_2_naming_it(tmp_path, capsys, case):
    """A broken splits/val.json was skipped and the user told of missing frames instead (the
    training frames of rgb/2x/): exit 2 naming splits/val.json and its problem, before the
    work; no results file."""
    from dynaeval.cli import main

    pred, gt = dycheck_dataset(tmp_path)
    text, problem = BROKEN_SPLITS[case]
    split_file = gt.parent.parent / "splits" / "val.json"
    split_file.write_text(text)
    out = tmp_path / "r.json"
    code = main(["score", str(pred), str(gt), "--no-lpips", "--focus", "none", "-q",
                 "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists() and "Traceback" not in err
    assert f"{split_file}: this DyCheck split" in err and problem in err
    assert "no prediction" not in err
    if case == "frames not in rgb/2x":
        assert f"{gt} does not hold: 1_00007" in err


def test_split_file_intact_still_scores(tmp_path, capsys):
    """The checks pass DyCheck's own files: time_ids and camera_ids of the same length."""
    import json

    from dynaeval.cli import main

    pred, gt = dycheck_dataset(tmp_path)
    out = tmp_path / "r.json"
    assert main(["score", str(pred), str(gt), "--no-lpips", "--focus", "none", "--no-masked",
                 "-q", "-o", str(out)]) == 0, capsys.readouterr().err
    assert [f["frame"] for f in json.loads(out.read_text())["frames"]] == [
        "1_00000", "1_00001", "1_00002"]

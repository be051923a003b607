"""Finding frames and pairing predictions with ground truth."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.io import find_frames, natural_key, pair_frames


def write(path: Path, value: int = 0, size=(6, 8)) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    img = np.full((*size, 3), value, np.uint8)
    if path.suffix == ".jpg":
        cv2.imwrite(str(path), img)
    else:
        cv2.imwrite(str(path), img)
    return path


def layout(root: Path, files: list[str]) -> Path:
    for f in files:
        write(root / f)
    return root


def test_natural_sort():
    names = ["10", "2", "1", "frame10", "frame9"]
    assert sorted(names, key=natural_key) == ["1", "2", "10", "frame9", "frame10"]


def test_flat_folder_is_one_camera(tmp_path):
    cams = find_frames(layout(tmp_path / "p", ["10.png", "2.png", "1.png"]))
    assert list(cams) == ["."]
    assert [n for n, _ in cams["."].frames] == ["1", "2", "10"]


def test_camera_folders_and_non_images_ignored(tmp_path):
    root = layout(tmp_path / "gt", ["cam10/0.png", "cam2/0.png", "cam2/1.png"])
    (root / "transforms.json").write_text("{}")
    (root / ".hidden").mkdir()
    write(root / ".hidden" / "0.png")
    cams = find_frames(root)
    assert list(cams) == ["cam2", "cam10"]


def test_extension_ignored_when_pairing(tmp_path):
    pred = layout(tmp_path / "pred", ["cam03/0007.jpg"])
    gt = layout(tmp_path / "gt", ["cam03/0006.png", "cam03/0007.png"])
    with pytest.raises(InputError, match=r"ground-truth frames with no prediction: 0006"):
        pair_frames(pred, gt)
    pairing = pair_frames(pred, gt, allow_missing=True)
    (pair,) = pairing.pairs
    assert (pair.camera, pair.frame, pair.index) == ("cam03", "0007", 1)
    assert pair.pred.path.name == "0007.jpg" and pair.gt.path.name == "0007.png"
    assert pairing.skipped == [{"camera": "cam03", "frame": "0006"}]


def test_gt_camera_without_predictions_is_listed_not_scored(tmp_path):
    pred = layout(tmp_path / "pred", ["eval00/0.png", "eval00/1.png"])
    gt = layout(tmp_path / "gt", ["cam00/0.png", "eval00/0.png", "eval00/1.png"])
    pairing = pair_frames(pred, gt)
    assert [p.camera for p in pairing.pairs] == ["eval00", "eval00"]
    assert pairing.unscored_cameras == ["cam00"]


def test_prediction_without_ground_truth_is_an_error(tmp_path):
    pred = layout(tmp_path / "pred", ["cam00/0.png", "cam00/5.png"])
    gt = layout(tmp_path / "gt", ["cam00/0.png"])
    with pytest.raises(InputError, match=r"predictions with no ground-truth frame: 5"):
        pair_frames(pred, gt)


def test_prediction_camera_without_ground_truth(tmp_path):
    pred = layout(tmp_path / "pred", ["camX/0.png"])
    gt = layout(tmp_path / "gt", ["cam00/0.png"])
    with pytest.raises(InputError, match=r"prediction cameras with no ground-truth camera: camX"):
        pair_frames(pred, gt)


def test_flat_prediction_against_camera_folders_hints(tmp_path):
    pred = layout(tmp_path / "pred", ["0.png"])
    gt = layout(tmp_path / "gt", ["cam00/0.png"])
    with pytest.raises(InputError, match="prediction folder is flat"):
        pair_frames(pred, gt)


def test_duplicate_stems_are_an_error(tmp_path):
    root = layout(tmp_path / "pred", ["0001.png", "0001.jpg"])
    with pytest.raises(InputError, match=r"share the frame name '0001': 0001\.jpg and 0001\.png"):
        find_frames(root)


def test_empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"empty: no prediction frames found"):
        find_frames(tmp_path / "empty", role="prediction")


def test_missing_folder_and_file_instead_of_folder(tmp_path):
    with pytest.raises(InputError, match="ground truth folder not found"):
        find_frames(tmp_path / "nope", role="ground truth")
    f = write(tmp_path / "a.png")
    with pytest.raises(InputError, match="must be a folder"):
        find_frames(f)


def test_pairs_order_is_camera_then_index(tmp_path):
    files = [f"cam{c}/{i}.png" for c in (1, 0) for i in (2, 10, 1)]
    pairing = pair_frames(layout(tmp_path / "p", files), layout(tmp_path / "g", files))
    assert [(p.camera, p.frame, p.index) for p in pairing.pairs] == [
        ("cam0", "1", 0), ("cam0", "2", 1), ("cam0", "10", 2),
        ("cam1", "1", 0), ("cam1", "2", 1), ("cam1", "10", 2),
    ]


def _video(path: Path, n: int, size=(32, 48)) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (size[1], size[0]))
    for i in range(n):
        w.write(np.full((*size, 3), 20 * i, np.uint8))
    w.release()
    return path


def test_video_is_a_camera_paired_by_position(tmp_path):
    _video(tmp_path / "pred" / "cam00.avi", 3)
    gt = layout(tmp_path / "gt", [f"cam00/{i:04d}.png" for i in range(3)])
    pairing = pair_frames(tmp_path / "pred", gt)
    assert [(p.frame, p.index) for p in pairing.pairs] == [("0000", 0), ("0001", 1), ("0002", 2)]
    frames = [p.pred.read() for p in pairing.pairs]
    assert frames[0].shape == (32, 48, 3)
    # decoded in order, values increase with the frame number (MJPG is lossy: compare roughly)
    means = [f.mean() for f in frames]
    assert means[0] < means[1] < means[2]
    # reading an earlier frame again re-opens the video and gives the same pixels
    np.testing.assert_array_equal(pairing.pairs[0].pred.read(), frames[0])


def test_video_longer_than_ground_truth(tmp_path):
    _video(tmp_path / "pred" / "cam00.avi", 4)
    gt = layout(tmp_path / "gt", [f"cam00/{i}.png" for i in range(2)])
    with pytest.raises(InputError, match="prediction has 4 frames, the ground truth only 2"):
        pair_frames(tmp_path / "pred", gt)


def test_corrupt_video(tmp_path):
    (tmp_path / "pred").mkdir()
    (tmp_path / "pred" / "cam00.mp4").write_bytes(b"not a video")
    with pytest.raises(InputError, match=r"cam00\.mp4: cannot open video|holds no decodable frame"):
        find_frames(tmp_path / "pred")


def _refuse_listing(monkeypatch, name: str) -> None:
    """Make os.walk's listing of folder ``name`` fail as chmod 000 would (tests may run as root,
    for whom chmod does not refuse)."""
    import os

    real = os.scandir

    def scandir(path=".", *a):  # noqa: ANN001, ANN202
        if Path(path).name == name:
            raise PermissionError(13, "Permission denied", str(path))
        return real(path, *a)

    monkeypatch.setattr(os, "scandir", scandir)


def test_unreadable_prediction_camera_folder_is_refused_not_skipped(tmp_path, monkeypatch):
    """Issue 16 item 6: an unreadable prediction camera was treated as a camera with no
    prediction (not scored, exit 0: lost silently)."""
    layout(tmp_path / "gt", ["cam0/0.png", "cam1/0.png"])
    layout(tmp_path / "pred", ["cam0/0.png", "cam1/0.png"])
    _refuse_listing(monkeypatch, "cam1")
    with pytest.raises(InputError, match=r"pred/cam1: cannot list this prediction folder "
                                         r"\(Permission denied\).*chmod"):
        pair_frames(tmp_path / "pred", tmp_path / "gt")


def test_unreadable_ground_truth_folder_is_named(tmp_path, monkeypatch):
    """Item 6: it used to give a misleading "no ground-truth camera"."""
    layout(tmp_path / "gt", ["cam0/0.png"])
    layout(tmp_path / "pred", ["cam0/0.png"])
    _refuse_listing(monkeypatch, "gt")
    with pytest.raises(InputError, match=r"gt: cannot list this ground truth folder"):
        pair_frames(tmp_path / "pred", tmp_path / "gt")


# ------------------------------------------------ issue 34 item 4: symbolic links, two videos


def _score(tmp_path, pred, gt, name="r.json"):
    """``dynaeval score PRED GT`` through the CLI: (exit code, stderr, results or None)."""
    import json

    from dynaeval.cli import main

    out = tmp_path / name
    code = main(["score", str(pred), str(gt), "--no-lpips", "--focus", "none", "-q",
                 "-o", str(out)])
    return code, json.loads(out.read_text()) if out.exists() else None


def _scene(root: Path, seed: int, cams=("cam0", "cam1"), n: int = 3) -> Path:
    rng = np.random.default_rng(seed)
    for cam in cams:
        (root / cam).mkdir(parents=True)
        for i in range(n):
            cv2.imwrite(str(root / cam / f"{i:04d}.png"),
                        rng.integers(0, 256, (24, 32, 3), dtype=np.uint8))
    return root


def test_symlinked_camera_folders_are_scored_as_their_targets(tmp_path, capsys):
    """A prediction camera folder that is a symbolic link was skipped (exit 0, listed as
    unscored), a linked ground-truth camera reported missing: both are read as their targets,
    with the numbers of the real folders."""
    import os

    pred, gt = _scene(tmp_path / "pred", 1), _scene(tmp_path / "gt", 2)
    for side, real in (("pred_links", pred), ("gt_links", gt)):
        (tmp_path / side).mkdir()
        for cam in ("cam0", "cam1"):
            os.symlink(real / cam, tmp_path / side / cam)
    code, want = _score(tmp_path, pred, gt, "real.json")
    assert code == 0
    for i, (p, g) in enumerate([(tmp_path / "pred_links", gt), (pred, tmp_path / "gt_links"),
                                (tmp_path / "pred_links", tmp_path / "gt_links")]):
        code, got = _score(tmp_path, p, g, f"l{i}.json")
        assert code == 0, capsys.readouterr().err
        assert got["inputs"]["unscored_cameras"] == []
        assert [(r["camera"], r["frame"], r["psnr"], r["ssim"]) for r in got["frames"]] == [
            (r["camera"], r["frame"], r["psnr"], r["ssim"]) for r in want["frames"]]
        assert len(got["frames"]) == 6


def test_symlinked_frame_files_are_read_as_their_targets(tmp_path):
    import os

    gt = _scene(tmp_path / "gt", 3, cams=("cam0",))
    (tmp_path / "pred" / "cam0").mkdir(parents=True)
    for f in sorted((gt / "cam0").iterdir()):
        os.symlink(f, tmp_path / "pred" / "cam0" / f.name)
    code, doc = _score(tmp_path, tmp_path / "pred", gt)
    assert code == 0 and [r["ssim"] for r in doc["frames"]] == pytest.approx([1.0] * 3)


@pytest.mark.parametrize("case", ["parent", "self", "loop", "dangling", "dangling-file"])
def test_symlink_loops_and_dangling_links_are_exit_2_naming_the_link(tmp_path, capsys, case):
    """A link to a folder that holds it (walked forever), a loop of links or a link to nothing
    is exit 2 naming the link, before the work; no results file."""
    import os

    pred, gt = _scene(tmp_path / "pred", 4), _scene(tmp_path / "gt", 5)
    link = pred / "cam1" / "back" if case != "dangling-file" else pred / "cam1" / "0003.png"
    if case == "parent":
        os.symlink(pred, link)  # pred/cam1/back -> pred
    elif case == "self":
        os.symlink(pred / "cam1", link)  # pred/cam1/back -> pred/cam1
    elif case == "loop":
        os.symlink(pred / "cam1" / "back2", link)
        os.symlink(link, pred / "cam1" / "back2")
    else:
        os.symlink(tmp_path / "gone", link)
    code, doc = _score(tmp_path, pred, gt)
    err = capsys.readouterr().err
    assert code == 2 and doc is None and "Traceback" not in err
    assert f"{link}: " in err or f"{pred / 'cam1' / 'back2'}: " in err
    want = {"parent": "a folder that holds it", "self": "a folder that holds it",
            "loop": "loop of symbolic links", "dangling": "broken symbolic link",
            "dangling-file": "broken symbolic link"}[case]
    assert want in err and "remove" in err


def test_symlinked_ground_truth_folder_above_is_a_loop(tmp_path):
    """``gt/cam0/up -> gt/..`` (a folder above the root): refused at once, not walked."""
    import os

    gt = _scene(tmp_path / "gt", 6, cams=("cam0",))
    os.symlink(tmp_path, gt / "cam0" / "up")
    with pytest.raises(InputError, match=r"cam0/up: this ground truth folder is a symbolic "
                                         r"link to .*a folder that holds it"):
        find_frames(gt, role="ground truth")


@pytest.mark.parametrize("second", ["cam0.avi", "cam0/"])
def test_two_videos_or_a_folder_and_a_video_of_one_camera_are_exit_2_naming_both(
        tmp_path, capsys, second):
    """``cam0.mp4`` beside ``cam0.avi``: one was silently ignored (the last listed won)."""
    gt = tmp_path / "gt"
    _video(gt / "cam0.mp4", 3)
    if second == "cam0/":
        layout(gt, [f"cam0/{i}.png" for i in range(3)])
    else:
        _video(gt / second, 3)
    pred = _scene(tmp_path / "pred", 7, cams=("cam0",))
    code, doc = _score(tmp_path, pred, gt)
    err = capsys.readouterr().err
    assert code == 2 and doc is None
    assert "cam0.mp4" in err and (f"{gt / 'cam0'}/" in err if second == "cam0/" else
                                  "cam0.avi" in err)
    assert "remove one of them, or move it out of the folder" in err


def test_prediction_folder_that_is_a_broken_link_is_named_as_such(tmp_path):
    """Not "folder not found": the link is there, its target is not."""
    import os

    os.symlink(tmp_path / "renders-deleted", tmp_path / "pred")
    with pytest.raises(InputError, match=r"pred: this prediction entry is a broken symbolic "
                                         r"link: its target .*renders-deleted does not exist"):
        find_frames(tmp_path / "pred", role="prediction")

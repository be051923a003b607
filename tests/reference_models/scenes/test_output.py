"""Files on disk: layout, formats, written cameras against the pixels, determinism."""

import json

import cv2
import numpy as np
import pytest

from dynaeval.core.boxes import mask_to_box
from dynaeval.errors import InputError
from dynaeval.regions.boxes_file import read_boxes_file
from reference_models.scenes import build_scene, render_scene

PRESET = "single-player-closeup"


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    out = tmp_path_factory.mktemp("scene") / "closeup"
    meta = render_scene(PRESET, out, size="tiny", seed=0)
    print(f"\ntiny {PRESET}: {meta['render_seconds']:.2f} s for 40 views")  # recorded, not asserted
    return out, meta


def _c2w_and_k(entry):
    return np.array(entry["transform_matrix"]), entry["fl_x"], entry["fl_y"], entry["cx"], entry["cy"]


def _project(entry, x):
    """Project world points with the written camera (OpenGL c2w, pinhole)."""
    c2w, fx, fy, cx, cy = _c2w_and_k(entry)
    pc = (x - c2w[:3, 3]) @ c2w[:3, :3]
    return np.stack([fx * pc[:, 0] / -pc[:, 2] + cx, -fy * pc[:, 1] / -pc[:, 2] + cy], 1)


def test_layout_and_formats(rendered):
    out, meta = rendered
    tf = json.loads((out / "transforms.json").read_text())
    assert tf["camera_model"] == "OPENCV"
    assert tf["eval_cameras"] == ["eval00"] and tf["train_cameras"] == ["cam00", "cam01", "cam02", "cam03"]
    assert len(tf["frames"]) == 5 * meta["frames"]
    for e in tf["frames"]:
        img = cv2.imread(str(out / e["file_path"]), cv2.IMREAD_UNCHANGED)
        assert img.dtype == np.uint8 and img.shape == (e["h"], e["w"], 3)
        mask = cv2.imread(str(out / e["instance_mask_path"]), cv2.IMREAD_UNCHANGED)
        assert mask.dtype == np.uint16 and mask.shape == (e["h"], e["w"])
        depth = np.load(out / e["depth_file_path"])
        assert depth.dtype == np.float32 and depth.shape == (e["h"], e["w"])
        assert 0 <= e["time"] <= 1
        last = e["frame"] == meta["frames"] - 1
        assert ("flow_file_path" in e) != last
        if not last:
            flow = np.load(out / e["flow_file_path"])
            assert flow.dtype == np.float32 and flow.shape == (e["h"], e["w"], 2)
    assert not (out / "flow" / "cam00" / f"{meta['frames'] - 1:04d}.npy").exists()
    assert set(tf["val_filenames"]) == {e["file_path"] for e in tf["frames"] if e["camera"] == "eval00"}
    assert meta["classes"] == {"0": "static", "1": "person", "2": "ball"}


def test_boxes_file_is_valid_and_matches_the_mask_files(rendered):
    out, _ = rendered
    boxes = read_boxes_file(out / "boxes.json").boxes
    assert len(boxes) == 40
    for key, records in boxes.items():
        mask = cv2.imread(str(out / "masks" / f"{key}.png"), cv2.IMREAD_UNCHANGED)
        assert {r["id"] for r in records} == set(np.unique(mask).tolist()) - {0}
        for r in records:
            assert r["box"] == mask_to_box(mask == r["id"]).tolist()


def test_written_cameras_project_the_ball_where_it_is_rendered(rendered):
    out, _ = rendered
    tf = json.loads((out / "transforms.json").read_text())
    scene = build_scene(PRESET, seed=0, size="tiny")
    hits = 0
    for e in tf["frames"]:
        ball = next(b for b in scene.bodies(e["frame"]) if b.cls == "ball")
        uv = _project(e, ball.a)[0]
        mask = cv2.imread(str(out / e["instance_mask_path"]), cv2.IMREAD_UNCHANGED)
        col, row = int(np.floor(uv[0])), int(np.floor(uv[1]))
        if 0 <= col < e["w"] and 0 <= row < e["h"] and mask[row, col] != 1:  # not behind the player
            assert mask[row, col] == ball.id
            hits += 1
    assert hits >= 20


def test_written_cameras_unproject_pitch_depth_onto_the_plane(rendered):
    out, _ = rendered
    tf = json.loads((out / "transforms.json").read_text())
    for e in tf["frames"][::7]:
        c2w, fx, fy, cx, cy = _c2w_and_k(e)
        depth = np.load(out / e["depth_file_path"])
        mask = cv2.imread(str(out / e["instance_mask_path"]), cv2.IMREAD_UNCHANGED)
        rows, cols = np.nonzero((mask == 0) & (depth > 0))
        pc = np.stack([(cols + 0.5 - cx) / fx, -(rows + 0.5 - cy) / fy, -np.ones(len(rows))], 1)
        x = c2w[:3, 3] + (depth[rows, cols, None] * pc) @ c2w[:3, :3].T
        near = np.hypot(x[:, 0], x[:, 1]) < 25  # the pitch around the player: nothing else there
        assert near.sum() > 100
        np.testing.assert_allclose(x[near, 2], 0.0, atol=2e-4)


def test_same_seed_gives_byte_identical_files(rendered, tmp_path):
    out, _ = rendered
    again = tmp_path / "again"
    render_scene(PRESET, again, size="tiny", seed=0)
    files = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(again) for p in again.rglob("*") if p.is_file())
    for rel in files:
        if rel.name != "timing.json":
            assert (out / rel).read_bytes() == (again / rel).read_bytes(), rel


def test_other_seed_changes_the_scene(tmp_path):
    a = render_scene("players-stadium", tmp_path / "a", size="tiny", seed=0, frames=2, spp=1)
    b = render_scene("players-stadium", tmp_path / "b", size="tiny", seed=1, frames=2, spp=1)
    assert a["classes"] != b["classes"] or (
        (tmp_path / "a" / "boxes.json").read_bytes() != (tmp_path / "b" / "boxes.json").read_bytes())


def test_refuses_non_empty_output_folder(tmp_path):
    (tmp_path / "x.txt").write_text("keep me")
    with pytest.raises(InputError, match="output folder is not empty"):
        render_scene(PRESET, tmp_path, size="tiny", frames=2)
    assert (tmp_path / "x.txt").read_text() == "keep me"


def test_refuses_a_file_as_output_folder(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(InputError, match="not a folder"):
        render_scene(PRESET, tmp_path / "f", size="tiny", frames=2)


def test_hide_ball_is_recorded_and_leaves_no_ball(tmp_path):
    meta = render_scene(PRESET, tmp_path / "o", size="tiny", frames=2, spp=1, hide=("ball",))
    assert meta["hide"] == ["ball"]
    boxes = json.loads((tmp_path / "o" / "boxes.json").read_text())
    assert all(r["class"] != "ball" for recs in boxes.values() for r in recs)

"""Dataset loading: generator, nerfstudio and D-NeRF files; splits, bounds and every error path."""

import json

import cv2
import numpy as np
import pytest

from dynaeval.errors import InputError
from reference_models.common.data import load_dataset, scene_box


def test_generator_files(tiny_data):
    data = load_dataset(tiny_data)
    tf = json.loads((tiny_data / "transforms.json").read_text())
    assert sorted(set(data.train.cameras)) == tf["train_cameras"]
    assert set(data.eval.cameras) == {"eval00"} and len(data.eval) == 8
    assert data.train.images.shape == (32, 36, 64, 3) and data.train.images.dtype == np.uint8
    assert data.n_frames == 8
    # pixels are the files' (RGB order), frame names are the file stems
    gt = cv2.imread(str(tiny_data / "images" / "eval00" / "0003.png"))[..., ::-1]
    i = data.eval.frames.index("0003")
    np.testing.assert_array_equal(data.eval.images[i], gt)
    np.testing.assert_allclose(data.eval.times[i], 3 / 7, atol=1e-6)
    # the box holds every training camera and reaches below the pitch (z = 0)
    centres = data.train.c2w[:, :3, 3]
    assert np.all(centres >= data.box[0]) and np.all(centres <= data.box[1])
    assert data.box[0, 2] < 0.0
    seq = data.train.camera_sequences()["cam01"]
    assert np.all(np.diff(data.train.times[seq]) > 0) and len(seq) == 8


def _write_images(root, names, size=(8, 6), seed=0):
    rng = np.random.default_rng(seed)
    for n in names:
        (root / n).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(root / n), rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8))


def _frame(path, t, x=0.0):
    c2w = np.eye(4)
    c2w[0, 3] = x
    return {"file_path": path, "transform_matrix": c2w.tolist(), "time": t}


def test_nerfstudio_split_by_filenames(tmp_path):
    names = [f"images/{c}/{f:04d}.png" for c in ("a", "b") for f in range(3)]
    _write_images(tmp_path, names)
    frames = [_frame(n, int(n[-5]) / 2, x=float(n[7] == "b")) for n in names]
    tf = {"fl_x": 10.0, "fl_y": 10.0, "frames": frames,
          "train_filenames": names[:3], "val_filenames": [f"./{n}" for n in names[3:]]}
    (tmp_path / "transforms.json").write_text(json.dumps(tf))
    data = load_dataset(tmp_path / "transforms.json")
    assert data.train.cameras == ["a"] * 3 and data.eval.cameras == ["b"] * 3
    assert data.eval.frames == ["0000", "0001", "0002"]
    np.testing.assert_allclose(data.train.intrinsics[0], [10, 10, 4, 3])  # centred default


def test_nerfstudio_without_split_trains_on_everything(tmp_path):
    _write_images(tmp_path, ["f0.png", "f1.png"])
    tf = {"fl_x": 10.0, "frames": [_frame("f0.png", 0.0), _frame("f1.png", 1.0, x=1.0)]}
    (tmp_path / "transforms.json").write_text(json.dumps(tf))
    data = load_dataset(tmp_path)
    assert len(data.train) == 2 and data.eval is None and data.train.cameras == [".", "."]


def test_dnerf_folder(tmp_path):
    _write_images(tmp_path, ["train/r_000.png", "train/r_001.png", "test/r_000.png"], size=(8, 8))
    angle = 2 * np.arctan(0.5)  # fx = W / 2 / tan(angle / 2) = 8
    for split, n in (("train", 2), ("test", 1)):
        frames = [_frame(f"./{split}/r_{i:03d}", i / 2, x=float(i)) for i in range(n)]
        (tmp_path / f"transforms_{split}.json").write_text(json.dumps({"camera_angle_x": angle, "frames": frames}))
    data = load_dataset(tmp_path)
    np.testing.assert_allclose(data.train.intrinsics[0], [8, 8, 4, 4], rtol=1e-6)
    assert data.eval.cameras == ["test"] and data.eval.frames == ["r_000"]


def test_scene_box_flat_axis_gets_the_largest_size():
    centres = np.array([[0.0, 0.0, 1.0], [10.0, 4.0, 1.0]])
    box = scene_box(centres, pad=0.0)
    np.testing.assert_allclose(box, [[0, 0, -4], [10, 4, 6]])
    assert scene_box(centres, ground_z=0.0, pad=0.0)[0, 2] == 0.0


@pytest.mark.parametrize("case, match", [
    ("missing", "dataset folder does not exist"),
    ("empty", "no transforms.json"),
    ("badjson", "not valid JSON"),
    ("noframes", "non-empty 'frames'"),
    ("noimage", "does not exist"),
    ("sizes", "differs from the first view"),
    ("time", "time must be in"),
    ("matrix", "4x4"),
    ("focal", "neither fl_x nor camera_angle_x"),
    ("nosplit", "names no training frame"),
])
def test_errors(tmp_path, case, match):
    root = tmp_path / "d"
    if case == "missing":
        with pytest.raises(InputError, match=match):
            load_dataset(root)
        return
    _write_images(root, ["a.png"])
    _write_images(root, ["b.png"], size=(4, 4))
    good = {"fl_x": 5.0, "frames": [_frame("a.png", 0.0)]}
    content = {
        "badjson": "{", "noframes": json.dumps({"frames": []}),
        "noimage": json.dumps({**good, "frames": [_frame("c.png", 0.0)]}),
        "sizes": json.dumps({**good, "frames": [_frame("a.png", 0.0), _frame("b.png", 1.0)]}),
        "time": json.dumps({**good, "frames": [_frame("a.png", 1.5)]}),
        "matrix": json.dumps({**good, "frames": [{"file_path": "a.png", "transform_matrix": [[1, 0]]}]}),
        "focal": json.dumps({"frames": [_frame("a.png", 0.0)]}),
        "nosplit": json.dumps({**good, "train_cameras": ["x"]}),
    }.get(case)
    if content is not None:
        (root / "transforms.json").write_text(content)
    with pytest.raises(InputError, match=match):
        load_dataset(root)

"""Given masks: found in NeRFBaselines / DyCheck layouts or named by --masks, read as weights,
checked for every frame before the work; and the 16-bit PNG decoding rule of ``--protocol
nerfbaselines`` (Pillow's high byte) against Pillow itself."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.io.images import read_image
from dynaeval.io.masks import MaskSet, check_masks, find_masks, read_mask, unused_mask_folders
from tests.dynaeval.mask_layouts import dycheck_dataset, nerfbaselines_folder


def test_pil_decode_equals_pillow_for_16_bit_rgb_and_rgba(tmp_path):
    Image = pytest.importorskip("PIL.Image")
    rng = np.random.default_rng(0)
    for ch in (3, 4):
        a = rng.integers(0, 65536, (9, 13, ch), dtype=np.uint16)
        path = tmp_path / f"x{ch}.png"
        cv2.imwrite(str(path), a[..., [2, 1, 0, 3][:ch]])
        ref = np.array(Image.open(path)).astype(np.float32) / 255  # Pillow: the high byte
        if ch == 4:  # composited over black as NeRFBaselines' image_to_srgb does by default
            ref = ref[..., :3] * ref[..., 3:]
        got = read_image(path, decode="pil", background="black")
        assert np.allclose(got, ref, atol=1e-6)
        plain = read_image(path, decode="dynaeval", background="black")
        assert np.abs(plain - got).max() > 1 / 512  # v/65535 differs from v >> 8


def test_pil_decode_refuses_16_bit_grey_and_keeps_8_bit(tmp_path):
    grey = tmp_path / "g.png"
    cv2.imwrite(str(grey), np.full((5, 5), 300, np.uint16))
    with pytest.raises(InputError, match="16-bit grey PNG.*I;16") as err:
        read_image(grey, decode="pil")
    assert err.value.path is not None and "g.png" in str(err.value)
    eight = tmp_path / "e.png"
    cv2.imwrite(str(eight), np.arange(75, dtype=np.uint8).reshape(5, 5, 3))
    assert np.array_equal(read_image(eight, decode="pil"), read_image(eight))
    with pytest.raises(InputError, match="decode must be one of"):
        read_image(eight, decode="imageio")


def test_read_mask_rules(tmp_path):
    m = (np.arange(20).reshape(4, 5) % 3 == 0).astype(np.uint8) * 255
    cv2.imwrite(str(tmp_path / "m.png"), m)
    w = read_mask(tmp_path / "m.png")
    assert w.dtype == np.float32 and np.array_equal(w, m / 255.0)
    cv2.imwrite(str(tmp_path / "rgb.png"), np.stack([m] * 3, axis=-1))
    assert np.array_equal(read_mask(tmp_path / "rgb.png"), w)  # equal channels: grey
    with pytest.raises(InputError, match="RGB mask fails"):
        read_mask(tmp_path / "rgb.png", decode="pil")
    colour = np.stack([m, m // 2, m], axis=-1)
    cv2.imwrite(str(tmp_path / "c.png"), colour)
    with pytest.raises(InputError, match="different colour channels"):
        read_mask(tmp_path / "c.png")
    cv2.imwrite(str(tmp_path / "m16.png"), m.astype(np.uint16) * 257)
    assert np.allclose(read_mask(tmp_path / "m16.png"), w)
    with pytest.raises(InputError, match="16-bit mask: NeRFBaselines multiplies"):
        read_mask(tmp_path / "m16.png", decode="pil")
    with pytest.raises(InputError, match="mask file not found"):
        read_mask(tmp_path / "nope.png")
    data = (tmp_path / "m.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(data[:-6])
    with pytest.raises(InputError, match=r"cut\.png: truncated PNG \(no IEND chunk\)"):
        read_mask(tmp_path / "cut.png")


def test_unreadable_mask_is_an_input_error_naming_it(tmp_path, monkeypatch):
    """Read as images are (``images._read_bytes``): a permission error is exit 2, not a
    traceback (patched: the tests run as root, who reads any file)."""
    from pathlib import Path

    m = np.full((4, 5), 255, np.uint8)
    cv2.imwrite(str(tmp_path / "m.png"), m)

    def denied(self):  # noqa: ANN001, ANN202
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", denied)
    with pytest.raises(InputError, match=r"m\.png: cannot read the file: permission denied"):
        read_mask(tmp_path / "m.png")


def test_found_in_nerfbaselines_and_dycheck_layouts(tmp_path):
    nb = nerfbaselines_folder(tmp_path / "nb")
    gts = sorted((nb / "gt-color").iterdir())
    found = find_masks(None, nb / "gt-color", gts, nb)
    assert found.origin == "nerfbaselines" and found.folder == nb / "mask"
    assert found.path_of(gts[1]) == nb / "mask" / gts[1].name
    pred, gt = dycheck_dataset(tmp_path / "dy")
    gts = sorted(gt.glob("1_*.png"))  # the val frames
    found = find_masks(None, gt, gts, None)
    assert found.origin == "dycheck" and found.folder == gt.parent.parent / "covisible" / "2x" / "val"
    by_root = find_masks(gt.parent.parent, gt, gts, None)  # --masks DATASET
    assert by_root.folder == found.folder
    assert find_masks(found.folder, gt, gts, None).origin == "given"
    assert find_masks(None, pred, sorted(pred.iterdir()), None) is None  # not a DyCheck rgb/ folder


def test_dycheck_dataset_without_unique_split_is_an_error(tmp_path):
    _, gt = dycheck_dataset(tmp_path)
    other = gt.parent.parent / "covisible" / "2x" / "test"
    other.mkdir()
    for f in (gt.parent.parent / "covisible" / "2x" / "val").iterdir():
        (other / f.name).write_bytes(f.read_bytes())
    gts = sorted(gt.glob("1_*.png"))  # the val frames
    assert find_masks(None, gt, gts, None) is None  # two splits fit: not guessed
    with pytest.raises(InputError, match="no single covisible/<factor>x/<split>/"):
        find_masks(gt.parent.parent, gt, gts, None)
    with pytest.raises(InputError, match="masks folder not found"):
        find_masks(tmp_path / "nope", gt, gts, None)


def test_check_masks_names_missing_and_wrong_size(tmp_path):
    nb = nerfbaselines_folder(tmp_path / "nb")
    gts = sorted((nb / "gt-color").iterdir())
    masks = MaskSet(nb / "mask", nb / "gt-color", "given")
    check_masks(masks, [(g, None) for g in gts])
    cv2.imwrite(str(nb / "mask" / gts[1].name), np.zeros((10, 12), np.uint8))
    with pytest.raises(InputError, match=r"mask is 12x10 px but its frame .*00001.png is") as err:
        check_masks(masks, [(g, None) for g in gts])
    assert "mask/00001.png" in str(err.value)
    (nb / "mask" / gts[2].name).unlink()
    (nb / "mask" / gts[1].name).unlink()
    with pytest.raises(InputError, match=r"no mask for ground-truth frame .*00001.png"):
        check_masks(masks, [(g, None) for g in gts])


def test_unused_mask_folders(tmp_path):
    nb = nerfbaselines_folder(tmp_path / "nb")
    used = MaskSet(nb / "mask", nb / "gt-color", "nerfbaselines")
    assert unused_mask_folders(used, [nb / "color", nb / "gt-color", nb]) == []
    assert unused_mask_folders(None, [nb / "color", nb / "gt-color"]) == [(nb / "mask").resolve()]
    _, gt = dycheck_dataset(tmp_path / "dy")
    assert unused_mask_folders(None, [gt]) == [(gt.parent.parent / "covisible").resolve()]


def test_generator_instance_masks_are_not_an_unused_mask_folder(tmp_path):
    scene = tmp_path / "scene"
    (scene / "images" / "cam00").mkdir(parents=True)
    (scene / "masks" / "cam00").mkdir(parents=True)
    frame = {"file_path": "images/cam00/0000.png", "instance_mask_path": "masks/cam00/0000.png"}
    (scene / "transforms.json").write_text(json.dumps({"frames": [frame]}))
    assert unused_mask_folders(None, [scene / "images", scene]) == []
    (scene / "transforms.json").write_text(json.dumps({"frames": [{"file_path": "x.png"}]}))
    assert unused_mask_folders(None, [scene / "images"]) == [(scene / "masks").resolve()]
    (scene / "transforms.json").write_text("not json")
    assert unused_mask_folders(None, [scene / "images"]) == [(scene / "masks").resolve()]


def test_mask_hash_follows_content_not_folder(tmp_path):
    a = nerfbaselines_folder(tmp_path / "a")
    b = nerfbaselines_folder(tmp_path / "b")
    ha, hb = (check_masks(MaskSet(r / "mask", r / "gt-color", "given"),
                          [(g, None) for g in sorted((r / "gt-color").iterdir())]).sha256 for r in (a, b))
    assert ha == hb and len(ha) == 64
    cv2.imwrite(str(b / "mask" / "00000.png"), np.zeros((301, 257), np.uint8))
    hb2 = check_masks(MaskSet(b / "mask", b / "gt-color", "given"),
                      [(g, None) for g in sorted((b / "gt-color").iterdir())]).sha256
    assert hb2 != ha

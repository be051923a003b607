"""PSNR by region: labels from depth and masks, per-region errors on a tiny scene."""

import json
import math
import shutil

import cv2
import numpy as np
import pytest

from reference_models.studies.psnr_by_region import REGIONS, main, region_labels, region_psnr
from tests.reference_models.common.tiny import render_tiny


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return render_tiny(tmp_path_factory.mktemp("regions") / "tiny")


def test_labels_from_height_sky_and_instances():
    c2w = np.eye(4)
    c2w[2, 3] = 1.0  # a camera 1 m up, looking along -z (straight down)
    depth = np.array([[0.0, 0.5], [0.9, 0.5]])  # sky; a point 0.5 m up; 0.1 m up; 0.5 m up
    ids = np.array([[0, 0], [0, 3]])
    labels = region_labels(depth, ids, c2w, 1.0, 1.0, 1.0, 1.0)
    assert [[REGIONS[k] for k in row] for row in labels] == [["sky", "stands"], ["pitch", "objects"]]


def test_region_psnr_of_a_prediction_wrong_only_in_the_stands(tiny, tmp_path):
    frames = json.loads((tiny / "transforms.json").read_text())["frames"]
    views = [f for f in frames if f["camera"].startswith("eval")][:2]
    for f in views:
        dst = tmp_path / "pred" / f["file_path"].removeprefix("images/")
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(tiny / f["file_path"], dst)
    exact = region_psnr(tiny, tmp_path / "pred")
    assert all(math.isinf(v["psnr"]) for v in exact.values())
    assert sum(v["pixel_share"] for v in exact.values()) == pytest.approx(1.0)
    for f in views:  # darken the stands only
        dst = tmp_path / "pred" / f["file_path"].removeprefix("images/")
        img = cv2.imread(str(dst)).astype(np.int16)
        labels = region_labels(np.load(tiny / f["depth_file_path"]),
                               cv2.imread(str(tiny / f["instance_mask_path"]), cv2.IMREAD_UNCHANGED),
                               np.asarray(f["transform_matrix"]), f["fl_x"], f["fl_y"], f["cx"], f["cy"])
        img[labels == 0] -= 16
        cv2.imwrite(str(dst), np.clip(img, 0, 255).astype(np.uint8))
    res = region_psnr(tiny, tmp_path / "pred")
    assert res["stands"]["error_share"] == pytest.approx(1.0)
    assert res["stands"]["psnr"] < 25 and math.isinf(res["pitch"]["psnr"])
    assert main([str(tiny), str(tmp_path / "pred")]) == 0

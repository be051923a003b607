"""The constant-colour baseline writes the eval frames in the prediction layout."""

import cv2
import numpy as np

from reference_models.common.baseline import main
from reference_models.common.data import load_dataset


def test_writes_mean_colour_frames(tiny_data, tmp_path, capsys):
    assert main([str(tiny_data), "--out", str(tmp_path), "--every", "2"]) == 0
    files = sorted(p.name for p in (tmp_path / "pred" / "eval00").iterdir())
    assert files == ["0000.png", "0002.png", "0004.png", "0006.png"]
    img = cv2.imread(str(tmp_path / "pred" / "eval00" / "0002.png"))[..., ::-1]
    mean = load_dataset(tiny_data).train.images.reshape(-1, 3).mean(0)
    np.testing.assert_allclose(img[5, 7], mean, atol=0.5)
    assert main([str(tiny_data), "--out", str(tmp_path), "--every", "0"]) == 2
    assert "every must be >= 1" in capsys.readouterr().err

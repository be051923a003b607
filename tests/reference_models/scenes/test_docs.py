"""The docs figure command writes the camera-layout plot and copies the shown frames."""

import cv2
import numpy as np

from reference_models.scenes.docs import FRAME, SHOWN, ball_sizes, copy_frames, layout_plot


def test_layout_plot_is_a_png(tmp_path):
    path = tmp_path / "layout.png"
    layout_plot(path)
    img = cv2.imread(str(path))
    assert img is not None and img.shape[1] > 2 * img.shape[0]


def test_copy_frames_takes_the_shown_views(tmp_path):
    renders = tmp_path / "renders"
    for preset, cams in SHOWN.items():
        for cam in cams:
            folder = renders / preset / "images" / cam
            folder.mkdir(parents=True)
            cv2.imwrite(str(folder / f"{FRAME:04d}.png"), np.full((4, 4, 3), len(cam), np.uint8))
    out = copy_frames(renders, tmp_path / "img")
    assert sorted(p.name for p in out) == sorted(
        f"scenes_{p}_{c}.png" for p, cams in SHOWN.items() for c in cams)


def test_ball_sizes_counts_the_closeup_ball_in_every_view():
    lines = ball_sizes()
    assert len(lines) == 5
    assert lines[-1].startswith("single-player-closeup small all: 744 ball images in 744 views")

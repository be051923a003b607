"""The rendered ground truth checked against itself and against the analytic scene."""

import numpy as np
import pytest

from dynaeval.core.boxes import mask_to_box
from dynaeval.errors import InputError
from reference_models.scenes import PRESETS, build_scene, render_view
from reference_models.scenes.geometry import closest_on_segment


def _views(preset, frames=(0, 3, 6), **kw):
    scene = build_scene(preset, seed=0, size="tiny", spp=1, **kw)
    for cam in scene.cameras:
        for f in frames:
            yield scene, cam, f, render_view(scene, cam.name, f)


@pytest.mark.parametrize("preset", PRESETS)
def test_boxes_are_tight_boxes_of_the_masks(preset):
    for scene, _, _, view in _views(preset):
        ids = set(np.unique(view.ids).tolist()) - {0}
        assert {b["id"] for b in view.boxes} == ids
        for b in view.boxes:
            assert b["box"] == mask_to_box(view.ids == b["id"]).tolist()
            assert b["class"] == scene.classes[b["id"]]
            assert 0 < b["visible"] <= 1


@pytest.mark.parametrize("preset", PRESETS)
def test_static_world_flow_is_exactly_zero(preset):
    for *_, view in _views(preset):
        assert view.flow is not None
        assert np.all(view.flow[view.ids == 0] == 0)
        assert np.all(np.isfinite(view.flow))


@pytest.mark.parametrize("preset", PRESETS)
def test_pitch_depth_matches_the_analytic_plane(preset):
    checked = 0
    for _, cam, _, view in _views(preset, frames=(2,)):
        dirs, zscale = cam.ray_grid(1)
        t = -cam.centre[2] / np.minimum(dirs[..., 2], -1e-12)
        ground = cam.centre + t[..., None] * dirs
        on_pitch = (np.abs(ground[..., 0]) < 45) & (np.abs(ground[..., 1]) < 30) & (view.ids == 0)
        on_pitch &= dirs[..., 2] < 0
        np.testing.assert_allclose(view.depth[on_pitch], (t * zscale)[on_pitch], rtol=1e-6)
        checked += on_pitch.sum()
    assert checked > 500


def _part_of(body, x):
    """The part whose surface a point lies on (the others' surfaces are farther)."""
    gap = [np.linalg.norm(x - closest_on_segment(x, np.broadcast_to(body.a[i], x.shape),
                                                    np.broadcast_to(body.b[i], x.shape)), axis=1)
           - body.radius[i] for i in range(len(body.radius))]
    return np.argmin(np.abs(np.stack(gap, 1)), axis=1)


@pytest.mark.parametrize("preset", ["single-player-closeup", "players-stadium"])
def test_flow_carries_player_pixels_onto_the_same_body_point(preset):
    scene = build_scene(preset, seed=0, size="tiny", width=128, height=72, spp=1, fps=30)
    errors, same_id = [], []
    cams = scene.cameras if preset != "players-stadium" else [scene.camera("eval00")]
    for cam in cams:
        for f in (1, 3, 5):
            view, nxt = render_view(scene, cam.name, f), render_view(scene, cam.name, f + 1)
            now = {b.id: b for b in scene.bodies(f)}
            later = {b.id: b for b in scene.bodies(f + 1)}
            dirs, zscale = cam.ray_grid(1)
            for pid, cls in scene.classes.items():
                if cls != "person":
                    continue
                rows, cols = np.nonzero(view.ids == pid)
                if rows.size == 0:
                    continue
                x = cam.centre + (view.depth[rows, cols] / zscale[rows, cols])[:, None] * dirs[rows, cols]
                part = _part_of(now[pid], x)
                x_next = later[pid].to_world(now[pid].to_local(x, part), part)
                target, _ = cam.project(x_next)
                landed = np.stack([cols + 0.5, rows + 0.5], 1) + view.flow[rows, cols]
                errors.append(np.linalg.norm(landed - target, axis=1))
                q = np.floor(landed).astype(int)
                inside = (q[:, 0] >= 0) & (q[:, 0] < cam.width) & (q[:, 1] >= 0) & (q[:, 1] < cam.height)
                q = q[inside]
                near = [nxt.ids[np.clip(q[:, 1] + dy, 0, cam.height - 1),
                                np.clip(q[:, 0] + dx, 0, cam.width - 1)] == pid
                        for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
                same_id.append(np.any(near, axis=0))
    errors, same_id = np.concatenate(errors), np.concatenate(same_id)
    assert errors.size > 200
    assert errors.max() < 1e-3  # the issue asks < 0.5 px; exact flow is off by float32 rounding only
    # and the next render shows that player there (within a pixel: thin limbs, silhouettes)
    assert same_id.mean() > 0.98


def test_visible_fraction_is_against_the_object_rendered_alone():
    scene = build_scene("single-player-closeup", seed=0, size="tiny", spp=1)
    seen_partial = False
    for cam in scene.cameras:
        for f in range(scene.n_frames):
            view = render_view(scene, cam.name, f)
            for b in view.boxes:
                others = tuple(i for i in scene.classes if i != b["id"])
                alone = render_view(scene, cam.name, f, hide=others)
                expected = (view.ids == b["id"]).sum() / (alone.ids == b["id"]).sum()
                assert b["visible"] == pytest.approx(expected, abs=1e-4)
                seen_partial |= b["visible"] < 1
    assert seen_partial


def test_hidden_ball_leaves_no_pixels_box_or_shadow():
    scene = build_scene("single-player-closeup", seed=0, size="tiny", spp=1)
    ball_id = next(i for i, c in scene.classes.items() if c == "ball")
    full = render_view(scene, "eval00", 0)
    erased = render_view(scene, "eval00", 0, hide=("ball",))
    assert (full.ids == ball_id).any()
    assert not (erased.ids == ball_id).any()
    assert all(b["class"] != "ball" for b in erased.boxes)
    # where neither render saw the ball, only the ball's shadow may differ; it must exist and be darker
    rest = (full.ids != ball_id)
    diff = erased.rgb[rest].mean(1) - full.rgb[rest].mean(1)
    assert diff.min() >= 0
    hi = build_scene("single-player-closeup", seed=0, size="tiny", width=256, height=144, spp=1)
    a, b = render_view(hi, "eval00", 0), render_view(hi, "eval00", 0, hide=("ball",))
    assert (b.rgb.mean(2) - a.rgb.mean(2))[a.ids == 0].max() > 0.05  # a shadow was there


def test_last_frame_has_no_flow():
    scene = build_scene("single-player-broadcast", seed=0, size="tiny", spp=1)
    assert render_view(scene, "cam00", scene.n_frames - 1).flow is None


def test_render_view_rejects_bad_frame_and_camera():
    scene = build_scene("single-player-broadcast", seed=0, size="tiny", spp=1)
    with pytest.raises(InputError, match=r"frame must be in \[0, 8\)"):
        render_view(scene, "cam00", 8)
    with pytest.raises(InputError, match="no camera 'cam99'"):
        render_view(scene, "cam99", 0)


def test_supersampling_changes_edges_not_the_ground_truth():
    scene = build_scene("single-player-closeup", seed=0, size="tiny")
    one, four = render_view(scene, "cam00", 4, spp=1), render_view(scene, "cam00", 4, spp=4)
    np.testing.assert_array_equal(one.ids, four.ids)
    np.testing.assert_array_equal(one.depth, four.depth)
    assert np.abs(one.rgb - four.rgb).max() > 0.05


def test_chunked_casting_gives_the_same_view(monkeypatch):
    import reference_models.scenes.render as render

    scene = build_scene("players-stadium", seed=0, size="tiny")
    whole = render_view(scene, "eval00", 4)
    monkeypatch.setattr(render, "_CHUNK", 999)
    chunked = render_view(scene, "eval00", 4)
    for name in ("rgb", "depth", "ids", "flow"):
        np.testing.assert_array_equal(getattr(whole, name), getattr(chunked, name))
    assert whole.boxes == chunked.boxes


def test_per_part_culling_gives_the_same_view(monkeypatch):
    import reference_models.scenes.render as render

    scene = build_scene("single-player-closeup", seed=0, size="tiny", width=160, height=90)
    monkeypatch.setattr(render, "_PER_PART", 10**9)  # whole bodies, vectorised over parts
    whole = render_view(scene, "eval00", 3)
    monkeypatch.setattr(render, "_PER_PART", 0)  # every part in its own block
    parts = render_view(scene, "eval00", 3)
    np.testing.assert_array_equal(whole.ids, parts.ids)
    np.testing.assert_allclose(whole.depth, parts.depth, rtol=1e-6)
    np.testing.assert_allclose(whole.flow, parts.flow, atol=1e-4)
    np.testing.assert_allclose(whole.rgb, parts.rgb, atol=1e-6)
    assert whole.boxes == parts.boxes

"""Motion weights (ISG / IST) and masks on a moving square over a static textured background."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.core.boxes import boxes_to_mask
from dynaeval.errors import InputError
from dynaeval.regions.motion import (
    LazyFrames,
    MotionConfig,
    clean_mask,
    importance_weights,
    iter_importance_weights,
    iter_motion_masks,
    mask_boxes,
    motion_mask,
    subsample_indices,
    temporal_median,
)

T, H, W, S = 20, 48, 64, 8
COLOUR = np.array([0.95, 0.05, 0.05], np.float32)


def square_box(t: int) -> list[int]:
    x, y = 4 + 2 * t, 6 + t
    return [x, y, x + S, y + S]


def scene(noise: float = 0.0, moving: bool = True, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(T, H, W, 3) float32 frames in [0, 1] and (T, H, W) bool true square masks."""
    rng = np.random.default_rng(seed)
    bg = rng.uniform(0.3, 0.7, (H, W, 3)).astype(np.float32)
    frames = np.repeat(bg[None], T, axis=0)
    truth = np.zeros((T, H, W), bool)
    for t in range(T):
        if moving:
            truth[t] = boxes_to_mask([square_box(t)], H, W)
            frames[t][truth[t]] = COLOUR
    frames += rng.normal(0, noise, frames.shape).astype(np.float32)
    return np.clip(frames, 0, 1), truth


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


# ------------------------------------------------------------------------------------------
# slow readable references


def isg_reference(frames: np.ndarray, gamma: float) -> np.ndarray:
    med = np.median(frames.astype(np.float64), axis=0)
    out = np.zeros(frames.shape[:3])
    for t in range(frames.shape[0]):
        for c in range(frames.shape[3]):
            d = frames[t, ..., c] - med[..., c]
            out[t] += d**2 / (d**2 + gamma**2) / frames.shape[3]
    return out


def ist_reference(frames: np.ndarray, window: int, alpha: float) -> np.ndarray:
    n = frames.shape[0]
    out = np.zeros(frames.shape[:3])
    for t in range(n):
        best = np.zeros(frames.shape[1:])
        for j in range(max(0, t - window), min(n, t + window + 1)):
            if j != t:
                best = np.maximum(best, np.abs(frames[t].astype(np.float64) - frames[j]))
        out[t] = np.maximum(best.mean(axis=-1), alpha)
    return out


def test_isg_matches_reference():
    frames, _ = scene(noise=0.01)
    w = importance_weights(frames, "isg", gamma=0.02)
    assert w.shape == (T, H, W) and w.dtype == np.float32
    np.testing.assert_allclose(w, isg_reference(frames, 0.02), rtol=1e-5, atol=1e-6)
    assert 0.0 <= w.min() and w.max() < 1.0


@pytest.mark.parametrize("window", [1, 3, 25])
def test_ist_matches_reference(window):
    frames, _ = scene(noise=0.01)
    w = importance_weights(frames, "ist", window=window, alpha=0.1)
    np.testing.assert_allclose(w, ist_reference(frames, window, 0.1), rtol=1e-5, atol=1e-6)
    assert w.min() >= np.float32(0.1)


def test_ist_accepts_a_generator():
    frames, _ = scene(noise=0.01)
    w_gen = importance_weights((f for f in frames), "ist", window=3)
    np.testing.assert_array_equal(w_gen, importance_weights(frames, "ist", window=3))


def test_uint8_frames_score_like_float():
    frames, _ = scene(noise=0.01)
    u8 = np.round(frames * 255).astype(np.uint8)
    np.testing.assert_allclose(
        importance_weights(u8, "isg"), importance_weights(u8.astype(np.float32) / 255, "isg"), rtol=1e-6, atol=1e-7
    )


def test_grayscale_frames_are_one_channel():
    frames, _ = scene(noise=0.01)
    gray = frames.mean(axis=-1)
    np.testing.assert_allclose(
        importance_weights(gray, "isg"), importance_weights(gray[..., None], "isg"), rtol=0, atol=0
    )
    np.testing.assert_allclose(importance_weights(gray, "isg"), isg_reference(gray[..., None], 0.02), rtol=1e-5, atol=1e-6)


# ------------------------------------------------------------------------------------------
# bounded memory


def test_median_is_exact_when_sequence_fits_the_cap():
    frames, _ = scene(noise=0.05)
    np.testing.assert_array_equal(temporal_median(frames, max_frames=64), np.median(frames, axis=0))
    np.testing.assert_array_equal(temporal_median(frames, max_frames=T), np.median(frames, axis=0))


@pytest.mark.parametrize("count", [1, 2, T])
def test_median_on_threads_equals_the_sequential_one(count):
    """With an executor the frames are read and the median is taken band by band on threads:
    the very same values (each pixel's median is its own), also for odd frame counts."""
    from concurrent.futures import ThreadPoolExecutor

    frames, _ = scene(noise=0.05)
    with ThreadPoolExecutor(3) as pool:
        got = temporal_median(frames[:count], executor=pool)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, temporal_median(frames[:count]))
    np.testing.assert_array_equal(got, np.median(frames[:count], axis=0))


@pytest.mark.parametrize("threads", [0, 3])
def test_median_in_bands_of_rows_reads_each_frame_once_a_band(threads):
    """A stack bigger than ``max_bytes`` is taken band by band of rows (issue 20 item 5: the
    1080p median held 1.6 GB): the same values, each band reading its frames again and holding
    no more than ``max_bytes`` of them."""
    from concurrent.futures import ThreadPoolExecutor

    frames, _ = scene(noise=0.05)
    reads = []
    lazy = LazyFrames(range(T), lambda i: reads.append(i) or frames[i])
    row = T * frames[0][0].nbytes  # one row of every frame
    pool = ThreadPoolExecutor(threads) if threads else None
    try:
        got = temporal_median(lazy, executor=pool, max_bytes=3 * row + 1)
    finally:
        if pool is not None:
            pool.shutdown()
    np.testing.assert_array_equal(got, np.median(frames, axis=0))
    bands = -(-frames.shape[1] // 3)
    assert len(reads) == 1 + (T - 1) * bands  # frame 0 is kept, the others read once a band


def test_median_subsample_is_even_and_bounded():
    idx = subsample_indices(1000, 64)
    assert len(idx) == 64 and idx[0] == 0 and idx[-1] == 999
    assert np.ptp(np.diff(idx)) <= 1
    frames, _ = scene(noise=0.05)
    np.testing.assert_array_equal(temporal_median(frames, max_frames=5), np.median(frames[subsample_indices(T, 5)], axis=0))


def test_lazy_frames_equal_array_and_load_each_frame_at_most_twice():
    frames, _ = scene(noise=0.01)
    loads: list[int] = []

    def load(i: int) -> np.ndarray:
        loads.append(i)
        return frames[i]

    w_lazy = importance_weights(LazyFrames(range(T), load), "isg", median_frames=8)
    np.testing.assert_array_equal(w_lazy, importance_weights(frames, "isg", median_frames=8))
    assert max(loads.count(i) for i in range(T)) <= 2
    assert len(LazyFrames(range(T), load)[2:5]) == 3


# ------------------------------------------------------------------------------------------
# masks


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_isg_mask_finds_the_moving_square(noise):
    frames, truth = scene(noise=noise)
    raw = motion_mask(frames, MotionConfig(dilate_radius=0))
    assert raw.shape == (T, H, W) and raw.dtype == bool
    ious = [iou(raw[t], truth[t]) for t in range(T)]
    assert min(ious) > 0.9, ious
    dilated = motion_mask(frames)  # default: 2 px dilation -> contains the square, grows by <= 2 px
    assert np.all(dilated[truth])
    tol = 0 if noise == 0 else 1  # a noisy neighbour pixel may join the blob
    for t in range(T):
        boxes = mask_boxes(dilated[t])
        assert boxes.shape == (1, 4)
        want = np.array(square_box(t)) + [-2, -2, 2, 2]
        assert np.all(np.abs(boxes[0] - want) <= tol), (boxes, want)


@pytest.mark.parametrize("kind", ["isg", "ist"])
def test_masks_on_an_executor_equal_the_sequential_masks(kind):
    """ISG frames run on the executor's threads (IST stays sequential): same masks, same order."""
    from concurrent.futures import ThreadPoolExecutor

    frames, _ = scene(noise=0.01)
    cfg = MotionConfig(kind=kind, window=2)
    seq = list(iter_motion_masks(frames, cfg))
    lazy = LazyFrames(list(range(T)), lambda i: frames[i])
    with ThreadPoolExecutor(max_workers=3) as pool:
        par = list(iter_motion_masks(lazy, cfg, pool))
    assert len(par) == T and all(np.array_equal(a, b) for a, b in zip(seq, par, strict=True))
    assert sum(m.sum() for m in par) > 0


def test_ist_mask_contains_the_square():
    frames, truth = scene(noise=0.01)
    m = motion_mask(frames, MotionConfig(kind="ist", window=2))
    assert np.all(m[truth])
    assert m.sum() < 6 * truth.sum()  # a trail of +-2 frames, not the whole image


@pytest.mark.parametrize("kind", ["isg", "ist"])
def test_static_sequence_gives_empty_mask(kind):
    frames, _ = scene(noise=0.01, moving=False)
    assert not motion_mask(frames, MotionConfig(kind=kind)).any()


def test_clean_mask_removes_speckle_and_small_components():
    m = np.zeros((40, 40), bool)
    m[5, 5] = True  # single pixel: removed by opening
    m[20:23, 20:23] = True  # 9 px blob: survives opening, removed by min_area=16
    m[30:36, 2:10] = True  # 48 px: kept
    out = clean_mask(m, MotionConfig(dilate_radius=0))
    assert not out[5, 5] and not out[20:23, 20:23].any()
    want = boxes_to_mask([[2, 30, 10, 36]], 40, 40)
    want[[30, 30, 35, 35], [2, 9, 2, 9]] = False  # opening with a 3x3 cross rounds the corners
    np.testing.assert_array_equal(out, want)


def test_mask_boxes_components_and_min_area():
    m = boxes_to_mask([[1, 1, 4, 5], [10, 2, 12, 3]], 20, 20)
    assert mask_boxes(m).tolist() == [[1, 1, 4, 5], [10, 2, 12, 3]]
    assert mask_boxes(m, min_area=5).tolist() == [[1, 1, 4, 5]]
    assert mask_boxes(np.zeros((5, 5), bool)).shape == (0, 4)
    diag = np.eye(6, dtype=bool)  # 8-connected: one component
    assert mask_boxes(diag).tolist() == [[0, 0, 6, 6]]


# ------------------------------------------------------------------------------------------
# errors


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "flow"}, "motion kind must be 'isg' or 'ist'"),
        ({"gamma": 0.0}, "gamma must be > 0"),
        ({"window": 0}, "window must be >= 1"),
        ({"alpha": 1.0}, r"alpha must be in \[0, 1\)"),
        ({"median_frames": 0}, "median_frames must be >= 1"),
        ({"min_area": -1}, "min_area must be >= 0"),
        ({"kind": "ist", "threshold": 0.05}, "must be above alpha"),
        ({"threshold": 1.0}, r"threshold must be in \[0, 1\)"),
    ],
)
def test_bad_config(kwargs, match):
    with pytest.raises(InputError, match=match):
        MotionConfig(**kwargs)


def test_bad_frames():
    frames, _ = scene()
    with pytest.raises(InputError, match="needs a sequence with len"):
        importance_weights((f for f in frames), "isg")
    with pytest.raises(InputError, match="no frames"):
        importance_weights(np.zeros((0, 4, 4, 3), np.float32), "isg")
    with pytest.raises(InputError, match="no frames"):
        importance_weights(iter([]), "ist")
    with pytest.raises(InputError, match=r"frame 3: float values must be in \[0, 1\]"):
        bad = frames.copy()
        bad[3, 0, 0, 0] = 1.5
        importance_weights(bad, "ist", window=1)
    with pytest.raises(InputError, match="frame 1: shape"):
        importance_weights([frames[0], frames[1][:10]], "isg")
    with pytest.raises(InputError, match="frame 0 contains 48 NaN or Inf values"):
        importance_weights(np.full((2, 4, 4, 3), np.nan, np.float32), "ist")
    with pytest.raises(InputError, match="uint8 or float"):
        importance_weights(np.zeros((2, 4, 4, 3), np.int16), "ist")
    with pytest.raises(InputError, match="kind must be 'isg' or 'ist'"):
        list(iter_importance_weights(frames, "median"))
    with pytest.raises(InputError, match=r"frames must be \(T, H, W, C\)"):
        importance_weights(np.zeros((4, 4), np.float32), "isg")
    with pytest.raises(InputError, match=r"takes one \(H, W\) mask"):
        mask_boxes(np.zeros((2, 4, 4), bool))


@pytest.mark.parametrize("where", ["inside", "near_border", "touching_border"])
def test_closing_does_not_grow_objects_at_the_border(where):
    # OpenCV's default border makes a closing extend objects near the edge out to the edge.
    x0 = {"inside": 10, "near_border": 2, "touching_border": 0}[where]
    m = boxes_to_mask([[x0, 30, x0 + 8, 36], [30, 0, 40, 5]], 40, 40)
    cfg = MotionConfig(open_radius=0, close_radius=2, min_area=0, dilate_radius=0)
    np.testing.assert_array_equal(clean_mask(m, cfg), m)

"""The one image validator (dynaeval.core.validation): the range rule, shapes, dtypes, NaN/Inf."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.core.validation import as_image, check_data_range, check_pair, to_numpy
from dynaeval.errors import InputError

U8 = np.arange(48, dtype=np.uint8).reshape(4, 4, 3) * 5


def test_unit_images_divide_integers_by_the_dtype_maximum():
    np.testing.assert_array_equal(as_image(U8), U8.astype(np.float32) / np.float32(255))
    u16 = U8.astype(np.uint16) * 257
    np.testing.assert_array_equal(as_image(u16), u16.astype(np.float32) / np.float32(65535))
    np.testing.assert_allclose(as_image(u16), as_image(U8), atol=1e-7)  # 257 = 65535 / 255
    assert as_image(U8).dtype == np.float32


def test_values_are_kept_when_the_caller_states_data_range():
    out = as_image(U8, to_unit=False)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, U8.astype(np.float32))
    assert as_image(np.zeros((2, 2), np.int32), to_unit=False).dtype == np.float32


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_floats_are_taken_as_they_are(dtype):
    x = np.linspace(-0.5, 2.0, 12, dtype=dtype).reshape(3, 4)
    out = as_image(x)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, x.astype(np.float32))
    assert as_image(x, keep_float64=True).dtype == (np.float64 if dtype == np.float64 else np.float32)


def test_float32_numpy_input_is_not_copied():
    x = np.zeros((3, 3), np.float32)
    assert np.shares_memory(as_image(x), x)
    assert np.shares_memory(as_image(x, to_unit=False), x)


def test_torch_tensors_are_accepted():
    torch = pytest.importorskip("torch")
    t = torch.from_numpy(U8.copy())
    np.testing.assert_array_equal(as_image(t), as_image(U8))
    np.testing.assert_array_equal(as_image(t.float(), to_unit=False), U8.astype(np.float32))


@pytest.mark.parametrize(
    ("image", "kwargs", "match"),
    [
        (np.zeros((2, 2), np.int32), {}, r"frame 3 has unsupported pixel type int32: expected uint8 or float"),
        (np.zeros((2, 2), bool), {}, "unsupported pixel type bool"),
        (np.zeros((2, 2), bool), {"to_unit": False}, r"frame 3 must hold numbers .* got dtype bool"),
        (np.array([["a"]]), {"to_unit": False}, "must hold numbers"),
        (np.zeros(4, np.float32), {}, r"frame 3 must be \(H, W\) or \(H, W, C\), got shape \(4,\)"),
        (np.zeros((0, 4), np.float32), {}, r"frame 3 is empty \(shape \(0, 4\)\)"),
        (np.zeros((2, 2, 0), np.float32), {}, "is empty"),
        (np.zeros((2, 2), np.float32), {"channels": 3}, r"frame 3 must be an \(H, W, 3\) RGB image, got shape \(2, 2\)"),
        (np.zeros((2, 2, 4), np.float32), {"channels": 1}, r"must be \(H, W, 1\), got shape \(2, 2, 4\)"),
        (np.array([[np.nan, np.inf]]), {}, "frame 3 contains 2 NaN or Inf values"),
        (np.array([[1.5, 0.0]]), {"check_range": True}, r"frame 3: float values must be in \[0, 1\], got values in \[0, 1\.5\]"),
    ],
)
def test_errors(image, kwargs, match):
    with pytest.raises(InputError, match=match):
        as_image(image, "frame 3", **kwargs)


def test_checks_that_can_be_turned_off():
    nan = np.array([[np.nan, 2.0]])
    assert np.isnan(as_image(nan, finite=False)).any()
    assert as_image(np.array([[2.0]])).max() == 2.0  # no range check unless asked: never clipped
    assert as_image(U8, check_range=True).max() <= 1.0  # integers are in range by construction


def test_errors_name_the_file(tmp_path):
    with pytest.raises(InputError, match=r"x\.tif: image has unsupported pixel type int64"):
        as_image(np.zeros((2, 2), np.int64), path=tmp_path / "x.tif")


def test_check_pair_keeps_values_and_float64():
    p, g = check_pair(U8, U8)
    np.testing.assert_array_equal(p, U8.astype(np.float32))
    assert check_pair(np.zeros((2, 2)), np.zeros((2, 2)))[0].dtype == np.float64
    with pytest.raises(InputError, match=r"same shape, got pred \(2, 2\) and gt \(2, 3\)"):
        check_pair(np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(InputError, match="gt contains 1 NaN or Inf"):
        check_pair(np.zeros((1, 2)), np.array([[0.0, np.nan]]))
    assert np.isnan(check_pair(np.zeros((1, 2)), np.array([[0.0, np.nan]]), finite=False)[1]).any()


def test_to_numpy_does_not_copy_numpy():
    x = np.zeros(3)
    assert to_numpy(x, "x") is x


@pytest.mark.parametrize("bad", [0, -1, float("nan"), float("inf"), "x", None])
def test_check_data_range(bad):
    assert check_data_range(255) == 255.0
    with pytest.raises(InputError, match="data_range must be a positive number"):
        check_data_range(bad)


def test_grey_to_rgb_replicates_grey_and_refuses_other_channel_counts():
    from dynaeval.core.validation import grey_to_rgb

    grey = np.arange(6, dtype=np.uint8).reshape(2, 3)
    for x in (grey, grey[..., None]):
        out = grey_to_rgb(x, "pred", "LPIPS")
        assert out.shape == (2, 3, 3) and out.dtype == np.uint8
        assert (out == grey[..., None]).all()
    rgb = np.zeros((2, 3, 3), np.float32)
    assert grey_to_rgb(rgb, "pred", "LPIPS") is rgb
    with pytest.raises(InputError, match=r"FLIP needs RGB .* got gt with 4 channels"):
        grey_to_rgb(np.zeros((2, 3, 4)), "gt", "FLIP")


@pytest.mark.parametrize("shape", [(256,), (16, 16), (8, 32, 1), (8, 32, 3), (8, 32, 4), (4, 8, 5)])
@pytest.mark.parametrize("strided", [False, True])
def test_unit_u8_is_the_float32_division_bit_for_bit(shape, strided):
    from dynaeval.core.validation import unit_u8

    arr = (np.arange(int(np.prod(shape))) % 256).astype(np.uint8).reshape(shape)
    arr = arr[..., ::-1] if strided else arr  # a view OpenCV cannot take: the numpy lookup
    want = arr.astype(np.float32) / np.float32(255)
    got = unit_u8(arr)
    assert got.dtype == np.float32 and got.shape == arr.shape
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


# ---- the range rule with a data_range (issue 32, item 1) ---------------------------------------

F255 = np.linspace(0.0, 255.0, 48).reshape(4, 4, 3)


@pytest.mark.parametrize(
    ("image", "data_range", "match"),
    [
        (U8, 1.0, r"pred is uint8 \(integer values, 0\.\.255\) but data_range is 1: integers are "
                  r"never read as \[0, 1\]; pass data_range=255, or pred / 255 as float"),
        (U8.astype(np.uint16), 0.5, r"pred is uint16 .* pass data_range=65535, or pred / 65535"),
        (U8.astype(np.int64), 1.0, r"pred is int64 .* pass data_range=255, or pred / 255"),
        (F255, 1.0, r"pred holds values in \[0, 255\], outside \[0, data_range\] = \[0, 1\]: "
                    r"0\.\.255 values\? pass data_range=255, or x / 255"),
        (F255 / 127.5 - 1.0, 1.0, r"values in \[-1, 1\], outside .* pass \(x \+ 1\) / 2"),
        (np.full((2, 2), 1.5), 1.0, r"\[1\.5, 1\.5\], outside .* pass the data_range the images "
                                    r"use \(data_range=255 for 0\.\.255 values\), or scale .*"
                                    r"np\.clip\(x, 0, 1\)"),
        (U8.astype(np.int16) - 10, 255.0, r"values in \[-10, 225\], outside \[0, data_range\] = "
                                          r"\[0, 255\]"),
        (U8.astype(np.uint16) * 2, 255.0, r"values in \[0, 470\], outside"),
        (np.full((2, 2), 1.002), 1.0, r"outside \[0, data_range\]"),  # beyond the tolerance
        (np.full((2, 2), -0.002), 1.0, r"outside \[0, data_range\]"),
    ],
)
def test_values_outside_data_range_are_refused_with_the_fix(image, data_range, match):
    with pytest.raises(InputError, match=match):
        check_pair(image, np.zeros_like(image), data_range=data_range)


def test_values_in_range_are_kept_as_they_are():
    edge = np.array([[-5e-4, 1.0 + 5e-4]])  # a renderer's rounding: within FLOAT_TOLERANCE
    p, _ = check_pair(edge, edge, data_range=1.0)
    np.testing.assert_array_equal(p, edge)  # kept, not clipped
    p, _ = check_pair(U8, U8, data_range=255)
    np.testing.assert_array_equal(p, U8.astype(np.float32))
    p, _ = check_pair(F255 / 255, F255 / 255, data_range=1)
    assert p.max() == 1.0


def test_the_range_pass_reports_nan_as_nan():
    with pytest.raises(InputError, match="gt contains 1 NaN or Inf"):
        check_pair(np.zeros((1, 2)), np.array([[0.0, np.nan]]), data_range=1.0)
    with pytest.raises(InputError, match="pred contains 1 NaN or Inf"):
        check_pair(np.array([[0.0, np.inf]]), np.zeros((1, 2)), data_range=1.0, finite=False)


def test_values_known_in_skips_the_range_pass_in_its_thread_only():
    import threading

    from dynaeval.core.validation import values_known_in

    big = np.full((2, 2), 0.8)
    with values_known_in(1.0):
        check_pair(big, big, data_range=1.0)  # known in [0, 1]: not checked again
        with pytest.raises(InputError, match=r"outside \[0, data_range\] = \[0, 0\.5\]"):
            check_pair(big, big, data_range=0.5)  # a narrower range is still checked
        with pytest.raises(InputError, match="contains 1 NaN"):  # the finite check stays
            check_pair(np.array([[np.nan, 0.0]]), big[:1], data_range=1.0)
        errors = []

        def other_thread():
            try:
                check_pair(F255, F255, data_range=1.0)
            except InputError as err:
                errors.append(err)

        t = threading.Thread(target=other_thread)
        t.start()
        t.join()
        assert len(errors) == 1  # another thread knows nothing of this block
    with pytest.raises(InputError, match="outside"):
        check_pair(F255, F255, data_range=1.0)  # and after the block it checks again


# ---- the layout rule (issue 32, item 2) --------------------------------------------------------


@pytest.mark.parametrize(
    ("shape", "match"),
    [
        ((3, 20, 30), r"pred looks channel-first: shape \(3, 20, 30\) read as \(C, H, W\); .* "
                      r"pass np\.moveaxis\(x, 0, -1\)"),
        ((1, 20, 30), r"shape \(1, 20, 30\) read as \(C, H, W\)"),
        ((4, 5, 6), r"shape \(4, 5, 6\) read as \(C, H, W\)"),
        ((2, 3, 20, 30), r"pred looks like a channel-first batch: shape \(2, 3, 20, 30\) read as "
                         r"\(B, C, H, W\); .* np\.moveaxis\(x\[i\], 0, -1\) for each image i, or "
                         r"feed the batch to dynaeval\.metrics\.ImageMetrics"),
    ],
)
def test_channel_first_images_are_refused_with_the_permute(shape, match):
    with pytest.raises(InputError, match=match):
        check_pair(np.zeros(shape), np.zeros(shape))


def test_channel_first_tensors_are_told_to_permute():
    torch = pytest.importorskip("torch")
    with pytest.raises(InputError, match=r"\(3, 20, 30\) read as \(C, H, W\).* pass "
                                         r"x\.permute\(1, 2, 0\)"):
        as_image(torch.zeros(3, 20, 30), "pred", to_unit=False)
    with pytest.raises(InputError, match=r"x\[i\]\.permute\(1, 2, 0\) for each image i"):
        as_image(torch.zeros(2, 3, 20, 30), "pred")


@pytest.mark.parametrize("shape", [(20, 30, 3), (20, 30, 4), (20, 30, 1), (3, 4, 3), (4, 4),
                                   (3, 30), (20, 30, 5)])
def test_channel_last_images_are_not_mistaken_for_channel_first(shape):
    assert check_pair(np.zeros(shape), np.zeros(shape))[0].shape == shape

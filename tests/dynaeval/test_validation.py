"""The one image validator (dynaeval.validation): the range rule, shapes, dtypes, NaN/Inf."""

from __future__ import annotations

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.validation import as_image, check_data_range, check_pair, to_numpy

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
    from dynaeval.validation import grey_to_rgb

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
    from dynaeval.validation import unit_u8

    arr = (np.arange(int(np.prod(shape))) % 256).astype(np.uint8).reshape(shape)
    arr = arr[..., ::-1] if strided else arr  # a view OpenCV cannot take: the numpy lookup
    want = arr.astype(np.float32) / np.float32(255)
    got = unit_u8(arr)
    assert got.dtype == np.float32 and got.shape == arr.shape
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))

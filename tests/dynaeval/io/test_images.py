"""Reading images: range from the dtype, channels, alpha, corrupt files."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.io import composite_alpha, read_image, to_float


@pytest.fixture
def rgb8(rng) -> np.ndarray:
    return rng.integers(0, 256, size=(13, 17, 3), dtype=np.uint8)


def test_png8_is_rgb_in_unit_range(tmp_path, rgb8):
    cv2.imwrite(str(tmp_path / "a.png"), rgb8[..., ::-1])  # cv2 writes BGR
    img = read_image(tmp_path / "a.png")
    assert img.dtype == np.float32 and img.shape == (13, 17, 3)
    np.testing.assert_array_equal(img, rgb8.astype(np.float32) / 255)


def test_png16_and_png8_of_same_picture_agree_to_quantisation(tmp_path, rgb8):
    cv2.imwrite(str(tmp_path / "a8.png"), rgb8[..., ::-1])
    cv2.imwrite(str(tmp_path / "a16.png"), (rgb8.astype(np.uint16) * 257)[..., ::-1])
    a8, a16 = read_image(tmp_path / "a8.png"), read_image(tmp_path / "a16.png")
    np.testing.assert_allclose(a8, a16, atol=1e-7)  # x*257/65535 == x/255 exactly


def test_range_comes_from_dtype_not_content(tmp_path):
    dark = np.full((4, 4, 3), 3, np.uint8)  # a dark image is not rescaled to its own max
    cv2.imwrite(str(tmp_path / "d.png"), dark)
    np.testing.assert_allclose(read_image(tmp_path / "d.png"), 3 / 255)


def test_grayscale_keeps_one_channel(tmp_path, rng):
    g = rng.integers(0, 256, size=(5, 6), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "g.png"), g)
    img = read_image(tmp_path / "g.png")
    assert img.shape == (5, 6, 1)
    np.testing.assert_array_equal(img[..., 0], g / np.float32(255))


@pytest.mark.parametrize("background,expected", [("white", 1.0), ("black", 0.0)])
def test_rgba_composited_over_background(tmp_path, background, expected):
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 2] = 255  # red in BGRA order
    rgba[0, 0, 3] = 255  # opaque red
    rgba[1, 1, 3] = 0  # fully transparent
    cv2.imwrite(str(tmp_path / "a.png"), rgba)
    img = read_image(tmp_path / "a.png", background=background)
    np.testing.assert_allclose(img[0, 0], [1, 0, 0])
    np.testing.assert_allclose(img[1, 1], [expected] * 3)


def test_composite_alpha_half():
    rgba = np.array([[[1.0, 0.0, 0.0, 0.5]]], np.float32)
    np.testing.assert_allclose(composite_alpha(rgba, "white"), [[[1.0, 0.5, 0.5]]])


def test_jpeg_and_tiff_read(tmp_path, rgb8):
    cv2.imwrite(str(tmp_path / "a.jpg"), rgb8, [cv2.IMWRITE_JPEG_QUALITY, 100])
    cv2.imwrite(str(tmp_path / "a.tif"), (rgb8.astype(np.uint16) * 257))
    assert read_image(tmp_path / "a.jpg").shape == (13, 17, 3)
    np.testing.assert_allclose(read_image(tmp_path / "a.tif"), rgb8[..., ::-1] / 255, atol=1e-7)


def _write_exr(OpenEXR, path, rgb) -> None:  # noqa: ANN001, N803
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(hdr, {"RGB": rgb}) as f:
        f.write(str(path))


def test_exr_float_read_as_stored(tmp_path, rng):
    OpenEXR = pytest.importorskip("OpenEXR")
    rgb = rng.random((4, 5, 3), dtype=np.float32)
    _write_exr(OpenEXR, tmp_path / "a.exr", rgb)
    np.testing.assert_array_equal(read_image(tmp_path / "a.exr"), rgb)


def test_exr_hdr_above_one_is_refused_naming_file_and_range(tmp_path, rng):
    """Issue 16 item 8: one range rule at reading time (HDR values used to pass under
    ``--focus none`` and be refused by the detector)."""
    OpenEXR = pytest.importorskip("OpenEXR")
    rgb = rng.random((4, 5, 3), dtype=np.float32) * 2
    rgb[0, 0, 0] = 2.0
    _write_exr(OpenEXR, tmp_path / "a.exr", rgb)
    with pytest.raises(InputError, match=r"a\.exr: float pixel values must be in \[0, 1\], .*"
                                         r"\[.*, 2\]; tone-map or clip"):
        read_image(tmp_path / "a.exr")


def test_exr_with_nan_is_an_error_naming_the_file(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    rgb = np.zeros((3, 3, 3), np.float32)
    rgb[1, 1, 0] = np.nan
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(hdr, {"RGB": rgb}) as f:
        f.write(str(tmp_path / "nan.exr"))
    with pytest.raises(InputError, match=r"nan\.exr: 1 pixel values are NaN or Inf"):
        read_image(tmp_path / "nan.exr")


def test_float16_array_to_float():
    assert to_float(np.ones((2, 2), np.float16)).dtype == np.float32


def test_unsupported_dtype():
    with pytest.raises(InputError, match="unsupported pixel type int32"):
        to_float(np.ones((2, 2), np.int32))


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.png: file not found"):
        read_image(tmp_path / "nope.png")


@pytest.mark.parametrize("cut", [0.5, "IEND"])
def test_truncated_png_is_named_before_libpng_prints(tmp_path, rgb8, capfd, cut):
    """libpng refuses a PNG without its IEND chunk, but first writes "PNG input buffer is
    incomplete" to stderr; the check comes first, so the user sees one message."""
    cv2.imwrite(str(tmp_path / "a.png"), rgb8)
    data = (tmp_path / "a.png").read_bytes()
    end = len(data) // 2 if cut == 0.5 else len(data) - 6  # half, or inside the IEND chunk
    (tmp_path / "t.png").write_bytes(data[:end])
    assert cv2.imdecode(np.frombuffer(data[:end], np.uint8), cv2.IMREAD_UNCHANGED) is None
    capfd.readouterr()
    with pytest.raises(InputError, match=r"t\.png: truncated PNG \(no IEND chunk\)"):
        read_image(tmp_path / "t.png")
    assert "libpng" not in capfd.readouterr().err


def test_png_with_bytes_after_iend_still_reads(tmp_path, rgb8):
    cv2.imwrite(str(tmp_path / "a.png"), rgb8)
    (tmp_path / "b.png").write_bytes((tmp_path / "a.png").read_bytes() + b"trailing bytes")
    np.testing.assert_array_equal(read_image(tmp_path / "b.png"), read_image(tmp_path / "a.png"))


def test_truncated_jpeg_is_not_silently_grey(tmp_path, rgb8):
    cv2.imwrite(str(tmp_path / "a.jpg"), rgb8)
    data = (tmp_path / "a.jpg").read_bytes()
    (tmp_path / "t.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"t\.jpg: truncated JPEG"):
        read_image(tmp_path / "t.jpg")


def test_not_an_image(tmp_path):
    (tmp_path / "x.png").write_bytes(b"hello")
    with pytest.raises(InputError, match="cannot decode image"):
        read_image(tmp_path / "x.png")


def test_empty_file(tmp_path):
    (tmp_path / "x.png").write_bytes(b"")
    with pytest.raises(InputError, match="cannot decode image"):
        read_image(tmp_path / "x.png")


def test_unknown_extension(tmp_path):
    (tmp_path / "x.gif").write_bytes(b"GIF89a")
    with pytest.raises(InputError, match="unsupported image extension '.gif'"):
        read_image(tmp_path / "x.gif")


# --- issue 16: inputs users really have ------------------------------------------------------


def test_unreadable_image_is_an_input_error_naming_it(tmp_path, rgb8, monkeypatch):
    """Item 6: a PermissionError (the tests may run as root, where chmod 000 still reads, so
    the refusal is simulated) becomes InputError naming the file, not a traceback."""
    cv2.imwrite(str(tmp_path / "a.png"), rgb8)
    real = type(tmp_path).read_bytes

    def refuse(self):  # noqa: ANN001, ANN202
        if self.name == "a.png":
            raise PermissionError(13, "Permission denied", str(self))
        return real(self)

    monkeypatch.setattr(type(tmp_path), "read_bytes", refuse)
    with pytest.raises(InputError, match=r"a\.png: cannot read the file: permission denied"):
        read_image(tmp_path / "a.png")


def test_huge_float_tiff_is_refused_naming_file_and_min_max(tmp_path):
    """Item 8: a float TIFF of 1e30 used to reach SSIM (RuntimeError: ssim is NaN)."""
    img = np.full((12, 12, 3), 1e30, np.float32)
    img[0, 0] = 0.25
    cv2.imwrite(str(tmp_path / "huge.tif"), img)
    with pytest.raises(InputError, match=r"huge\.tif: float pixel values must be in \[0, 1\], "
                                         r"this file holds values in \[0\.25, 1e\+30\]"):
        read_image(tmp_path / "huge.tif")


def test_negative_float_tiff_is_refused(tmp_path):
    cv2.imwrite(str(tmp_path / "neg.tif"), np.full((4, 4), -0.5, np.float32))
    with pytest.raises(InputError, match=r"neg\.tif: float pixel values must be in \[0, 1\]"):
        read_image(tmp_path / "neg.tif")


def test_float_rounding_just_outside_unit_range_is_clipped(tmp_path):
    """Within FLOAT_TOLERANCE (a renderer's rounding) values are clipped, so every path (the
    detector and motion masks check [0, 1] exactly) sees the same image."""
    img = np.array([[1.0004, -0.0004, 0.5]], np.float32)
    cv2.imwrite(str(tmp_path / "r.tif"), img)
    np.testing.assert_array_equal(read_image(tmp_path / "r.tif")[..., 0], [[1.0, 0.0, 0.5]])


def test_float_tiff_in_unit_range_is_read_exactly(tmp_path, rng):
    img = rng.random((5, 6, 3), dtype=np.float32)
    cv2.imwrite(str(tmp_path / "f.tif"), img)
    np.testing.assert_array_equal(read_image(tmp_path / "f.tif"), img[..., ::-1])


def test_png_named_jpg_is_decoded_by_content(tmp_path, rgb8):
    """Item 12: a valid PNG named .jpg used to be refused as a "truncated JPEG"."""
    ok, buf = cv2.imencode(".png", rgb8[..., ::-1])
    (tmp_path / "a.jpg").write_bytes(buf.tobytes())
    np.testing.assert_array_equal(read_image(tmp_path / "a.jpg"), rgb8 / np.float32(255))


def test_truncated_jpeg_is_still_named(tmp_path, rgb8):
    ok, buf = cv2.imencode(".jpg", rgb8)
    (tmp_path / "t.png").write_bytes(buf.tobytes()[: len(buf) // 2])  # JPEG bytes, any name
    with pytest.raises(InputError, match=r"t\.png: truncated JPEG"):
        read_image(tmp_path / "t.png")


def test_exr_named_png_is_read_as_exr(tmp_path, rng):
    OpenEXR = pytest.importorskip("OpenEXR")
    rgb = rng.random((4, 5, 3), dtype=np.float32)
    _write_exr(OpenEXR, tmp_path / "a.exr", rgb)
    (tmp_path / "a.exr").rename(tmp_path / "a.png")
    np.testing.assert_array_equal(read_image(tmp_path / "a.png"), rgb)


def test_npy_gz_frames_are_read_as_stored_rgb_under_the_dtype_rule(tmp_path):
    """Issue 32 item 11: nerfstudio's raw renders (a gzip'd ``np.save``): channels kept in RGB
    order (no BGR swap), uint8 / 255, RGBA over the background, float range checked."""
    import gzip

    from dynaeval.io.images import frame_name_parts

    def save(name, arr):
        with gzip.open(tmp_path / name, "wb") as f:
            np.save(f, arr)
        return tmp_path / name

    rgb = np.zeros((4, 5, 3), np.float32)
    rgb[..., 0] = 0.25  # red only
    assert np.array_equal(read_image(save("a.npy.gz", rgb)), rgb)
    u8 = np.full((4, 5, 3), 51, np.uint8)
    assert np.allclose(read_image(save("b.npy.gz", u8)), 0.2)
    rgba = np.concatenate([rgb, np.zeros((4, 5, 1), np.float32)], axis=2)  # fully transparent
    assert np.allclose(read_image(save("c.NPY.GZ", rgba), background="white"), 1.0)
    assert frame_name_parts(tmp_path / "frame_00001.npy.gz") == ("frame_00001", ".npy.gz")
    with pytest.raises(InputError, match=r"d\.npy\.gz.*float pixel values must be in \[0, 1\]"):
        read_image(save("d.npy.gz", rgb + 2))
    with pytest.raises(InputError, match="unsupported pixel type int32"):
        read_image(save("e.npy.gz", np.zeros((4, 5, 3), np.int32)))


# ------------------------------------------- issue 34 item 4: every TIFF pixel type, by name

REFUSED_TIFF = ("int8", "int16", "int32", "uint32")
"""Integer pixel types without a range rule (OpenCV writes and decodes them)."""


def _tiff_scene(tmp_path, dtype, value=0.25) -> tuple:
    """pred/cam0/0000..0002.tif and gt/ the same, of ``dtype`` (cv2's writer)."""
    for side in ("pred", "gt"):
        (tmp_path / side / "cam0").mkdir(parents=True)
        for i in range(3):
            img = np.full((20, 24, 3), value * (i + 1), np.float64).astype(dtype)
            assert cv2.imwrite(str(tmp_path / side / "cam0" / f"{i:04d}.tif"), img)
    return tmp_path / "pred", tmp_path / "gt"


def _cli(pred, gt, out) -> int:
    from dynaeval.cli import main

    return main(["score", str(pred), str(gt), "--no-lpips", "--focus", "none", "-q",
                 "-o", str(out)])


@pytest.mark.parametrize("dtype", REFUSED_TIFF)
def test_integer_tiffs_without_a_range_rule_are_exit_2_naming_file_and_dtype(
        tmp_path, capsys, dtype):
    """int32 / int16 / int8 / uint32 TIFFs ended in a cv2.error traceback (exit 1): exit 2
    naming the file, its pixel type and the fix, before the work (no results file)."""
    pred, gt = _tiff_scene(tmp_path, dtype, value=3)
    assert _cli(pred, gt, tmp_path / "r.json") == 2
    err = capsys.readouterr().err
    assert f"0000.tif: unsupported pixel type {dtype}" in err and "Traceback" not in err
    assert "save it as an 8/16-bit PNG, or a 32-bit float TIFF" in err
    assert not (tmp_path / "r.json").exists()
    with pytest.raises(InputError, match=f"unsupported pixel type {dtype}"):
        read_image(gt / "cam0" / "0002.tif")  # also when read (a TIFF under another name)


def test_pixel_type_is_refused_before_the_work(tmp_path, monkeypatch):
    """The header check runs when the folder is listed, not when the frame is scored: the
    last ground-truth frame's int32 stops the run before any frame is decoded."""
    from dynaeval.io import find_frames, images

    pred, gt = _tiff_scene(tmp_path, np.float32)
    assert cv2.imwrite(str(gt / "cam0" / "0002.tif"), np.zeros((20, 24, 3), np.int32))
    decoded = []
    monkeypatch.setattr(images, "decode_file", lambda *a, **k: decoded.append(a) or 1 / 0)
    with pytest.raises(InputError, match=r"gt/cam0/0002\.tif: unsupported pixel type int32"):
        find_frames(gt, role="ground truth")
    assert decoded == []


def test_float64_tiff_is_read_as_float32_under_the_float_rule(tmp_path, capsys, rng):
    """A float64 TIFF ended in a traceback (OpenCV's colour conversion has no 64-bit float):
    read as stored, as float32 (nearest), like a float32 TIFF of the same values, so it scores
    as that file; outside [0, 1] the float rule refuses it naming the file."""
    img = rng.random((20, 24, 3))
    cv2.imwrite(str(tmp_path / "a64.tif"), img[..., ::-1])
    cv2.imwrite(str(tmp_path / "a32.tif"), img[..., ::-1].astype(np.float32))
    np.testing.assert_array_equal(read_image(tmp_path / "a64.tif"), img.astype(np.float32))
    np.testing.assert_array_equal(read_image(tmp_path / "a64.tif"), read_image(tmp_path / "a32.tif"))
    p64, g64 = _tiff_scene(tmp_path / "f64", np.float64)
    p32, g32 = _tiff_scene(tmp_path / "f32", np.float32)
    cv2.imwrite(str(p64 / "cam0" / "0001.tif"), np.full((20, 24, 3), 0.4))
    cv2.imwrite(str(p32 / "cam0" / "0001.tif"), np.full((20, 24, 3), 0.4, np.float32))
    assert _cli(p64, g64, tmp_path / "r64.json") == 0
    assert _cli(p32, g32, tmp_path / "r32.json") == 0
    import json

    r64, r32 = (json.loads((tmp_path / f"r{b}.json").read_text()) for b in (64, 32))
    assert [f["psnr"] for f in r64["frames"]] == [f["psnr"] for f in r32["frames"]]
    cv2.imwrite(str(tmp_path / "big.tif"), np.full((4, 4, 3), 2.0))
    with pytest.raises(InputError, match=r"big\.tif: float pixel values must be in \[0, 1\]"):
        read_image(tmp_path / "big.tif")


def test_complex_half_float_and_big_tiffs_are_refused_by_name(tmp_path):
    """OpenCV cannot decode complex or half-float TIFFs ("cannot decode image (corrupt ...)",
    a wrong reason): the header names the pixel type. A BigTIFF header is read too."""
    tifffile = pytest.importorskip("tifffile")
    from dynaeval.io import find_frames

    cases = {"c.tif": (np.complex64, {}, r"unsupported pixel type complex float"),
             "h.tif": (np.float16, {}, r"16-bit \(half\) float TIFF: OpenCV cannot decode it"),
             "b.tif": (np.int32, {"bigtiff": True}, r"unsupported pixel type int32")}
    for name, (dtype, kw, match) in cases.items():
        folder = tmp_path / name[0]
        folder.mkdir()
        tifffile.imwrite(folder / name, np.zeros((8, 8, 3), dtype), photometric="rgb", **kw)
        with pytest.raises(InputError, match=rf"{name}: {match}"):
            find_frames(folder)
        with pytest.raises(InputError, match=rf"{name}: {match}"):
            read_image(folder / name)


def test_bilevel_tiff_is_read_as_0_and_1(tmp_path):
    """A 1-bit (black/white) TIFF: OpenCV decodes it to uint8 0 / 255 as displayed (its
    photometric tag honoured: a "min is white" file's 0 bits are white), so it reads as 0 and 1."""
    tifffile = pytest.importorskip("tifffile")
    bits = np.zeros((8, 8), bool)
    bits[2:5] = True
    for photometric, white in (("minisblack", bits), ("miniswhite", ~bits)):
        tifffile.imwrite(tmp_path / "b.tif", bits, photometric=photometric)
        np.testing.assert_array_equal(read_image(tmp_path / "b.tif")[..., 0],
                                      white.astype(np.float32))


def test_int32_tiff_named_png_is_refused_when_decoded(tmp_path):
    """The header check is by name (``.tif``); a TIFF under another name is checked when read."""
    cv2.imwrite(str(tmp_path / "a.tif"), np.zeros((4, 4, 3), np.int32))
    (tmp_path / "a.png").write_bytes((tmp_path / "a.tif").read_bytes())
    with pytest.raises(InputError, match=r"a\.png: unsupported pixel type int32"):
        read_image(tmp_path / "a.png")


def test_exr_of_uint_channels_is_refused_by_name(tmp_path):
    """OpenEXR's UINT channels were read as floats: 0/1 ids silently as black and white, 3 as
    "float pixel values must be in [0, 1]" (a wrong reason)."""
    OpenEXR = pytest.importorskip("OpenEXR")  # noqa: N806
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    planes = {c: np.ones((4, 4), np.uint32) for c in "RGB"}
    with OpenEXR.File(hdr, planes) as f:
        f.write(str(tmp_path / "u.exr"))
    with pytest.raises(InputError, match=r"u\.exr: unsupported pixel type uint32 \(OpenEXR UINT"):
        read_image(tmp_path / "u.exr")


@pytest.mark.parametrize("dtype", ["int32", "bool", "int64"])
def test_npy_gz_pixel_type_is_refused_when_listed(tmp_path, monkeypatch, dtype):
    """A ``.npy.gz`` frame's dtype is in its header: refused when the folder is listed (it was
    refused only when the frame was read, mid-run), naming the file and the fix."""
    import gzip

    from dynaeval.io import find_frames, images

    (tmp_path / "g").mkdir()
    for i in range(2):
        with gzip.open(tmp_path / "g" / f"{i}.npy.gz", "wb") as f:
            np.save(f, np.zeros((4, 4, 3), np.float32 if i == 0 else dtype))
    monkeypatch.setattr(images, "decode_file", lambda *a, **k: 1 / 0)
    with pytest.raises(InputError, match=rf"1\.npy\.gz: unsupported pixel type {dtype}.*"
                                         "16-bit PNG"):
        find_frames(tmp_path / "g")


def test_big_endian_npy_gz_frames_are_read_in_the_machine_order(tmp_path):
    """``np.save`` keeps a big-endian array's byte order: float32 and uint16 are read as the
    native arrays of the same values (the pixel-type check compares the type, not the order)."""
    import gzip

    from dynaeval.io import find_frames

    (tmp_path / "g").mkdir()
    values = np.linspace(0, 1, 48).reshape(4, 4, 3)
    for name, arr in (("f.npy.gz", values.astype(">f4")),
                      ("u.npy.gz", (values * 65535).astype(">u2"))):
        with gzip.open(tmp_path / "g" / name, "wb") as f:
            np.save(f, arr)
    find_frames(tmp_path / "g")
    np.testing.assert_array_equal(read_image(tmp_path / "g" / "f.npy.gz"),
                                  values.astype(np.float32))
    np.testing.assert_array_equal(read_image(tmp_path / "g" / "u.npy.gz"),
                                  (values * 65535).astype(np.uint16) / np.float32(65535))

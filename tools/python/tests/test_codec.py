"""caoen.encode / decode / info / read / write on arrays, and their errors."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

import caoen
from conftest import picture


def as_dtype(a: np.ndarray, dtype) -> np.ndarray:
    if dtype == np.uint8:
        return a
    if dtype == np.uint16:
        return a.astype(np.uint16) * 257
    return a.astype(np.float32) / 255.0


def psnr(a: np.ndarray, b: np.ndarray, peak: float) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(peak * peak / mse)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_round_trip_keeps_shape_dtype_and_pixels(dtype, channels):
    a = as_dtype(picture(48, 40, channels), dtype)
    data = caoen.encode(a, quality=90)
    assert isinstance(data, bytes) and data[:4] == b"CAOE"
    b = caoen.decode(data)
    assert b.shape == a.shape and b.dtype == a.dtype
    peak = {np.uint8: 255.0, np.uint16: 65535.0, np.float32: 1.0}[dtype]
    assert psnr(a, b, peak) > 30.0


def test_encoding_is_deterministic_and_quality_matters():
    a = picture()
    assert caoen.encode(a, quality=60) == caoen.encode(a, quality=60)
    assert len(caoen.encode(a, quality=20)) < len(caoen.encode(a, quality=95))


def test_non_contiguous_arrays_are_read_in_their_logical_order():
    a = picture(64, 64)
    view = a.transpose(1, 0, 2)
    assert caoen.encode(view, quality=70) == caoen.encode(np.ascontiguousarray(view), quality=70)


def test_decode_at_any_size():
    data = caoen.encode(picture(), quality=80)
    assert caoen.decode(data, size=(48, 32)).shape == (32, 48, 3)
    assert caoen.decode(data, size=(200, 100)).shape == (100, 200, 3)
    assert caoen.decode(data, size=[20, 10]).shape == (10, 20, 3)


def test_rate_targets():
    a = picture(128, 128)
    data = caoen.encode(a, target_size=1500)
    assert abs(len(data) - 1500) < 0.1 * 1500
    data = caoen.encode(a, target_bpp=1.0)
    assert abs(len(data) * 8 / (128 * 128) - 1.0) < 0.1


def test_info_describes_without_decoding():
    a = as_dtype(picture(40, 56, 4), np.uint16)
    icc, exif, xmp = b"icc-profile", b"II*\x00\x08\x00\x00\x00\x00\x00", b"<x:xmpmeta/>"
    data = caoen.encode(a, quality=70, icc=icc, exif=exif, xmp=xmp)
    i = caoen.info(data)
    assert (i["width"], i["height"], i["channels"], i["alpha"]) == (56, 40, 4, True)
    assert i["dtype"] == "uint16" and i["bytes"] == len(data)
    assert i["bpp"] == pytest.approx(len(data) * 8 / (56 * 40))
    assert (i["icc"], i["exif"], i["xmp"]) == (icc, exif, xmp)
    assert i["version"] == caoen.FORMAT_VERSION


def test_read_and_write_files(tmp_path: Path):
    a = picture()
    n = caoen.write(tmp_path / "a.cae", a, quality=70)
    assert n == (tmp_path / "a.cae").stat().st_size
    assert (tmp_path / "a.cae").read_bytes() == caoen.encode(a, quality=70)
    assert np.array_equal(caoen.read(tmp_path / "a.cae"), caoen.decode(caoen.encode(a, quality=70)))
    assert [p.name for p in tmp_path.iterdir()] == ["a.cae"]


def test_read_loads_image_files(png: Path):
    from PIL import Image

    assert np.array_equal(caoen.read(png), np.asarray(Image.open(png)))


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: caoen.decode(b"not a caoen file"), "not a caoen file"),
        (lambda: caoen.decode(caoen.encode(picture())[:-9]), "invalid caoen file"),
        (lambda: caoen.info(b""), "caoen"),
        (lambda: caoen.encode(picture(), quality=150), "quality"),
        (lambda: caoen.encode(picture(), effort=0), "effort"),
        (lambda: caoen.encode(picture(), target_size=100, target_bpp=1.0), "not both"),
        (lambda: caoen.encode(picture().astype(np.float64)), "uint8, uint16 or float32"),
        (lambda: caoen.encode(np.zeros((4, 4, 5), np.uint8)), "HxW"),
        (lambda: caoen.encode(np.zeros((0, 4), np.uint8)), "1..="),
        (lambda: caoen.encode(np.full((8, 8), np.nan, np.float32)), "finite"),
        (lambda: caoen.encode([[1, 2], [3, 4]]), "NumPy array"),
        (lambda: caoen.decode(caoen.encode(picture()), size=(0, 10)), "size"),
        (lambda: caoen.decode(caoen.encode(picture()), size="big"), "width, height"),
    ],
)
def test_errors_raise_caoen_error_with_caoens_message(call, message):
    with pytest.raises(caoen.CaoenError, match=message) as e:
        call()
    assert isinstance(e.value, ValueError)


def test_a_damaged_image_file_is_a_caoen_error(tmp_path: Path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png at all")
    with pytest.raises(caoen.CaoenError, match="bad.png"):
        caoen.read(bad)
    with pytest.raises(OSError):
        caoen.read(tmp_path / "missing.cae")


def test_every_byte_damage_is_an_error_not_a_crash():
    data = bytearray(caoen.encode(picture(32, 32), quality=50))
    for i in range(0, len(data), max(1, len(data) // 64)):
        bad = bytearray(data)
        bad[i] ^= 0x5A
        try:
            caoen.decode(bytes(bad))
        except caoen.CaoenError:
            pass


def test_threads_code_at_once_with_the_gil_released():
    a = picture(96, 96)
    want = caoen.encode(a, quality=70)
    got = []
    threads = [threading.Thread(target=lambda: got.append(caoen.encode(a, quality=70))) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert got == [want] * 4


def test_file_names_follow_the_command_line():
    for name in ["a/b.PNG", "x.exr", "y.jpeg", "z.webp", "t.tif"]:
        assert caoen.is_image_name(name), name
    for name in ["notes.txt", "z.cae", "noext"]:
        assert not caoen.is_image_name(name), name
    assert caoen.output_name("sub/b.jpg") == Path("sub/b.cae")


def test_load_gives_pixels_and_metadata(tmp_path: Path):
    from PIL import Image, ImageCms

    srgb = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    path = tmp_path / "m.png"
    Image.fromarray(picture()).save(path, icc_profile=srgb)
    pixels, meta = caoen.load(path)
    assert pixels.dtype == np.uint8 and pixels.shape == (64, 96, 3)
    assert meta == {"icc": srgb, "exif": None, "xmp": None}

"""The Pillow plugin: Image.open and Image.save of .cae files, with ICC and EXIF."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageCms

import caoen
import caoen.pillow  # noqa: F401 - registers the plugin
from conftest import picture

ICC = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


def exif_bytes() -> bytes:
    exif = Image.Exif()
    exif[0x010F] = "caoen camera"  # Make
    exif[0x0112] = 1  # Orientation
    return exif.tobytes()


def test_open_reads_size_mode_pixels_and_metadata(tmp_path: Path):
    a = picture()
    path = tmp_path / "x.cae"
    tiff = exif_bytes()[6:]
    caoen.write(path, a, quality=80, icc=ICC, exif=tiff)
    with Image.open(path) as img:
        assert (img.format, img.size, img.mode) == ("CAE", (96, 64), "RGB")
        assert img.info["icc_profile"] == ICC
        assert img.getexif()[0x010F] == "caoen camera"
        assert np.array_equal(np.asarray(img), caoen.read(path))
    assert Image.MIME["CAE"] == "image/x-caoen"
    assert Image.EXTENSION[".cae"] == "CAE"


def test_save_writes_the_same_bytes_as_encode_with_metadata(tmp_path: Path):
    img = Image.fromarray(picture(channels=4))
    path = tmp_path / "y.cae"
    img.save(path, quality=60, icc_profile=ICC, exif=exif_bytes())
    info = caoen.info(path.read_bytes())
    assert (info["icc"], info["exif"]) == (ICC, exif_bytes()[6:])
    assert path.read_bytes() == caoen.encode(np.asarray(img), quality=60, icc=ICC, exif=exif_bytes()[6:])


def test_a_photo_round_trips_through_pillow_with_its_icc_profile(tmp_path: Path):
    src = tmp_path / "photo.png"
    Image.fromarray(picture(80, 120)).save(src, icc_profile=ICC, exif=exif_bytes())
    with Image.open(src) as img:
        img.save(tmp_path / "photo.cae", quality=60)
    with Image.open(tmp_path / "photo.cae") as back:
        assert back.info["icc_profile"] == ICC
        assert back.getexif()[0x010F] == "caoen camera"
        back.save(tmp_path / "again.png")
    with Image.open(tmp_path / "again.png") as png:
        assert png.info["icc_profile"] == ICC
        assert png.size == (120, 80)


@pytest.mark.parametrize("dtype, mode", [(np.uint16, "I;16"), (np.float32, "F")])
def test_deep_grey_opens_in_pillows_deep_modes(tmp_path: Path, dtype, mode):
    a = picture(32, 32, 1).astype(dtype)
    path = tmp_path / "g.cae"
    caoen.write(path, a if dtype == np.uint16 else a / 255, quality=90)
    with Image.open(path) as img:
        assert img.mode == mode
        assert np.array_equal(np.asarray(img), caoen.read(path))


def test_deep_colour_opens_as_8_bit(tmp_path: Path):
    path = tmp_path / "c.cae"
    caoen.write(path, picture().astype(np.uint16) * 257, quality=90)
    with Image.open(path) as img:
        assert img.mode == "RGB"
        want = (caoen.read(path).astype(np.uint32) * 255 + 32767) // 65535
        assert np.array_equal(np.asarray(img), want.astype(np.uint8))


def test_a_damaged_file_raises_caoen_error(tmp_path: Path):
    data = bytearray(caoen.encode(picture(), quality=50))
    data[len(data) // 2] ^= 0xFF
    path = tmp_path / "bad.cae"
    path.write_bytes(bytes(data))
    with pytest.raises(caoen.CaoenError):
        with Image.open(path) as img:
            img.load()

"""The same bytes and pixels as the `caoen` command line for the same input and options."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import caoen
from conftest import picture, run


@pytest.mark.parametrize("quality", [40, 80])
def test_encode_gives_the_clis_bytes(cli, png: Path, tmp_path: Path, quality):
    out = tmp_path / "cli.cae"
    run(cli, ["encode", str(png), "-q", str(quality), "-o", str(out)])
    from PIL import Image

    array = np.asarray(Image.open(png))
    assert caoen.encode(array, quality=quality) == out.read_bytes()
    assert caoen.encode_file(png, quality=quality) == out.read_bytes()


def test_options_give_the_clis_bytes(cli, png: Path, tmp_path: Path):
    out = tmp_path / "cli.cae"
    run(cli, ["encode", str(png), "-e", "3", "--target-size", "900", "-o", str(out)])
    assert caoen.encode(caoen.read(png), effort=3, target_size=900) == out.read_bytes()
    run(cli, ["-f", "encode", str(png), "--target-bpp", "0.8", "-o", str(out)])
    assert caoen.encode(caoen.read(png), target_bpp=0.8) == out.read_bytes()


def test_decode_gives_the_clis_pixels(cli, png: Path, tmp_path: Path):
    cae = tmp_path / "a.cae"
    caoen.encode_file(png, cae, quality=60)
    run(cli, ["decode", str(cae), "-o", str(tmp_path / "a.png")])
    assert np.array_equal(caoen.read(cae), caoen.read(tmp_path / "a.png"))
    run(cli, ["decode", str(cae), "--size", "50x30", "-o", str(tmp_path / "s.png")])
    assert np.array_equal(caoen.decode(cae.read_bytes(), size=(50, 30)), caoen.read(tmp_path / "s.png"))


@pytest.mark.parametrize("dtype, ext", [(np.uint16, "png"), (np.float32, "exr")])
def test_sixteen_bit_and_float_files_match_the_cli(cli, tmp_path: Path, dtype, ext):
    a = picture(40, 64).astype(np.float32) / 255.0
    a = (a * 65535.0).astype(np.uint16) if dtype == np.uint16 else a * 4.0
    cae = tmp_path / "a.cae"
    caoen.write(cae, a, quality=80)
    # The CLI writes the file's pixels as an image file, which the CLI encodes again:
    # the array the package reads from that file gives the same bytes.
    image = tmp_path / f"a.{ext}"
    run(cli, ["decode", str(cae), "-o", str(image)])
    pixels = caoen.read(image)
    assert pixels.dtype == dtype
    assert np.array_equal(pixels, caoen.read(cae))
    again = tmp_path / "again.cae"
    run(cli, ["encode", str(image), "-q", "80", "-o", str(again)])
    assert caoen.encode(pixels, quality=80) == again.read_bytes()
    part = tmp_path / f"part.{ext}"
    run(cli, ["decode", str(cae), "--region", "8,4,40.5,36", "-o", str(part)])
    region = caoen.decode(cae.read_bytes(), region=(8, 4, 40.5, 36))
    assert region.dtype == dtype and np.array_equal(region, caoen.read(part))


def test_region_gives_the_clis_pixels_and_a_crop_of_the_whole(cli, png: Path, tmp_path: Path):
    cae = tmp_path / "a.cae"
    caoen.encode_file(png, cae, quality=70)
    data = cae.read_bytes()
    part = caoen.decode(data, region=(16, 8, 48, 40))
    assert part.shape == (32, 32, 3)
    assert np.array_equal(part, caoen.decode(data)[8:40, 16:48])
    out = tmp_path / "r.png"
    run(cli, ["decode", str(cae), "--region", "16,8,48,40", "-o", str(out)])
    assert np.array_equal(part, caoen.read(out))
    zoom = caoen.decode(data, region=(10.5, 4.25, 30.5, 20.25), size=(80, 64))
    out = tmp_path / "z.png"
    run(cli, ["decode", str(cae), "--region", "10.5,4.25,30.5,20.25", "--size", "80x64", "-o", str(out)])
    assert zoom.shape == (64, 80, 3) and np.array_equal(zoom, caoen.read(out))
    with pytest.raises(caoen.CaoenError, match="invalid region"):
        caoen.decode(data, region=(0, 0, 500, 10))
    with pytest.raises(caoen.CaoenError, match="x0, y0, x1, y1"):
        caoen.decode(data, region=(1, 2))


def test_the_benchmark_photos(cli, tmp_path: Path):
    """The acceptance check on real photographs, when CAOEN_PHOTOS names their folder."""
    folder = os.environ.get("CAOEN_PHOTOS")
    if not folder:
        pytest.skip("CAOEN_PHOTOS is not set (a folder of photos, e.g. ../shared/photos)")
    photos = sorted(p for p in Path(folder).iterdir() if caoen.is_image_name(p))
    assert photos
    for photo in photos:
        for q in (40, 80):
            out = tmp_path / f"{photo.stem}-{q}.cae"
            run(cli, ["encode", str(photo), "-q", str(q), "-o", str(out)])
            pixels, meta = caoen.load(photo)
            assert caoen.encode(pixels, quality=q, **meta) == out.read_bytes(), photo
            png = tmp_path / f"{photo.stem}-{q}.png"
            run(cli, ["decode", str(out), "-o", str(png)])
            assert np.array_equal(caoen.read(out), caoen.read(png)), photo
            run(cli, ["-f", "decode", str(out), "--region", "100,50,356.5,306", "-o", str(png)])
            region = caoen.decode(out.read_bytes(), region=(100, 50, 356.5, 306))
            assert np.array_equal(region, caoen.read(png)), photo

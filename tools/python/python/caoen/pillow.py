"""A Pillow plugin for .cae files: ``import caoen.pillow``, then ``Image.open("x.cae")``
reads and ``img.save("x.cae", quality=60)`` writes.

The ICC profile (``img.info["icc_profile"]``), EXIF (``img.info["exif"]``) and XMP
(``img.info["xmp"]``) go both ways. Pillow has no modes for 16-bit colour or float
colour, so such files open as 8-bit ``RGB``/``RGBA`` (16-bit and float grey open as
``I;16`` and ``F``); :func:`caoen.decode` gives every file at its own depth.
"""

from __future__ import annotations

from typing import IO, Any, Optional

import numpy as np
from PIL import Image, ImageFile

import caoen

#: The format name Pillow reports for .cae files (``img.format``).
FORMAT = "CAE"
#: The MIME type registered for .cae files.
MIME = "image/x-caoen"

_EXIF_PREFIX = b"Exif\x00\x00"


def _accept(prefix: bytes) -> bool:
    return prefix[:4] == caoen.MAGIC


def _to_8bit(a: np.ndarray) -> np.ndarray:
    if a.dtype == np.uint16:
        return ((a.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    return (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _mode_of(channels: int, dtype: str) -> str:
    if channels == 1 and dtype == "uint16":
        return "I;16"
    if channels == 1 and dtype == "float32":
        return "F"
    return {1: "L", 2: "LA", 3: "RGB", 4: "RGBA"}[channels]


class CaoenImageFile(ImageFile.ImageFile):
    """A .cae file opened by Pillow: decoded at its own size when its pixels are first used."""

    format = FORMAT
    format_description = "caoen image"

    def _open(self) -> None:
        data = self.fp.read()
        about = caoen.info(data)
        self._caoen_data: Optional[bytes] = data
        self._size = (about["width"], about["height"])
        self._mode = _mode_of(about["channels"], about["dtype"])
        if about["icc"] is not None:
            self.info["icc_profile"] = about["icc"]
        if about["exif"] is not None:
            # Pillow's own readers keep EXIF with the JPEG APP1 prefix.
            self.info["exif"] = _EXIF_PREFIX + about["exif"]
        if about["xmp"] is not None:
            self.info["xmp"] = about["xmp"]
        self.tile = []

    def load(self) -> Any:
        data = getattr(self, "_caoen_data", None)
        if data is not None:
            a = caoen.decode(data)
            if self.mode in ("L", "LA", "RGB", "RGBA") and a.dtype != np.uint8:
                a = _to_8bit(a)
            img = Image.fromarray(np.ascontiguousarray(a))
            if img.mode != self.mode:
                img = img.convert(self.mode)
            self.im = img.im
            self._caoen_data = None
        return super().load()


def _array_of(im: Image.Image) -> np.ndarray:
    if im.mode in ("L", "LA", "RGB", "RGBA", "I;16", "F"):
        return np.asarray(im)
    if im.mode == "I":
        return np.clip(np.asarray(im), 0, 65535).astype(np.uint16)
    rgba = "transparency" in im.info or im.mode in ("PA", "RGBa", "La")
    return np.asarray(im.convert("RGBA" if rgba else "RGB"))


def _metadata_bytes(item: Any) -> Optional[bytes]:
    if item is None:
        return None
    if isinstance(item, Image.Exif):
        item = item.tobytes()
    if isinstance(item, str):
        item = item.encode("utf-8")
    return bytes(item)


def _save(im: Image.Image, fp: IO[bytes], filename: Any) -> None:
    opts = im.encoderinfo
    exif = _metadata_bytes(opts.get("exif", im.info.get("exif")))
    if exif is not None and exif.startswith(_EXIF_PREFIX):
        exif = exif[len(_EXIF_PREFIX):]
    data = caoen.encode(
        _array_of(im),
        quality=opts.get("quality", 75),
        effort=opts.get("effort"),
        target_size=opts.get("target_size"),
        target_bpp=opts.get("target_bpp"),
        icc=_metadata_bytes(opts.get("icc_profile", im.info.get("icc_profile"))),
        exif=exif or None,
        xmp=_metadata_bytes(opts.get("xmp", im.info.get("xmp"))),
    )
    fp.write(data)


Image.register_open(FORMAT, CaoenImageFile, _accept)
Image.register_save(FORMAT, _save)
Image.register_extension(FORMAT, ".cae")
Image.register_mime(FORMAT, MIME)

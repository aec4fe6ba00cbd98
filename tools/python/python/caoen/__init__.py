"""caoen from Python: NumPy images to ``.cae`` bytes and back.

The codec is caoen's own Rust library, called as the ``caoen`` command line calls
it, so the same pixels and options give the same bytes as ``caoen encode``. The GIL
is released while an image is coded, so threads encode in parallel. Every failure
raises :class:`CaoenError` (a :class:`ValueError`) with caoen's message.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any, Optional, Tuple, Union

from . import _caoen
from ._caoen import FORMAT_VERSION, CaoenError

__all__ = [
    "CaoenError",
    "FORMAT_VERSION",
    "decode",
    "encode",
    "encode_file",
    "info",
    "is_image_name",
    "load",
    "read",
    "write",
    "output_name",
]

__version__ = "0.1.0"

MAGIC = b"CAOE"

PathLike = Union[str, "os.PathLike[str]"]


def _bytes(data: Any) -> bytes:
    # The native side borrows `bytes`; bytearray and memoryview are copied once here.
    if isinstance(data, bytes):
        return data
    if isinstance(data, (bytearray, memoryview)):
        return bytes(data)
    raise CaoenError(f"expected bytes of a .cae file, got {type(data).__name__}")


def _opt_bytes(item: Any, name: str) -> Optional[bytes]:
    if item is None:
        return None
    if isinstance(item, (bytes, bytearray, memoryview)):
        return bytes(item)
    raise CaoenError(f"{name} must be bytes, got {type(item).__name__}")


def _size(size: Any) -> Optional[Tuple[int, int]]:
    if size is None:
        return None
    try:
        w, h = size
        return int(w), int(h)
    except (TypeError, ValueError):
        raise CaoenError(f"size must be (width, height), got {size!r}") from None


def encode(
    array: Any,
    quality: float = 75,
    effort: Optional[int] = None,
    target_size: Optional[int] = None,
    target_bpp: Optional[float] = None,
    icc: Optional[bytes] = None,
    exif: Optional[bytes] = None,
    xmp: Optional[bytes] = None,
) -> bytes:
    """Encode a NumPy image (HxW, HxWx3, HxWx4; uint8, uint16 or float32) as .cae bytes."""
    return _caoen.encode(
        array,
        quality=float(quality),
        effort=effort,
        target_size=target_size,
        target_bpp=None if target_bpp is None else float(target_bpp),
        icc=_opt_bytes(icc, "icc"),
        exif=_opt_bytes(exif, "exif"),
        xmp=_opt_bytes(xmp, "xmp"),
    )


def _region(region: Any) -> Optional[Tuple[float, float, float, float]]:
    if region is None:
        return None
    try:
        x0, y0, x1, y1 = region
        return float(x0), float(y0), float(x1), float(y1)
    except (TypeError, ValueError):
        raise CaoenError(f"region must be (x0, y0, x1, y1), got {region!r}") from None


def decode(
    data: Any,
    size: Optional[Tuple[int, int]] = None,
    region: Optional[Tuple[float, float, float, float]] = None,
) -> Any:
    """Decode .cae bytes to a NumPy array of the file's sample type.

    ``size`` is ``(width, height)``; the network is continuous, so any size works.
    ``region`` is ``(x0, y0, x1, y1)`` in the image's own pixels (fractions allowed):
    that rectangle alone, at its own size or at ``size``.
    """
    return _caoen.decode(_bytes(data), size=_size(size), region=_region(region))


def info(data: Any) -> dict:
    """Describe .cae bytes without decoding them (size, dtype, key points, metadata)."""
    return _caoen.info(_bytes(data))


def load(path: PathLike) -> Tuple[Any, dict]:
    """Read an image file (PNG, JPEG, EXR, ...) as ``caoen encode`` reads it, with its metadata."""
    return _caoen.load(os.fspath(path))


def read(path: PathLike) -> Any:
    """The pixels of a .cae file, or of any image file caoen reads, as a NumPy array."""
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head == MAGIC:
            return decode(head + f.read())
    return load(path)[0]


def _write_whole(path: PathLike, data: bytes) -> None:
    # A temporary file beside the output, renamed over it once complete: a reader
    # never sees half a file, and a failed write leaves no debris.
    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".caoen-tmp", dir=target.parent or ".")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def write(path: PathLike, array: Any, **options: Any) -> int:
    """Encode ``array`` (options as :func:`encode`) into the file ``path``; returns its bytes."""
    data = encode(array, **options)
    _write_whole(path, data)
    return len(data)


def encode_file(
    src: PathLike,
    dst: Optional[PathLike] = None,
    quality: float = 75,
    effort: Optional[int] = None,
    target_size: Optional[int] = None,
    target_bpp: Optional[float] = None,
    metadata: str = "all",
) -> bytes:
    """Encode an image file exactly as ``caoen encode SRC -o DST`` does; writes ``dst`` if given.

    ``metadata`` is ``"all"``, ``"icc"`` or ``"none"`` (``--metadata``).
    """
    data = _caoen.encode_file(
        os.fspath(src),
        quality=float(quality),
        effort=effort,
        target_size=target_size,
        target_bpp=None if target_bpp is None else float(target_bpp),
        metadata=metadata,
    )
    if dst is not None:
        _write_whole(dst, data)
    return data


def is_image_name(path: PathLike) -> bool:
    """Whether ``caoen encode DIR`` takes a file by its name (PNG, JPEG, EXR, ...)."""
    return _caoen.is_image_name(os.fspath(path))


def output_name(rel: PathLike) -> Path:
    """The path below the output folder that ``caoen encode DIR -o OUT`` gives an input at ``rel``."""
    return Path(rel).with_suffix(".cae")

"""Type stubs of the caoen package (see docs/python.md)."""

import os
from pathlib import Path
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
FORMAT_VERSION: int
MAGIC: bytes

PathLike = Union[str, os.PathLike[str]]
BytesLike = Union[bytes, bytearray, memoryview]

class CaoenError(ValueError):
    """An image or file caoen cannot code, or options it refuses; the message is caoen's."""

def encode(
    array: npt.NDArray[Any],
    quality: float = 75,
    effort: Optional[int] = None,
    target_size: Optional[int] = None,
    target_bpp: Optional[float] = None,
    icc: Optional[bytes] = None,
    exif: Optional[bytes] = None,
    xmp: Optional[bytes] = None,
) -> bytes:
    """Encode a NumPy image (HxW, HxWx3, HxWx4; uint8, uint16 or float32) as .cae bytes."""

def decode(
    data: BytesLike,
    size: Optional[Tuple[int, int]] = None,
    region: Optional[Tuple[float, float, float, float]] = None,
) -> npt.NDArray[Any]:
    """Decode .cae bytes to a NumPy array of the file's sample type; size is (width, height),
    region (x0, y0, x1, y1) in the image's own pixels."""

def info(data: BytesLike) -> Dict[str, Any]:
    """Describe .cae bytes without decoding them (size, dtype, key points, metadata)."""

def load(path: PathLike) -> Tuple[npt.NDArray[Any], Dict[str, Optional[bytes]]]:
    """Read an image file (PNG, JPEG, EXR, ...) as ``caoen encode`` reads it, with its metadata."""

def read(path: PathLike) -> npt.NDArray[Any]:
    """The pixels of a .cae file, or of any image file caoen reads, as a NumPy array."""

def write(
    path: PathLike,
    array: npt.NDArray[Any],
    *,
    quality: float = 75,
    effort: Optional[int] = None,
    target_size: Optional[int] = None,
    target_bpp: Optional[float] = None,
    icc: Optional[bytes] = None,
    exif: Optional[bytes] = None,
    xmp: Optional[bytes] = None,
) -> int:
    """Encode ``array`` into the file ``path`` (written whole); returns its bytes."""

def encode_file(
    src: PathLike,
    dst: Optional[PathLike] = None,
    quality: float = 75,
    effort: Optional[int] = None,
    target_size: Optional[int] = None,
    target_bpp: Optional[float] = None,
    metadata: str = "all",
) -> bytes:
    """Encode an image file exactly as ``caoen encode SRC -o DST`` does; writes ``dst`` if given."""

def is_image_name(path: PathLike) -> bool:
    """Whether ``caoen encode DIR`` takes a file by its name (PNG, JPEG, EXR, ...)."""

def output_name(rel: PathLike) -> Path:
    """The path below the output folder that ``caoen encode DIR -o OUT`` gives an input at ``rel``."""

"""Type stubs of the Pillow plugin (``import caoen.pillow`` registers it)."""

from PIL import ImageFile

FORMAT: str
MIME: str

class CaoenImageFile(ImageFile.ImageFile):
    """A .cae file opened by Pillow: decoded at its own size when its pixels are first used."""

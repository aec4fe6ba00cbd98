//! Image metadata carried through the codec beside the pixels: the ICC colour profile,
//! EXIF and XMP, stored verbatim in their own container sections (`docs/format.md`).

/// Largest metadata item (one ICC profile, EXIF block or XMP packet) read or stored.
pub const MAX_ITEM_BYTES: usize = 16 << 20;

/// The metadata of one image, each item as the bytes its own standard defines.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Metadata {
    /// ICC colour profile.
    pub icc: Option<Vec<u8>>,
    /// EXIF, as the TIFF structure (starting with `II*\0` or `MM\0*`).
    pub exif: Option<Vec<u8>>,
    /// XMP packet (UTF-8 XML).
    pub xmp: Option<Vec<u8>>,
}

impl Metadata {
    /// Whether no item is present.
    pub fn is_empty(&self) -> bool {
        self.icc.is_none() && self.exif.is_none() && self.xmp.is_none()
    }
}

//! The bounded EXIF walker: the TIFF structure read with every offset checked against
//! the block, directory chains stopped when they loop; the orientation read and reset
//! in place.

use super::{MetadataError, MAX_IFDS, ORIENTATION_TAG, TYPE_SHORT};

/// A TIFF structure with its byte order; every read is bounds-checked.
struct Tiff<'a> {
    data: &'a [u8],
    little: bool,
}

impl<'a> Tiff<'a> {
    fn new(data: &'a [u8]) -> Result<Self, MetadataError> {
        let little = match data.get(..4) {
            Some(b"II*\0") => true,
            Some(b"MM\0*") => false,
            _ => {
                return Err(MetadataError::NotTiff {
                    start: data[..data.len().min(4)].to_vec(),
                })
            }
        };
        Ok(Tiff { data, little })
    }

    fn bytes<const N: usize>(&self, what: &'static str, at: u64) -> Result<[u8; N], MetadataError> {
        let out = usize::try_from(at)
            .ok()
            .and_then(|a| self.data.get(a..a.checked_add(N)?))
            .ok_or(MetadataError::OutOfBounds {
                what,
                offset: at,
                need: N as u64,
                len: self.data.len(),
            })?;
        let mut b = [0; N];
        b.copy_from_slice(out);
        Ok(b)
    }

    fn u16(&self, what: &'static str, at: u64) -> Result<u16, MetadataError> {
        let b = self.bytes::<2>(what, at)?;
        Ok(if self.little {
            u16::from_le_bytes(b)
        } else {
            u16::from_be_bytes(b)
        })
    }

    fn u32(&self, what: &'static str, at: u64) -> Result<u32, MetadataError> {
        let b = self.bytes::<4>(what, at)?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn first_ifd(&self) -> Result<u64, MetadataError> {
        self.u32("header", 4).map(u64::from)
    }

    /// The number of entries of the directory at `ifd`, once all of them are known to
    /// lie inside the block.
    fn entry_count(&self, ifd: u64) -> Result<u64, MetadataError> {
        let n = u64::from(self.u16("directory", ifd)?);
        let need = 2 + 12 * n;
        if ifd.saturating_add(need) > self.data.len() as u64 {
            return Err(MetadataError::OutOfBounds {
                what: "directory",
                offset: ifd,
                need,
                len: self.data.len(),
            });
        }
        Ok(n)
    }

    /// The offset of the next directory (0: none). A block that ends right after a
    /// directory's entries, without the link, is read as the end of the chain.
    fn next_ifd(&self, ifd: u64, count: u64) -> u64 {
        self.u32("link", ifd + 2 + 12 * count).map_or(0, u64::from)
    }

    /// Where the orientation's value sits in IFD0, and the value, when the tag is
    /// there as one SHORT.
    fn orientation_slot(&self) -> Result<Option<(u64, u16)>, MetadataError> {
        let ifd = self.first_ifd()?;
        let count = self.entry_count(ifd)?;
        for i in 0..count {
            let entry = ifd + 2 + 12 * i;
            if self.u16("entry", entry)? != ORIENTATION_TAG {
                continue;
            }
            let kind = self.u16("entry", entry + 2)?;
            let n = self.u32("entry", entry + 4)?;
            if kind != TYPE_SHORT || n != 1 {
                return Ok(None);
            }
            return Ok(Some((entry + 8, self.u16("entry", entry + 8)?)));
        }
        Ok(None)
    }
}

/// The offsets of the TIFF directories in an EXIF block's chain (IFD0, IFD1, ...), each
/// checked to lie inside the block; a loop or a chain over [`MAX_IFDS`] is an error.
pub fn ifd_chain(exif: &[u8]) -> Result<Vec<u64>, MetadataError> {
    let tiff = Tiff::new(exif)?;
    let mut seen = Vec::new();
    let mut ifd = tiff.first_ifd()?;
    while ifd != 0 {
        if seen.contains(&ifd) {
            return Err(MetadataError::IfdLoop { offset: ifd });
        }
        if seen.len() == MAX_IFDS {
            return Err(MetadataError::TooManyIfds { max: MAX_IFDS });
        }
        let count = tiff.entry_count(ifd)?;
        seen.push(ifd);
        ifd = tiff.next_ifd(ifd, count);
    }
    Ok(seen)
}

/// The EXIF orientation (1 to 8) from IFD0 of a TIFF-structured EXIF block: `None`
/// when the tag is absent, not a single SHORT, or out of range. Only IFD0 is read, so
/// a damaged chain after it does not matter here.
pub fn orientation(exif: &[u8]) -> Result<Option<u16>, MetadataError> {
    let slot = Tiff::new(exif)?.orientation_slot()?;
    Ok(slot.map(|(_, v)| v).filter(|v| (1..=8).contains(v)))
}

/// Sets the EXIF orientation in place to 1 (upright as stored), returning the value it
/// had; an EXIF without the tag is left as it is.
pub fn reset_orientation(exif: &mut [u8]) -> Result<Option<u16>, MetadataError> {
    let tiff = Tiff::new(exif)?;
    let little = tiff.little;
    let Some((at, old)) = tiff.orientation_slot()? else {
        return Ok(None);
    };
    // `orientation_slot` read two bytes there, so the range is inside the block.
    let at = at as usize;
    let one = if little {
        1u16.to_le_bytes()
    } else {
        1u16.to_be_bytes()
    };
    exif[at..at + 2].copy_from_slice(&one);
    Ok(Some(old))
}

/// A copy of an EXIF block saying orientation 1; unreadable blocks are copied as they
/// are (nothing can be rewritten in them).
pub fn with_orientation_one(exif: &[u8]) -> Vec<u8> {
    let mut out = exif.to_vec();
    let _ = reset_orientation(&mut out);
    out
}

//! Image metadata carried through the codec beside the pixels: the ICC colour profile,
//! EXIF and XMP, stored verbatim in their own container sections (`docs/format.md`).
//!
//! EXIF is read only as far as its orientation: a bounded walker over the TIFF
//! structure that never follows an offset outside the block, never allocates by a
//! declared count, and stops a directory chain that loops.

use thiserror::Error;

/// Largest metadata item (one ICC profile, EXIF block or XMP packet) read or stored.
pub const MAX_ITEM_BYTES: usize = 16 << 20;

/// Longest chain of TIFF directories (IFD0, IFD1, ...) followed; cameras write two.
pub const MAX_IFDS: usize = 64;

/// The TIFF tag of the EXIF orientation.
pub const ORIENTATION_TAG: u16 = 0x0112;

/// The TIFF field type SHORT (an unsigned 16-bit value), the orientation's type.
const TYPE_SHORT: u16 = 3;

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

    /// The items a policy keeps.
    pub fn filtered(&self, policy: MetadataPolicy) -> Metadata {
        match policy {
            MetadataPolicy::None => Metadata::default(),
            MetadataPolicy::Icc => Metadata {
                icc: self.icc.clone(),
                ..Metadata::default()
            },
            MetadataPolicy::All => self.clone(),
        }
    }

    /// Rejects an item over [`MAX_ITEM_BYTES`].
    pub fn check_sizes(&self) -> Result<(), MetadataError> {
        for (item, bytes) in [
            (Item::Icc, &self.icc),
            (Item::Exif, &self.exif),
            (Item::Xmp, &self.xmp),
        ] {
            if let Some(b) = bytes {
                check_size(item, b.len() as u64)?;
            }
        }
        Ok(())
    }

    /// The EXIF orientation (1 to 8), if the EXIF has a valid one.
    pub fn orientation(&self) -> Result<Option<u16>, MetadataError> {
        self.exif.as_deref().map_or(Ok(None), orientation)
    }
}

/// Which metadata items are kept (`--metadata none|icc|all`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum MetadataPolicy {
    /// None: the pixels alone.
    None,
    /// The colour profile alone, which the pixels need to mean the right colours.
    Icc,
    /// ICC, EXIF and XMP.
    #[default]
    All,
}

impl MetadataPolicy {
    /// Parses `none`, `icc` or `all`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "none" => Some(MetadataPolicy::None),
            "icc" => Some(MetadataPolicy::Icc),
            "all" => Some(MetadataPolicy::All),
            _ => None,
        }
    }
}

/// One kind of metadata item, for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Item {
    /// The ICC profile.
    Icc,
    /// The EXIF block.
    Exif,
    /// The XMP packet.
    Xmp,
}

impl std::fmt::Display for Item {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Item::Icc => "ICC profile",
            Item::Exif => "EXIF",
            Item::Xmp => "XMP packet",
        })
    }
}

/// Why a metadata item could not be read.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MetadataError {
    /// The item (as declared, or as read) is over [`MAX_ITEM_BYTES`].
    #[error("{item} of {bytes} bytes is over the limit of {max} bytes")]
    TooLarge {
        /// Which item.
        item: Item,
        /// Its declared or actual size.
        bytes: u64,
        /// The limit.
        max: usize,
    },
    /// A compressed item inflates past [`MAX_ITEM_BYTES`].
    #[error("{item} inflates past the limit of {max} bytes")]
    InflatesTooLarge {
        /// Which item.
        item: Item,
        /// The limit.
        max: usize,
    },
    /// The EXIF block does not start with a TIFF header.
    #[error("EXIF does not start with a TIFF header (II*\\0 or MM\\0*) but with {start:02x?}")]
    NotTiff {
        /// Its first bytes (up to 4).
        start: Vec<u8>,
    },
    /// An EXIF offset or directory reaches past the end of the block.
    #[error("EXIF {what} at offset {offset} needs {need} bytes, the block has {len}")]
    OutOfBounds {
        /// What was being read.
        what: &'static str,
        /// Where it starts.
        offset: u64,
        /// Bytes it needs from there.
        need: u64,
        /// The block's length.
        len: usize,
    },
    /// The EXIF directory chain comes back to a directory already read.
    #[error("EXIF directory chain loops back to offset {offset}")]
    IfdLoop {
        /// The directory met twice.
        offset: u64,
    },
    /// The EXIF directory chain is longer than [`MAX_IFDS`].
    #[error("EXIF directory chain is longer than {max} directories")]
    TooManyIfds {
        /// The limit.
        max: usize,
    },
    /// The file's container around the item is damaged.
    #[error("{item}: {reason}")]
    Corrupt {
        /// Which item, or the container.
        item: &'static str,
        /// What is wrong, with the offending values.
        reason: String,
    },
}

/// Rejects an item size over [`MAX_ITEM_BYTES`].
pub fn check_size(item: Item, bytes: u64) -> Result<(), MetadataError> {
    if bytes > MAX_ITEM_BYTES as u64 {
        return Err(MetadataError::TooLarge {
            item,
            bytes,
            max: MAX_ITEM_BYTES,
        });
    }
    Ok(())
}

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

fn corrupt(item: &'static str, reason: String) -> MetadataError {
    MetadataError::Corrupt { item, reason }
}

/// EXIF blocks some writers start with the JPEG APP1 prefix even outside JPEG.
fn strip_exif_prefix(b: &[u8]) -> &[u8] {
    b.strip_prefix(b"Exif\0\0").unwrap_or(b)
}

/// The metadata of an image file, from its bytes: JPEG (APP2 ICC chunks, APP1 EXIF and
/// XMP), PNG (iCCP, eXIf, iTXt XMP) and WebP (ICCP, EXIF, XMP chunks); other formats
/// give none. Every declared size is checked against the file and against
/// [`MAX_ITEM_BYTES`] before the item is copied.
pub fn read_container(bytes: &[u8]) -> Result<Metadata, MetadataError> {
    if bytes.starts_with(&[0xff, 0xd8]) {
        read_jpeg(bytes)
    } else if bytes.starts_with(PNG_SIGNATURE) {
        read_png(bytes)
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        read_webp(bytes)
    } else {
        Ok(Metadata::default())
    }
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

fn read_jpeg(b: &[u8]) -> Result<Metadata, MetadataError> {
    const EXIF: &[u8] = b"Exif\0\0";
    const XMP: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";
    const ICC: &[u8] = b"ICC_PROFILE\0";
    let mut meta = Metadata::default();
    // (sequence number, chunk count, data) of each ICC chunk, borrowed until assembled.
    let mut icc: Vec<(u8, u8, &[u8])> = Vec::new();
    let mut icc_total = 0u64;
    let mut pos = 2;
    while let Some(&byte) = b.get(pos) {
        // Stray bytes between segments: the pixel decoder skips them, so the metadata
        // read so far stands and the scan stops.
        if byte != 0xff {
            break;
        }
        while b.get(pos) == Some(&0xff) {
            pos += 1;
        }
        let Some(&marker) = b.get(pos) else { break };
        pos += 1;
        match marker {
            // Markers without a payload.
            0x01 | 0xd0..=0xd8 => continue,
            // Metadata comes before the scan; a short file is the pixel decoder's to report.
            0xd9 | 0xda => break,
            _ => {}
        }
        let Some(len) = b.get(pos..pos + 2) else {
            break;
        };
        let len = usize::from(u16::from_be_bytes([len[0], len[1]]));
        let remain = b.len() - pos;
        if len < 2 || len > remain {
            return Err(corrupt(
                "JPEG",
                format!(
                    "segment {marker:#04x} at offset {} declares {len} bytes, {remain} remain",
                    pos - 2
                ),
            ));
        }
        let payload = &b[pos + 2..pos + len];
        pos += len;
        match marker {
            0xe1 if meta.exif.is_none() && payload.starts_with(EXIF) => {
                meta.exif = Some(payload[EXIF.len()..].to_vec());
            }
            0xe1 if meta.xmp.is_none() && payload.starts_with(XMP) => {
                meta.xmp = Some(payload[XMP.len()..].to_vec());
            }
            0xe2 if payload.starts_with(ICC) && payload.len() >= ICC.len() + 2 => {
                let (seq, count) = (payload[ICC.len()], payload[ICC.len() + 1]);
                let data = &payload[ICC.len() + 2..];
                if seq == 1 && data.len() >= 4 {
                    // The profile's header declares its whole size.
                    let declared = u32::from_be_bytes([data[0], data[1], data[2], data[3]]);
                    check_size(Item::Icc, declared.into())?;
                }
                icc_total += data.len() as u64;
                check_size(Item::Icc, icc_total)?;
                icc.push((seq, count, data));
            }
            _ => {}
        }
    }
    if !icc.is_empty() {
        icc.sort_by_key(|c| c.0);
        let count = icc[0].1;
        let in_order = icc
            .iter()
            .enumerate()
            .all(|(i, c)| usize::from(c.0) == i + 1 && c.1 == count);
        if !in_order || icc.len() != usize::from(count) {
            let seqs: Vec<(u8, u8)> = icc.iter().map(|c| (c.0, c.1)).collect();
            return Err(corrupt(
                "ICC profile",
                format!("JPEG chunks (number, count) {seqs:?} are not 1..=count of one count"),
            ));
        }
        let mut out = Vec::with_capacity(icc_total as usize);
        for (_, _, data) in icc {
            out.extend_from_slice(data);
        }
        meta.icc = Some(out);
    }
    Ok(meta)
}

/// The text up to the first NUL within `max` bytes, and the bytes after the NUL.
fn nul_terminated(b: &[u8], max: usize) -> Option<(&[u8], &[u8])> {
    let end = b.iter().take(max + 1).position(|&c| c == 0)?;
    Some((&b[..end], &b[end + 1..]))
}

/// Inflates a zlib stream of at most [`MAX_ITEM_BYTES`].
fn inflate(item: Item, z: &[u8]) -> Result<Vec<u8>, MetadataError> {
    use miniz_oxide::inflate::{decompress_to_vec_zlib_with_limit, TINFLStatus};
    decompress_to_vec_zlib_with_limit(z, MAX_ITEM_BYTES).map_err(|e| match e.status {
        TINFLStatus::HasMoreOutput => MetadataError::InflatesTooLarge {
            item,
            max: MAX_ITEM_BYTES,
        },
        status => MetadataError::Corrupt {
            item: match item {
                Item::Icc => "ICC profile",
                Item::Exif => "EXIF",
                Item::Xmp => "XMP packet",
            },
            reason: format!("damaged zlib stream ({status:?})"),
        },
    })
}

fn read_png(b: &[u8]) -> Result<Metadata, MetadataError> {
    let mut meta = Metadata::default();
    let mut pos = PNG_SIGNATURE.len();
    while let Some(head) = b.get(pos..pos + 8) {
        let len = u64::from(u32::from_be_bytes([head[0], head[1], head[2], head[3]]));
        let kind: [u8; 4] = [head[4], head[5], head[6], head[7]];
        let start = pos + 8;
        if &kind == b"eXIf" {
            check_size(Item::Exif, len)?;
        }
        let remain = b.len() - start;
        if len > remain as u64 {
            return Err(corrupt(
                "PNG",
                format!(
                    "chunk {} at offset {pos} declares {len} bytes, {remain} remain",
                    String::from_utf8_lossy(&kind)
                ),
            ));
        }
        let data = &b[start..start + len as usize];
        match &kind {
            b"IEND" => break,
            b"iCCP" if meta.icc.is_none() => meta.icc = Some(png_iccp(data)?),
            b"eXIf" if meta.exif.is_none() => meta.exif = Some(strip_exif_prefix(data).to_vec()),
            b"iTXt" if meta.xmp.is_none() => meta.xmp = png_xmp(data)?,
            _ => {}
        }
        // The chunk's CRC follows; the pixel decoder checks it.
        pos = start + len as usize + 4;
    }
    Ok(meta)
}

fn png_iccp(data: &[u8]) -> Result<Vec<u8>, MetadataError> {
    let bad = |what: &str| corrupt("ICC profile", format!("PNG iCCP chunk: {what}"));
    let (_, rest) = nul_terminated(data, 79).ok_or_else(|| bad("no profile name"))?;
    let (&method, z) = rest
        .split_first()
        .ok_or_else(|| bad("no compression method"))?;
    if method != 0 {
        return Err(bad(&format!("unknown compression method {method}")));
    }
    // The profile's header declares its size: refuse an oversized one before inflating.
    use miniz_oxide::inflate::decompress_to_vec_zlib_with_limit;
    let head = decompress_to_vec_zlib_with_limit(z, 4).unwrap_or_else(|e| e.output);
    if let [a, b, c, d] = head[..] {
        check_size(Item::Icc, u32::from_be_bytes([a, b, c, d]).into())?;
    }
    inflate(Item::Icc, z)
}

/// The XMP packet of an iTXt chunk, if the chunk is the XMP one.
fn png_xmp(data: &[u8]) -> Result<Option<Vec<u8>>, MetadataError> {
    let bad = |what: &str| corrupt("XMP packet", format!("PNG iTXt chunk: {what}"));
    let Some((keyword, rest)) = nul_terminated(data, 79) else {
        return Ok(None);
    };
    if keyword != b"XML:com.adobe.xmp" {
        return Ok(None);
    }
    let [flag, method, rest @ ..] = rest else {
        return Err(bad("no compression flag"));
    };
    let (_, rest) = nul_terminated(rest, rest.len()).ok_or_else(|| bad("no language tag"))?;
    let (_, text) = nul_terminated(rest, rest.len()).ok_or_else(|| bad("no translated keyword"))?;
    match (flag, method) {
        (0, _) => {
            check_size(Item::Xmp, text.len() as u64)?;
            Ok(Some(text.to_vec()))
        }
        (1, 0) => inflate(Item::Xmp, text).map(Some),
        _ => Err(bad(&format!("compression flag {flag}, method {method}"))),
    }
}

fn read_webp(b: &[u8]) -> Result<Metadata, MetadataError> {
    let mut meta = Metadata::default();
    let mut pos = 12;
    while let Some(head) = b.get(pos..pos + 8) {
        let len = u64::from(u32::from_le_bytes([head[4], head[5], head[6], head[7]]));
        let kind = &head[..4];
        let item = match kind {
            b"ICCP" => Some(Item::Icc),
            b"EXIF" => Some(Item::Exif),
            b"XMP " => Some(Item::Xmp),
            _ => None,
        };
        if let Some(item) = item {
            check_size(item, len)?;
        }
        let start = pos + 8;
        let remain = b.len() - start;
        if len > remain as u64 {
            return Err(corrupt(
                "WebP",
                format!(
                    "chunk {} at offset {pos} declares {len} bytes, {remain} remain",
                    String::from_utf8_lossy(kind)
                ),
            ));
        }
        let data = &b[start..start + len as usize];
        match item {
            Some(Item::Icc) if meta.icc.is_none() => meta.icc = Some(data.to_vec()),
            Some(Item::Exif) if meta.exif.is_none() => {
                meta.exif = Some(strip_exif_prefix(data).to_vec())
            }
            Some(Item::Xmp) if meta.xmp.is_none() => meta.xmp = Some(data.to_vec()),
            _ => {}
        }
        // Chunks are padded to an even length.
        pos = start + len as usize + (len as usize & 1);
    }
    Ok(meta)
}

/// One PNG chunk: length, type, data, CRC.
fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let start = out.len();
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let crc = crc32fast::hash(&out[start..]);
    out.extend_from_slice(&crc.to_be_bytes());
}

/// The PNG chunks that carry the metadata: iCCP (the profile, zlib), eXIf and iTXt
/// (`XML:com.adobe.xmp`, uncompressed), in an order valid right after IHDR.
pub fn png_chunks(meta: &Metadata) -> Result<Vec<u8>, MetadataError> {
    meta.check_sizes()?;
    let mut out = Vec::new();
    if let Some(icc) = &meta.icc {
        let mut data = b"ICC profile\0\0".to_vec();
        data.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(icc, 9));
        png_chunk(&mut out, b"iCCP", &data);
    }
    if let Some(exif) = &meta.exif {
        png_chunk(&mut out, b"eXIf", exif);
    }
    if let Some(xmp) = &meta.xmp {
        let mut data = b"XML:com.adobe.xmp\0\0\0\0\0".to_vec();
        data.extend_from_slice(xmp);
        png_chunk(&mut out, b"iTXt", &data);
    }
    Ok(out)
}

/// Adds [`png_chunks`] to a PNG file right after its IHDR chunk.
pub fn insert_png_chunks(png: &mut Vec<u8>, meta: &Metadata) -> Result<(), MetadataError> {
    // Signature, then IHDR's length, type, 13 bytes and CRC.
    const AFTER_IHDR: usize = 8 + 8 + 13 + 4;
    if png.get(12..16) != Some(b"IHDR") || png.len() < AFTER_IHDR {
        return Err(corrupt("PNG", "the file does not start with IHDR".into()));
    }
    let chunks = png_chunks(meta)?;
    png.reserve_exact(chunks.len());
    png.splice(AFTER_IHDR..AFTER_IHDR, chunks);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A TIFF block with IFD0 holding `entries` (tag, type, count, value) and linking
    /// to `next`.
    fn tiff(little: bool, entries: &[(u16, u16, u32, u32)], next: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let u16b = |v: u16| {
            if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        let u32b = |v: u32| {
            if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        out.extend_from_slice(if little { b"II*\0" } else { b"MM\0*" });
        out.extend_from_slice(&u32b(8));
        out.extend_from_slice(&u16b(entries.len() as u16));
        for &(tag, kind, count, value) in entries {
            out.extend_from_slice(&u16b(tag));
            out.extend_from_slice(&u16b(kind));
            out.extend_from_slice(&u32b(count));
            if kind == TYPE_SHORT && count == 1 {
                // A SHORT sits in the first two bytes of the value field.
                out.extend_from_slice(&u16b(value as u16));
                out.extend_from_slice(&[0, 0]);
            } else {
                out.extend_from_slice(&u32b(value));
            }
        }
        out.extend_from_slice(&u32b(next));
        out
    }

    #[test]
    fn orientation_in_both_byte_orders() {
        for little in [true, false] {
            let exif = tiff(
                little,
                &[(0x010f, 2, 4, 0), (ORIENTATION_TAG, TYPE_SHORT, 1, 6)],
                0,
            );
            assert_eq!(orientation(&exif), Ok(Some(6)), "little endian: {little}");
            let reset = with_orientation_one(&exif);
            assert_eq!(orientation(&reset), Ok(Some(1)));
            assert_eq!(reset.len(), exif.len());
            let changed = exif.iter().zip(&reset).filter(|(a, b)| a != b).count();
            assert_eq!(changed, 1, "only the value's low byte changes");
        }
    }

    #[test]
    fn absent_or_odd_orientation_is_none() {
        let none = tiff(true, &[(0x010f, 2, 4, 0)], 0);
        assert_eq!(orientation(&none), Ok(None));
        let long = tiff(true, &[(ORIENTATION_TAG, 4, 1, 6)], 0);
        assert_eq!(orientation(&long), Ok(None));
        let nine = tiff(false, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 9)], 0);
        assert_eq!(orientation(&nine), Ok(None));
        let mut same = none.clone();
        assert_eq!(reset_orientation(&mut same), Ok(None));
        assert_eq!(same, none);
    }

    #[test]
    fn cyclic_chain_is_an_error_and_orientation_still_reads() {
        // IFD0 at 8 links to itself.
        let exif = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 3)], 8);
        assert_eq!(ifd_chain(&exif), Err(MetadataError::IfdLoop { offset: 8 }));
        assert_eq!(orientation(&exif), Ok(Some(3)));
        // Two directories linking to each other.
        let mut two = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 3)], 26);
        two.extend_from_slice(&[0, 0, 8, 0, 0, 0]);
        assert_eq!(two.len(), 32);
        assert_eq!(ifd_chain(&two), Err(MetadataError::IfdLoop { offset: 8 }));
        let chain = ifd_chain(&tiff(true, &[], 0)).expect("one directory");
        assert_eq!(chain, vec![8]);
    }

    #[test]
    fn long_chain_stops_at_the_limit() {
        // Directories of no entries, each linking to the next, MAX_IFDS + 1 of them.
        let mut exif = b"II*\0".to_vec();
        exif.extend_from_slice(&8u32.to_le_bytes());
        for i in 0..=MAX_IFDS as u32 {
            exif.extend_from_slice(&0u16.to_le_bytes());
            exif.extend_from_slice(&(8 + 6 * (i + 1)).to_le_bytes());
        }
        exif.extend_from_slice(&[0; 6]);
        assert_eq!(
            ifd_chain(&exif),
            Err(MetadataError::TooManyIfds { max: MAX_IFDS })
        );
    }

    #[test]
    fn truncated_and_huge_counts_are_errors() {
        let exif = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 6)], 0);
        for cut in 0..exif.len() - 4 {
            let r = orientation(&exif[..cut]);
            assert!(r.is_err(), "cut at {cut}: {r:?}");
        }
        // The link may be missing: the chain ends there.
        assert_eq!(orientation(&exif[..exif.len() - 4]), Ok(Some(6)));
        // 65535 entries declared in a 26-byte block.
        let mut huge = exif.clone();
        huge[8..10].copy_from_slice(&u16::MAX.to_le_bytes());
        assert!(matches!(
            orientation(&huge),
            Err(MetadataError::OutOfBounds { need: 786_422, .. })
        ));
        assert!(ifd_chain(&huge).is_err());
        // IFD0 far past the end, and at the very top of the offset range.
        for off in [1000u32, u32::MAX] {
            let mut far = exif.clone();
            far[4..8].copy_from_slice(&off.to_le_bytes());
            assert!(matches!(
                orientation(&far),
                Err(MetadataError::OutOfBounds { .. })
            ));
        }
        assert!(matches!(
            orientation(b"JFIF"),
            Err(MetadataError::NotTiff { .. })
        ));
        assert!(matches!(
            orientation(b""),
            Err(MetadataError::NotTiff { .. })
        ));
    }

    #[test]
    fn filtering_keeps_what_the_policy_names() {
        let all = Metadata {
            icc: Some(vec![1]),
            exif: Some(vec![2]),
            xmp: Some(vec![3]),
        };
        assert!(all.filtered(MetadataPolicy::None).is_empty());
        let icc = all.filtered(MetadataPolicy::Icc);
        assert_eq!(
            (icc.icc.as_deref(), icc.exif, icc.xmp),
            (Some(&[1u8][..]), None, None)
        );
        assert_eq!(all.filtered(MetadataPolicy::All), all);
        assert_eq!(MetadataPolicy::parse("icc"), Some(MetadataPolicy::Icc));
        assert_eq!(MetadataPolicy::parse("ICC"), None);
        let big = Metadata {
            xmp: Some(vec![0; MAX_ITEM_BYTES + 1]),
            ..Metadata::default()
        };
        assert!(matches!(
            big.check_sizes(),
            Err(MetadataError::TooLarge {
                item: Item::Xmp,
                ..
            })
        ));
    }

    fn jpeg_with(segments: &[(u8, Vec<u8>)]) -> Vec<u8> {
        let mut out = vec![0xff, 0xd8];
        for (marker, payload) in segments {
            out.extend_from_slice(&[0xff, *marker]);
            out.extend_from_slice(&(payload.len() as u16 + 2).to_be_bytes());
            out.extend_from_slice(payload);
        }
        out.extend_from_slice(&[0xff, 0xd9]);
        out
    }

    fn icc_chunk(seq: u8, count: u8, data: &[u8]) -> (u8, Vec<u8>) {
        let mut p = b"ICC_PROFILE\0".to_vec();
        p.extend_from_slice(&[seq, count]);
        p.extend_from_slice(data);
        (0xe2, p)
    }

    #[test]
    fn jpeg_icc_chunks_join_in_sequence_order() {
        let mut profile = vec![0u8; 300];
        profile[..4].copy_from_slice(&300u32.to_be_bytes());
        profile
            .iter_mut()
            .skip(4)
            .enumerate()
            .for_each(|(i, b)| *b = i as u8);
        let (a, b) = profile.split_at(100);
        let jpeg = jpeg_with(&[icc_chunk(2, 2, b), icc_chunk(1, 2, a)]);
        let meta = read_container(&jpeg).unwrap();
        assert_eq!(meta.icc, Some(profile.clone()));
        // A chunk missing, or counts that disagree.
        for bad in [
            jpeg_with(&[icc_chunk(1, 2, a)]),
            jpeg_with(&[icc_chunk(1, 2, a), icc_chunk(2, 3, b)]),
            jpeg_with(&[icc_chunk(1, 2, a), icc_chunk(1, 2, a)]),
        ] {
            assert!(
                matches!(
                    read_container(&bad),
                    Err(MetadataError::Corrupt {
                        item: "ICC profile",
                        ..
                    })
                ),
                "{:?}",
                read_container(&bad)
            );
        }
    }

    #[test]
    fn jpeg_exif_and_xmp_segments() {
        let exif = tiff(false, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 8)], 0);
        let xmp = b"<x:xmpmeta/>".to_vec();
        let jpeg = jpeg_with(&[
            (0xe0, b"JFIF\0\x01\x02".to_vec()),
            (0xe1, [b"Exif\0\0".as_slice(), &exif].concat()),
            (
                0xe1,
                [b"http://ns.adobe.com/xap/1.0/\0".as_slice(), &xmp].concat(),
            ),
        ]);
        let meta = read_container(&jpeg).unwrap();
        assert_eq!(meta.exif, Some(exif));
        assert_eq!(meta.xmp, Some(xmp));
        assert_eq!(meta.icc, None);
        assert_eq!(meta.orientation(), Ok(Some(8)));
        // Every prefix of the file is read without a panic.
        for cut in 0..jpeg.len() {
            let _ = read_container(&jpeg[..cut]);
        }
    }

    #[test]
    fn webp_chunks_with_padding() {
        let mut riff = b"RIFF\0\0\0\0WEBP".to_vec();
        for (kind, data) in [
            (b"VP8X", vec![0u8; 10]),
            (b"ICCP", vec![1, 2, 3]),
            (
                b"EXIF",
                [b"Exif\0\0".as_slice(), b"MM\0*\0\0\0\x08\0\0"].concat(),
            ),
            (b"XMP ", b"<x/>".to_vec()),
        ] {
            riff.extend_from_slice(kind);
            riff.extend_from_slice(&(data.len() as u32).to_le_bytes());
            riff.extend_from_slice(&data);
            if data.len() % 2 == 1 {
                riff.push(0);
            }
        }
        let meta = read_container(&riff).unwrap();
        assert_eq!(meta.icc, Some(vec![1, 2, 3]));
        assert_eq!(meta.exif.as_deref(), Some(&b"MM\0*\0\0\0\x08\0\0"[..]));
        assert_eq!(meta.xmp, Some(b"<x/>".to_vec()));
        let mut lying = riff.clone();
        lying[16..20].copy_from_slice(&1000u32.to_le_bytes());
        assert!(matches!(
            read_container(&lying),
            Err(MetadataError::Corrupt { item: "WebP", .. })
        ));
        let mut huge = riff[..12].to_vec();
        huge.extend_from_slice(b"ICCP");
        huge.extend_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            read_container(&huge),
            Err(MetadataError::TooLarge {
                item: Item::Icc,
                bytes: 4_294_967_295,
                ..
            })
        ));
    }

    #[test]
    fn png_chunks_read_back() {
        let meta = Metadata {
            icc: Some(vec![
                0, 0, 0, 20, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
            ]),
            exif: Some(tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 1)], 0)),
            xmp: Some(b"<x/>".to_vec()),
        };
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"IEND", &[]);
        insert_png_chunks(&mut png, &meta).unwrap();
        assert_eq!(read_container(&png).unwrap(), meta);
        for cut in 0..png.len() {
            let _ = read_container(&png[..cut]);
        }
        // A compressed XMP packet is inflated.
        let mut data = b"XML:com.adobe.xmp\0\x01\0\0\0".to_vec();
        data.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(
            b"<x:packed/>",
            6,
        ));
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"iTXt", &data);
        assert_eq!(
            read_container(&png).unwrap().xmp,
            Some(b"<x:packed/>".to_vec())
        );
    }

    /// A JPEG, a PNG and a WebP each carrying all three items.
    fn samples() -> [Vec<u8>; 3] {
        let exif = tiff(
            true,
            &[(0x010f, 2, 4, 0), (ORIENTATION_TAG, TYPE_SHORT, 1, 6)],
            0,
        );
        let jpeg = jpeg_with(&[
            (0xe1, [b"Exif\0\0".as_slice(), &exif].concat()),
            (0xe1, b"http://ns.adobe.com/xap/1.0/\0<x/>".to_vec()),
            icc_chunk(1, 1, &[0, 0, 0, 8, 1, 2, 3, 4]),
        ]);
        let meta = Metadata {
            icc: Some(vec![0, 0, 0, 8, 1, 2, 3, 4]),
            exif: Some(exif.clone()),
            xmp: Some(b"<x/>".to_vec()),
        };
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"IEND", &[]);
        insert_png_chunks(&mut png, &meta).unwrap();
        let mut webp = b"RIFF\0\0\0\0WEBP".to_vec();
        for (kind, data) in [
            (b"ICCP", &meta.icc),
            (b"EXIF", &meta.exif),
            (b"XMP ", &meta.xmp),
        ] {
            let data = data.as_ref().unwrap();
            webp.extend_from_slice(kind);
            webp.extend_from_slice(&(data.len() as u32).to_le_bytes());
            webp.extend_from_slice(data);
        }
        [jpeg, png, webp]
    }

    fn exercise(bytes: &[u8]) {
        if let Ok(meta) = read_container(bytes) {
            assert!(meta.check_sizes().is_ok());
            if let Some(mut exif) = meta.exif {
                let before = orientation(&exif);
                let _ = ifd_chain(&exif);
                let reset = reset_orientation(&mut exif);
                assert_eq!(before.is_ok(), reset.is_ok());
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]

        #[test]
        fn damaged_containers_never_panic(
            which in 0usize..3,
            flips in proptest::collection::vec((0usize..4096, proptest::prelude::any::<u8>()), 1..6),
            cut in 0usize..4096,
        ) {
            let mut b = samples()[which].clone();
            for (at, v) in flips {
                let n = b.len();
                b[at % n] = v;
            }
            b.truncate(cut.max(2));
            exercise(&b);
        }

        #[test]
        fn any_exif_block_is_walked_safely(
            little in proptest::prelude::any::<bool>(),
            body in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
        ) {
            let mut exif = if little { b"II*\0".to_vec() } else { b"MM\0*".to_vec() };
            exif.extend_from_slice(&body);
            let o = orientation(&exif);
            let _ = ifd_chain(&exif);
            let mut copy = exif.clone();
            let old = reset_orientation(&mut copy);
            if let (Ok(Some(v)), Ok(Some(w))) = (o, old) {
                proptest::prop_assert_eq!(v, w);
            }
        }
    }
}

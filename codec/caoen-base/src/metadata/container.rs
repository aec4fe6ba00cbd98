//! The metadata items found in JPEG (APP1/APP2 segments), PNG (iCCP, eXIf, iTXt) and
//! WebP (ICCP, EXIF, XMP chunks) files, every declared size checked before copying.

use super::xmp_ext::{join_extended, without_pointer, EXTENSION_NAMESPACE};
use super::{
    check_size, corrupt, strip_exif_prefix, Dropped, Item, Metadata, MetadataError, MAX_ITEM_BYTES,
};

/// The metadata of an image file, from its bytes: JPEG (APP2 ICC chunks, APP1 EXIF and
/// XMP), PNG (iCCP, eXIf, iTXt XMP) and WebP (ICCP, EXIF, XMP chunks); other formats
/// give none. Every declared size is checked against the file and against
/// [`MAX_ITEM_BYTES`] before the item is copied.
pub fn read_container(bytes: &[u8]) -> Result<Metadata, MetadataError> {
    read_skipping(bytes, &[])
}

/// [`read_container`] as files are found in the wild: a damaged item (a profile with a
/// chunk missing, a bad zlib stream, an item over the limit) is left out and named, and
/// the other items are still read. A damaged container (a segment or chunk running
/// past the file) is still an error: the pixels are behind it.
pub fn read_container_lenient(bytes: &[u8]) -> Result<(Metadata, Vec<Dropped>), MetadataError> {
    let mut skip = Vec::new();
    let mut dropped = Vec::new();
    loop {
        match read_skipping(bytes, &skip) {
            Ok(meta) => return Ok((meta, dropped)),
            Err(e) => {
                // Each round leaves one more kind of item out, so this ends.
                let item = item_of(&e).filter(|i| !skip.contains(i)).ok_or(e.clone())?;
                skip.push(item);
                let reason = match &e {
                    MetadataError::Corrupt { reason, .. } => reason.clone(),
                    e => e.to_string(),
                };
                dropped.push(Dropped { item, reason });
            }
        }
    }
}

/// The item an error is about, or `None` for the container around the items.
fn item_of(e: &MetadataError) -> Option<Item> {
    match e {
        MetadataError::TooLarge { item, .. } | MetadataError::InflatesTooLarge { item, .. } => {
            Some(*item)
        }
        MetadataError::Corrupt { item, .. } => match *item {
            "ICC profile" => Some(Item::Icc),
            "EXIF" => Some(Item::Exif),
            "XMP packet" => Some(Item::Xmp),
            "extended XMP" => Some(Item::XmpExtension),
            _ => None,
        },
        _ => Some(Item::Exif),
    }
}

fn read_skipping(bytes: &[u8], skip: &[Item]) -> Result<Metadata, MetadataError> {
    if bytes.starts_with(&[0xff, 0xd8]) {
        read_jpeg(bytes, skip)
    } else if bytes.starts_with(PNG_SIGNATURE) {
        read_png(bytes, skip)
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        read_webp(bytes, skip)
    } else {
        Ok(Metadata::default())
    }
}

pub const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

fn read_jpeg(b: &[u8], skip: &[Item]) -> Result<Metadata, MetadataError> {
    const EXIF: &[u8] = b"Exif\0\0";
    const XMP: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";
    const ICC: &[u8] = b"ICC_PROFILE\0";
    let mut meta = Metadata::default();
    // The payloads of the extended XMP's segments, borrowed until joined.
    let mut extension: Vec<&[u8]> = Vec::new();
    let keep_extension = !skip.contains(&Item::Xmp) && !skip.contains(&Item::XmpExtension);
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
            0xe1 if skip.contains(&Item::Exif) && payload.starts_with(EXIF) => {}
            0xe1 if skip.contains(&Item::Xmp) && payload.starts_with(XMP) => {}
            0xe2 if skip.contains(&Item::Icc) => {}
            0xe1 if meta.exif.is_none() && payload.starts_with(EXIF) => {
                // Some writers repeat the prefix inside the segment.
                meta.exif = Some(strip_exif_prefix(&payload[EXIF.len()..]).to_vec());
            }
            0xe1 if meta.xmp.is_none() && payload.starts_with(XMP) => {
                meta.xmp = Some(payload[XMP.len()..].to_vec());
            }
            0xe1 if keep_extension && payload.starts_with(EXTENSION_NAMESPACE) => {
                extension.push(&payload[EXTENSION_NAMESPACE.len()..]);
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
    if keep_extension {
        meta.xmp = join_extended(meta.xmp.take(), &extension)?;
    } else if skip.contains(&Item::XmpExtension) {
        meta.xmp = without_pointer(meta.xmp.take());
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
                Item::Xmp | Item::XmpExtension => "XMP packet",
            },
            reason: format!("damaged zlib stream ({status:?})"),
        },
    })
}

/// The `len` bytes of the `format` file `b`'s chunk `kind` (its header at `pos`) from
/// `start` on; an error if the file ends first.
fn chunk_data<'a>(
    format: &'static str,
    b: &'a [u8],
    kind: &[u8],
    pos: usize,
    start: usize,
    len: u64,
) -> Result<&'a [u8], MetadataError> {
    let remain = b.len() - start;
    if len > remain as u64 {
        return Err(corrupt(
            format,
            format!(
                "chunk {} at offset {pos} declares {len} bytes, {remain} remain",
                crate::printable(&String::from_utf8_lossy(kind))
            ),
        ));
    }
    Ok(&b[start..start + len as usize])
}

fn read_png(b: &[u8], skip: &[Item]) -> Result<Metadata, MetadataError> {
    let mut meta = Metadata::default();
    let mut pos = PNG_SIGNATURE.len();
    while let Some(head) = b.get(pos..pos + 8) {
        let len = u64::from(u32::from_be_bytes([head[0], head[1], head[2], head[3]]));
        let kind: [u8; 4] = [head[4], head[5], head[6], head[7]];
        let start = pos + 8;
        if &kind == b"eXIf" && !skip.contains(&Item::Exif) {
            check_size(Item::Exif, len)?;
        }
        let data = chunk_data("PNG", b, &kind, pos, start, len)?;
        let skipped = match &kind {
            b"iCCP" => Some(Item::Icc),
            b"eXIf" => Some(Item::Exif),
            b"iTXt" => Some(Item::Xmp),
            _ => None,
        }
        .is_some_and(|i| skip.contains(&i));
        // The pixel decoder does not check the CRC of the chunks it skips: a damaged
        // item would otherwise be kept as if it were whole.
        let crc = b.get(start + len as usize..start + len as usize + 4);
        let whole = |item: &'static str| match crc {
            Some(c) if c != png_crc(&kind, data).to_be_bytes() => Err(corrupt(
                item,
                format!(
                    "PNG {} chunk: the CRC is wrong (the chunk is damaged)",
                    crate::printable(&String::from_utf8_lossy(&kind))
                ),
            )),
            _ => Ok(()),
        };
        match &kind {
            b"IEND" => break,
            _ if skipped => {}
            b"iCCP" if meta.icc.is_none() => {
                whole("ICC profile")?;
                meta.icc = Some(png_iccp(data)?);
            }
            b"eXIf" if meta.exif.is_none() => {
                whole("EXIF")?;
                meta.exif = Some(strip_exif_prefix(data).to_vec());
            }
            b"iTXt" if meta.xmp.is_none() => {
                meta.xmp = png_xmp(data)?;
                if meta.xmp.is_some() {
                    whole("XMP packet")?;
                }
            }
            _ => {}
        }
        pos = start + len as usize + 4;
    }
    Ok(meta)
}

/// The CRC of a PNG chunk: over its type and data.
fn png_crc(kind: &[u8; 4], data: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(kind);
    h.update(data);
    h.finalize()
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

fn read_webp(b: &[u8], skip: &[Item]) -> Result<Metadata, MetadataError> {
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
        let item = item.filter(|i| !skip.contains(i));
        if let Some(item) = item {
            check_size(item, len)?;
        }
        let start = pos + 8;
        let data = chunk_data("WebP", b, kind, pos, start, len)?;
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

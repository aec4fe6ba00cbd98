//! The metadata written as PNG chunks (iCCP, eXIf, iTXt) right after IHDR.

use super::{corrupt, Metadata, MetadataError};

/// One PNG chunk: length, type, data, CRC.
pub fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
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

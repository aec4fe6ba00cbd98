//! Reading: files and bytes into rasters (upright by the EXIF orientation), with their
//! metadata, under the header-checked size limits and the memory budget.

use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek};
use std::path::Path;

use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};

use super::convert::{from_dynamic_at, is_compact, EncodeSource};
use super::error::{guarded, image_error};
use super::{exr, ImageIoError, LoadLimits, EXR_MAGIC};
use caoen_base::metadata::{Dropped, Item, Metadata};
use caoen_base::raster::Raster;

/// Reads an image file with the default limits, upright by its EXIF orientation.
pub fn load(path: &Path) -> Result<Raster, ImageIoError> {
    load_with_limits(path, &LoadLimits::default())
}

/// Reads an image file upright by its EXIF orientation, as [`load_with_metadata`]
/// does, so every command sees a photo the way the encoder does; the format comes from
/// the file's magic bytes, or from its extension for formats that have none (TGA).
pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Raster, ImageIoError> {
    let io = |source| ImageIoError::Io {
        path: path.to_path_buf(),
        source,
    };
    if !std::fs::metadata(path).map_err(io)?.is_file() {
        // A stream cannot be read twice: its pixels as they come, without metadata.
        let mut file = BufReader::new(File::open(path).map_err(io)?);
        let mut magic = [0u8; 4];
        let got = read_up_to(&mut file, &mut magic).map_err(io)?;
        file.rewind().map_err(io)?;
        let by_ext = ImageFormat::from_path(path).ok();
        return decode_reader(file, path, &magic[..got], by_ext, limits, 1);
    }
    let bytes = limits.memory.read(path).map_err(io)?;
    let head = &bytes[..bytes.len().min(4)];
    decode_reader(
        Cursor::new(&bytes),
        path,
        head,
        ImageFormat::from_path(path).ok(),
        limits,
        exif_orientation(&bytes),
    )
}

/// The EXIF orientation of an image held in memory, read as [`oriented`] reads it; 1
/// (as stored) when there is none or the metadata is damaged: a plain load is for the
/// pixels, and damaged metadata is reported by the commands that keep it.
fn exif_orientation(bytes: &[u8]) -> u16 {
    if bytes.starts_with(&EXR_MAGIC) {
        return 1;
    }
    caoen_base::metadata::read_container_lenient(bytes)
        .ok()
        .and_then(|(meta, _)| meta.exif)
        .and_then(|exif| caoen_base::metadata::orientation(&exif).ok().flatten())
        .unwrap_or(1)
}

/// The metadata of an image file held in memory: JPEG, PNG and WebP as
/// [`caoen_base::metadata::read_container`] reads them, OpenEXR from the attributes
/// [`encode_with_metadata`](super::encode_with_metadata) writes; other formats give none.
pub fn read_metadata(bytes: &[u8]) -> Result<Metadata, ImageIoError> {
    read_metadata_at(bytes, Path::new("<memory>"))
}

fn read_metadata_at(bytes: &[u8], path: &Path) -> Result<Metadata, ImageIoError> {
    if bytes.starts_with(&EXR_MAGIC) {
        return exr::read_metadata(bytes, path);
    }
    caoen_base::metadata::read_container(bytes).map_err(|source| ImageIoError::Metadata {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads an image file and its metadata. The pixels are turned upright by the EXIF
/// orientation, and the kept EXIF says orientation 1, so the two agree.
pub fn load_with_metadata(
    path: &Path,
    limits: &LoadLimits,
) -> Result<(Raster, Metadata), ImageIoError> {
    let (image, meta, _) = read_oriented(path, limits, false)?;
    Ok((image.into_raster()?, meta))
}

/// Reads a whole file and decodes it upright with its metadata ([`oriented`]) and the
/// damaged or unfitting items left out of it.
pub(super) fn read_oriented(
    path: &Path,
    limits: &LoadLimits,
    compact: bool,
) -> Result<(EncodeSource, Metadata, Vec<Dropped>), ImageIoError> {
    let bytes = limits
        .memory
        .read(path)
        .map_err(|source| ImageIoError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    oriented(
        &bytes,
        path,
        ImageFormat::from_path(path).ok(),
        limits,
        compact,
    )
}

/// [`load_with_metadata`] of an image held in memory.
pub fn load_from_memory_with_metadata(
    bytes: &[u8],
    limits: &LoadLimits,
) -> Result<(Raster, Metadata), ImageIoError> {
    let (image, meta, _) = oriented(bytes, Path::new("<memory>"), None, limits, false)?;
    Ok((image.into_raster()?, meta))
}

/// Decodes an image held in memory upright, with its metadata (EXIF orientation reset
/// to 1); `compact` as in [`load_for_encoding`]. A damaged metadata item, or one that
/// does not fit the pixels (a CMYK profile once the pixels are RGB), is left out and
/// returned beside: the pixels are what the caller came for.
fn oriented(
    bytes: &[u8],
    path: &Path,
    by_ext: Option<ImageFormat>,
    limits: &LoadLimits,
    compact: bool,
) -> Result<(EncodeSource, Metadata, Vec<Dropped>), ImageIoError> {
    let (mut meta, mut dropped) = if bytes.starts_with(&EXR_MAGIC) {
        (exr::read_metadata(bytes, path)?, Vec::new())
    } else {
        caoen_base::metadata::read_container_lenient(bytes).map_err(|source| {
            ImageIoError::Metadata {
                path: path.to_path_buf(),
                source,
            }
        })?
    };
    let mut orientation = 1;
    if let Some(exif) = meta.exif.as_mut() {
        match caoen_base::metadata::orientation(exif) {
            Ok(o) => {
                orientation = o.unwrap_or(1);
                // `orientation` read the slot, so the reset cannot fail.
                let _ = caoen_base::metadata::reset_orientation(exif);
            }
            Err(e) => {
                meta.exif = None;
                dropped.push(Dropped {
                    item: Item::Exif,
                    reason: e.to_string(),
                });
            }
        }
    }
    // The pixels are turned upright below: an XMP orientation must then say so too.
    if orientation != 1 {
        if let Some(upright) = meta
            .xmp
            .as_deref()
            .and_then(caoen_base::metadata::xmp_with_orientation_one)
        {
            meta.xmp = Some(upright);
        }
    }
    let head = &bytes[..bytes.len().min(4)];
    let image = decode_image(
        Cursor::new(bytes),
        path,
        head,
        by_ext,
        limits,
        compact,
        orientation,
    )?;
    let colour = match &image {
        EncodeSource::Compact(i) => i.color().has_color(),
        EncodeSource::Raster(r) => r.layout().colour_channels() == 3,
    };
    let (meta, unfit) = meta.fitted(if colour { 3 } else { 1 });
    dropped.extend(unfit);
    Ok((image, meta, dropped))
}

/// Decodes an image held in memory (format from its magic bytes), upright by its EXIF
/// orientation as [`load_with_limits`] reads a file.
pub fn load_from_memory(bytes: &[u8], limits: &LoadLimits) -> Result<Raster, ImageIoError> {
    let head = &bytes[..bytes.len().min(4)];
    decode_reader(
        Cursor::new(bytes),
        Path::new("<memory>"),
        head,
        None,
        limits,
        exif_orientation(bytes),
    )
}

/// Fills `buf` as far as the reader allows; short files are not an error here.
fn read_up_to(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match reader.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

fn decode_reader<R: std::io::BufRead + Seek>(
    reader: R,
    path: &Path,
    magic: &[u8],
    by_ext: Option<ImageFormat>,
    limits: &LoadLimits,
    orientation: u16,
) -> Result<Raster, ImageIoError> {
    match decode_image(reader, path, magic, by_ext, limits, false, orientation)? {
        EncodeSource::Raster(r) => Ok(r),
        EncodeSource::Compact(image) => from_dynamic_at(image, path),
    }
}

/// Decodes an image, kept in the decoder's own 8/16-bit form when `compact` and the
/// image has integer samples, else as a raster.
fn decode_image<R: std::io::BufRead + Seek>(
    reader: R,
    path: &Path,
    magic: &[u8],
    by_ext: Option<ImageFormat>,
    limits: &LoadLimits,
    compact: bool,
    orientation: u16,
) -> Result<EncodeSource, ImageIoError> {
    if magic.is_empty() {
        return Err(ImageIoError::Truncated {
            path: path.to_path_buf(),
            reason: "the file is empty".into(),
        });
    }
    if magic == EXR_MAGIC {
        return exr::read_exr(reader, path, limits).map(EncodeSource::Raster);
    }
    let is_exr_ext = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr_ext {
        // Say what is wrong rather than "unknown format" when an .exr lacks its magic.
        return Err(ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: format!("not an OpenEXR file (starts with {magic:02x?})"),
        });
    }
    let mut reader = ImageReader::new(reader)
        .with_guessed_format()
        .map_err(|source| ImageIoError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    if reader.format().is_none() {
        match by_ext {
            // Only formats without a signature are trusted by extension; for the
            // others a missing signature means the file is not what its name says.
            Some(ImageFormat::Tga) => reader.set_format(ImageFormat::Tga),
            Some(f) => {
                return Err(ImageIoError::Corrupt {
                    path: path.to_path_buf(),
                    reason: format!(
                        "named as {} but does not start like one (bytes {magic:02x?})",
                        f.extensions_str()
                            .first()
                            .map_or("an image".into(), |e| e.to_ascii_uppercase())
                    ),
                })
            }
            None => {
                return Err(ImageIoError::Unsupported {
                    path: path.to_path_buf(),
                    reason: format!("unknown file format (starts with {magic:02x?})"),
                })
            }
        }
    }
    // Read only the header first, with an allocation budget but no side limit, so the
    // dimensions can be checked (and reported) before the pixels are decoded.
    let mut header_limits = limits.for_image_crate();
    header_limits.max_image_width = None;
    header_limits.max_image_height = None;
    reader.limits(header_limits);
    let image = guarded(path, || {
        let mut decoder = reader.into_decoder().map_err(|e| image_error(path, e))?;
        let (w, h) = decoder.dimensions();
        limits.check(path, u64::from(w), u64::from(h))?;
        let colour = decoder.color_type();
        let integer = compact && is_compact(colour);
        // Orientations 5 to 8 swap the axes, which takes a rotated copy beside the
        // decoded image; the others flip in place.
        let copies = if (5..=8).contains(&orientation) { 2 } else { 1 };
        limits.check_memory(
            path,
            (u64::from(w), u64::from(h)),
            copies * u64::from(colour.bytes_per_pixel()),
            if integer {
                0
            } else {
                colour.channel_count().into()
            },
        )?;
        decoder
            .set_limits(limits.for_image_crate())
            .map_err(|e| image_error(path, e))?;
        let mut image = DynamicImage::from_decoder(decoder).map_err(|e| image_error(path, e))?;
        if let Some(o) = u8::try_from(orientation)
            .ok()
            .and_then(image::metadata::Orientation::from_exif)
        {
            image.apply_orientation(o);
        }
        Ok(image)
    })?;
    if compact && is_compact(image.color()) {
        Ok(EncodeSource::Compact(image))
    } else {
        from_dynamic_at(image, path).map(EncodeSource::Raster)
    }
}

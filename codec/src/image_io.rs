//! Image files in and out of a [`Raster`]: everything the `image` crate reads (PNG,
//! JPEG, BMP, GIF, TIFF, WebP, PNM, TGA, QOI, Radiance HDR; 8/16-bit, grey, grey+alpha,
//! RGB, RGBA) and OpenEXR (float, through the `exr` crate); PNG (8 or 16-bit) and
//! OpenEXR (32-bit float) out.
//!
//! Reading checks the header's dimensions against [`LoadLimits`] before any pixel
//! buffer is allocated, so a hostile header cannot make us allocate gigabytes, and
//! every decoder failure becomes an [`ImageIoError`], never a panic.

use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek};
use std::path::{Path, PathBuf};

use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};
use thiserror::Error;

use crate::codec::tiling::TileRect;
use crate::codec::PixelSource;
use crate::metadata::Metadata;
use crate::raster::{ChannelLayout, Raster, RasterError, SampleFormat};

/// Default limit on either side, matching the codec's [`crate::codec::MAX_SIDE`].
pub const DEFAULT_MAX_SIDE: u32 = crate::codec::MAX_SIDE;
/// Default limit on pixels of images read as textures, slices and references (2^26);
/// the encoder reads up to [`crate::codec::DEFAULT_MAX_PIXELS`].
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 26;

/// The four bytes every OpenEXR file starts with.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Why an image could not be read or written, sorted by who is at fault.
#[derive(Debug, Error)]
pub enum ImageIoError {
    // --- The file's fault -----------------------------------------------------------
    /// The file is damaged or not what its format says.
    #[error("{}: corrupt image: {reason}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The file ends before the image does.
    #[error("{}: truncated image: {reason}", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The header declares a zero width or height.
    #[error("{}: empty image ({width}x{height})", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
    },
    /// A float sample is NaN or infinite; the codec only codes finite values.
    #[error(
        "{}: sample {value} in channel {channel} at pixel ({x}, {y}) is not finite",
        path.display()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Channel name as stored in the file (e.g. `R`).
        channel: String,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The offending value.
        value: f32,
    },
    /// The format or its pixel type is not one we read.
    #[error("{}: unsupported image: {reason}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is missing.
        reason: String,
    },
    /// The header declares an image larger than the limits allow.
    #[error(
        "{}: image is {width}x{height}, over the limit ({max_side} per side, {max_pixels} pixels)",
        path.display()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// Side limit in force.
        max_side: u32,
        /// Pixel limit in force.
        max_pixels: u64,
    },

    /// Decoding the image would exceed the memory budget.
    #[error("{}: {source}", path.display())]
    Memory {
        /// The file.
        path: PathBuf,
        /// The need and the budget.
        source: crate::budget::OverBudget,
    },

    /// A metadata item (ICC profile, EXIF, XMP) is damaged or over its size limit.
    #[error("{}: {source}", path.display())]
    Metadata {
        /// The file.
        path: PathBuf,
        /// What is wrong with the item.
        source: crate::metadata::MetadataError,
    },

    // --- The caller's fault ---------------------------------------------------------
    /// The output path's extension names no format we write.
    #[error("{}: cannot write this format (use .png or .exr)", path.display())]
    UnknownOutputFormat {
        /// The requested output.
        path: PathBuf,
    },

    // --- The environment's fault ----------------------------------------------------
    /// Reading or writing the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// Size limits checked against an image's header before its pixels are decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoadLimits {
    /// Largest accepted width or height.
    pub max_side: u32,
    /// Largest accepted `width * height`.
    pub max_pixels: u64,
}

impl Default for LoadLimits {
    fn default() -> Self {
        LoadLimits {
            max_side: DEFAULT_MAX_SIDE,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

impl LoadLimits {
    /// Rejects empty or oversized dimensions.
    fn check(&self, path: &Path, width: u64, height: u64) -> Result<(), ImageIoError> {
        if width == 0 || height == 0 {
            return Err(ImageIoError::Empty {
                path: path.to_path_buf(),
                width,
                height,
            });
        }
        let side = u64::from(self.max_side);
        if width > side || height > side || width.saturating_mul(height) > self.max_pixels {
            return Err(ImageIoError::TooLarge {
                path: path.to_path_buf(),
                width,
                height,
                max_side: self.max_side,
                max_pixels: self.max_pixels,
            });
        }
        Ok(())
    }

    /// Checks the memory a decode takes against the budget: the decoder's buffer of
    /// `decoded_bytes` per pixel (counted twice when `decoded_bytes` include a rotated
    /// copy), and the raster's `channels` floats per pixel.
    fn check_memory(
        &self,
        path: &Path,
        (width, height): (u64, u64),
        decoded_bytes: u64,
        channels: u64,
    ) -> Result<(), ImageIoError> {
        let need = crate::budget::bytes(width, height, decoded_bytes + 4 * channels);
        crate::budget::check(|| format!("decoding {width}x{height}"), need).map_err(|source| {
            ImageIoError::Memory {
                path: path.to_path_buf(),
                source,
            }
        })
    }

    /// The same limits for the `image` crate: strict sides, and an allocation budget
    /// of the largest accepted image at 4 channels of 32-bit floats plus slack for
    /// the decoder's own buffers, never more than the memory budget.
    fn for_image_crate(&self) -> image::Limits {
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(self.max_side);
        limits.max_image_height = Some(self.max_side);
        let alloc = self.max_pixels.saturating_mul(16).saturating_add(64 << 20);
        limits.max_alloc = Some(alloc.min(crate::budget::get()));
        limits
    }
}

/// An output file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OutputFormat {
    /// PNG, 8 bits per sample (values clamped to [0, 1]).
    Png8,
    /// PNG, 16 bits per sample (values clamped to [0, 1]).
    Png16,
    /// OpenEXR, 32-bit float samples as they are.
    Exr,
}

impl OutputFormat {
    /// The format a path's extension asks for, with the PNG depth following the
    /// raster's sample format (8-bit sources as 8-bit, 16-bit and float as 16-bit).
    pub fn for_path(path: &Path, format: SampleFormat) -> Option<OutputFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "png" => Some(match format {
                SampleFormat::U8 => OutputFormat::Png8,
                SampleFormat::U16 | SampleFormat::F32 => OutputFormat::Png16,
            }),
            "exr" => Some(OutputFormat::Exr),
            _ => None,
        }
    }

    /// The natural file format for a sample format: PNG at its depth, EXR for float.
    pub fn natural(format: SampleFormat) -> OutputFormat {
        match format {
            SampleFormat::U8 => OutputFormat::Png8,
            SampleFormat::U16 => OutputFormat::Png16,
            SampleFormat::F32 => OutputFormat::Exr,
        }
    }

    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            OutputFormat::Png8 | OutputFormat::Png16 => "png",
            OutputFormat::Exr => "exr",
        }
    }
}

/// Reads an image file with the default limits, its pixels as stored (no EXIF
/// orientation applied: [`load_with_metadata`] turns them upright).
pub fn load(path: &Path) -> Result<Raster, ImageIoError> {
    load_with_limits(path, &LoadLimits::default())
}

/// Reads an image file; the format comes from the file's magic bytes, or from its
/// extension for formats that have none (TGA).
pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Raster, ImageIoError> {
    let io = |source| ImageIoError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = BufReader::new(File::open(path).map_err(io)?);
    let mut magic = [0u8; 4];
    let got = read_up_to(&mut file, &mut magic).map_err(io)?;
    file.rewind().map_err(io)?;
    let by_ext = ImageFormat::from_path(path).ok();
    decode_reader(file, path, &magic[..got], by_ext, limits, 1)
}

/// The metadata of an image file held in memory: JPEG, PNG and WebP as
/// [`crate::metadata::read_container`] reads them, OpenEXR from the attributes
/// [`encode_with_metadata`] writes; other formats give none.
pub fn read_metadata(bytes: &[u8]) -> Result<Metadata, ImageIoError> {
    read_metadata_at(bytes, Path::new("<memory>"))
}

fn read_metadata_at(bytes: &[u8], path: &Path) -> Result<Metadata, ImageIoError> {
    if bytes.starts_with(&EXR_MAGIC) {
        return exr_io::read_metadata(bytes, path);
    }
    crate::metadata::read_container(bytes).map_err(|source| ImageIoError::Metadata {
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
    let (image, meta) = read_oriented(path, limits, false)?;
    Ok((image.into_raster()?, meta))
}

/// Reads a whole file and decodes it upright with its metadata ([`oriented`]).
fn read_oriented(
    path: &Path,
    limits: &LoadLimits,
    compact: bool,
) -> Result<(EncodeSource, Metadata), ImageIoError> {
    let bytes = crate::budget::read(path).map_err(|source| ImageIoError::Io {
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
    let (image, meta) = oriented(bytes, Path::new("<memory>"), None, limits, false)?;
    Ok((image.into_raster()?, meta))
}

/// Decodes an image held in memory upright, with its metadata (EXIF orientation reset
/// to 1); `compact` as in [`load_for_encoding`].
fn oriented(
    bytes: &[u8],
    path: &Path,
    by_ext: Option<ImageFormat>,
    limits: &LoadLimits,
    compact: bool,
) -> Result<(EncodeSource, Metadata), ImageIoError> {
    let mut meta = read_metadata_at(bytes, path)?;
    let mut orientation = 1;
    if let Some(exif) = meta.exif.as_mut() {
        orientation = crate::metadata::orientation(exif)
            .map_err(|source| ImageIoError::Metadata {
                path: path.to_path_buf(),
                source,
            })?
            .unwrap_or(1);
        // `orientation` read the slot, so the reset cannot fail.
        let _ = crate::metadata::reset_orientation(exif);
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
    Ok((image, meta))
}

/// Decodes an image held in memory (format from its magic bytes).
pub fn load_from_memory(bytes: &[u8], limits: &LoadLimits) -> Result<Raster, ImageIoError> {
    let head = &bytes[..bytes.len().min(4)];
    decode_reader(
        Cursor::new(bytes),
        Path::new("<memory>"),
        head,
        None,
        limits,
        1,
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
        return exr_io::read_exr(reader, path, limits).map(EncodeSource::Raster);
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

/// Whether images of this colour type are kept compact for encoding: the integer
/// types [`from_dynamic`] converts.
fn is_compact(c: image::ColorType) -> bool {
    use image::ColorType as C;
    matches!(
        c,
        C::L8 | C::La8 | C::Rgb8 | C::Rgba8 | C::L16 | C::La16 | C::Rgb16 | C::Rgba16
    )
}

/// An image loaded for encoding: integer images as the decoder gave them (1 or 2
/// bytes per sample, converted a tile at a time by the encoder), others as a raster.
#[derive(Debug, Clone)]
pub enum EncodeSource {
    /// An 8- or 16-bit image.
    Compact(DynamicImage),
    /// A float image (or any raster).
    Raster(Raster),
}

/// Reads an image file for encoding, upright, with its metadata: like
/// [`load_with_metadata`], but an integer image stays in its compact decoded form,
/// counted at its own size against the budget.
pub fn load_for_encoding(
    path: &Path,
    limits: &LoadLimits,
) -> Result<(EncodeSource, Metadata), ImageIoError> {
    read_oriented(path, limits, true)
}

impl EncodeSource {
    /// The image as a raster (converted whole).
    pub fn into_raster(self) -> Result<Raster, ImageIoError> {
        match self {
            EncodeSource::Raster(r) => Ok(r),
            EncodeSource::Compact(image) => from_dynamic(image),
        }
    }
}

impl PixelSource for EncodeSource {
    fn width(&self) -> u32 {
        match self {
            EncodeSource::Compact(i) => i.width(),
            EncodeSource::Raster(r) => r.width(),
        }
    }

    fn height(&self) -> u32 {
        match self {
            EncodeSource::Compact(i) => i.height(),
            EncodeSource::Raster(r) => r.height(),
        }
    }

    fn layout(&self) -> ChannelLayout {
        match self {
            EncodeSource::Compact(i) => {
                ChannelLayout::from_channels(i.color().channel_count().into())
                    .expect("compact images have 1 to 4 channels")
            }
            EncodeSource::Raster(r) => r.layout(),
        }
    }

    fn format(&self) -> SampleFormat {
        match self {
            EncodeSource::Compact(i)
                if i.color().bytes_per_pixel() / i.color().channel_count() == 1 =>
            {
                SampleFormat::U8
            }
            EncodeSource::Compact(_) => SampleFormat::U16,
            EncodeSource::Raster(r) => r.format(),
        }
    }

    fn region(&self, rect: TileRect) -> Raster {
        match self {
            EncodeSource::Compact(i) => {
                from_dynamic(i.crop_imm(rect.x0, rect.y0, rect.width, rect.height))
                    .expect("integer samples convert to finite values")
            }
            EncodeSource::Raster(r) => r.region(rect),
        }
    }

    fn held_bytes(&self) -> u64 {
        match self {
            EncodeSource::Compact(i) => i.as_bytes().len() as u64,
            EncodeSource::Raster(r) => r.held_bytes(),
        }
    }
}

/// Runs a third-party decoder, turning a panic inside it into [`ImageIoError::Corrupt`]:
/// a bad file must never bring the program down.
fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T, ImageIoError>) -> Result<T, ImageIoError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        Err(tidy(ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: format!("the decoder failed: {what}"),
        }))
    })
}

/// Sorts an `image` crate error by fault.
/// A third-party decoder's words as one printable line: trimmed, control characters
/// escaped.
fn tidy(e: ImageIoError) -> ImageIoError {
    let line = |r: String| crate::surface::error::printable(r.trim());
    match e {
        ImageIoError::Truncated { path, reason } => ImageIoError::Truncated {
            path,
            reason: line(reason),
        },
        ImageIoError::Corrupt { path, reason } => ImageIoError::Corrupt {
            path,
            reason: line(reason),
        },
        ImageIoError::Unsupported { path, reason } => ImageIoError::Unsupported {
            path,
            reason: line(reason),
        },
        other => other,
    }
}

fn image_error(path: &Path, e: image::ImageError) -> ImageIoError {
    tidy(image_error_words(path, e))
}

fn image_error_words(path: &Path, e: image::ImageError) -> ImageIoError {
    use image::error::{ImageError as E, LimitErrorKind};
    let path = path.to_path_buf();
    match e {
        E::IoError(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => {
            ImageIoError::Truncated {
                path,
                reason: source.to_string(),
            }
        }
        E::IoError(source) => ImageIoError::Io { path, source },
        E::Unsupported(u) => ImageIoError::Unsupported {
            path,
            reason: u.to_string(),
        },
        E::Limits(l) if matches!(l.kind(), LimitErrorKind::DimensionError) => {
            ImageIoError::Corrupt {
                path,
                reason: format!("image dimensions rejected: {l}"),
            }
        }
        E::Limits(l) => ImageIoError::Corrupt {
            path,
            reason: format!("decoding needs more memory than the limits allow: {l}"),
        },
        other => {
            let reason = other.to_string();
            // Decoders report a short file in their own words.
            let lower = reason.to_ascii_lowercase();
            if lower.contains("eof") || lower.contains("end of file") || lower.contains("truncat") {
                ImageIoError::Truncated { path, reason }
            } else {
                ImageIoError::Corrupt { path, reason }
            }
        }
    }
}

/// Converts a decoded `image` crate image, keeping its layout and sample format.
pub fn from_dynamic(image: DynamicImage) -> Result<Raster, ImageIoError> {
    from_dynamic_at(image, Path::new("<memory>"))
}

fn from_dynamic_at(image: DynamicImage, path: &Path) -> Result<Raster, ImageIoError> {
    // Division, not multiplication by the reciprocal: `k / 255` is the correctly
    // rounded value, the one every other part of the project computes.
    const U8: f32 = 255.0;
    const U16: f32 = 65535.0;
    let (w, h) = (image.width(), image.height());
    let (layout, format, samples) = match image {
        DynamicImage::ImageLuma8(b) => (
            ChannelLayout::Grey,
            SampleFormat::U8,
            planar(b.as_raw(), 1, |v| f32::from(v) / U8),
        ),
        DynamicImage::ImageLumaA8(b) => (
            ChannelLayout::GreyAlpha,
            SampleFormat::U8,
            planar(b.as_raw(), 2, |v| f32::from(v) / U8),
        ),
        DynamicImage::ImageRgb8(b) => (
            ChannelLayout::Rgb,
            SampleFormat::U8,
            planar(b.as_raw(), 3, |v| f32::from(v) / U8),
        ),
        DynamicImage::ImageRgba8(b) => (
            ChannelLayout::Rgba,
            SampleFormat::U8,
            planar(b.as_raw(), 4, |v| f32::from(v) / U8),
        ),
        DynamicImage::ImageLuma16(b) => (
            ChannelLayout::Grey,
            SampleFormat::U16,
            planar(b.as_raw(), 1, |v| f32::from(v) / U16),
        ),
        DynamicImage::ImageLumaA16(b) => (
            ChannelLayout::GreyAlpha,
            SampleFormat::U16,
            planar(b.as_raw(), 2, |v| f32::from(v) / U16),
        ),
        DynamicImage::ImageRgb16(b) => (
            ChannelLayout::Rgb,
            SampleFormat::U16,
            planar(b.as_raw(), 3, |v| f32::from(v) / U16),
        ),
        DynamicImage::ImageRgba16(b) => (
            ChannelLayout::Rgba,
            SampleFormat::U16,
            planar(b.as_raw(), 4, |v| f32::from(v) / U16),
        ),
        DynamicImage::ImageRgb32F(b) => (
            ChannelLayout::Rgb,
            SampleFormat::F32,
            planar(b.as_raw(), 3, |v| v),
        ),
        DynamicImage::ImageRgba32F(b) => (
            ChannelLayout::Rgba,
            SampleFormat::F32,
            planar(b.as_raw(), 4, |v| v),
        ),
        other => {
            return Err(ImageIoError::Unsupported {
                path: path.to_path_buf(),
                reason: format!("pixel type {:?}", other.color()),
            })
        }
    };
    raster_or_error(w, h, layout, format, samples, path, &["R", "G", "B", "A"])
}

/// Builds the raster, turning the raster's own checks into file errors.
fn raster_or_error(
    w: u32,
    h: u32,
    layout: ChannelLayout,
    format: SampleFormat,
    samples: Vec<f32>,
    path: &Path,
    names: &[&str],
) -> Result<Raster, ImageIoError> {
    Raster::new(w, h, layout, format, samples).map_err(|e| match e {
        RasterError::Empty { width, height } => ImageIoError::Empty {
            path: path.to_path_buf(),
            width: u64::from(width),
            height: u64::from(height),
        },
        RasterError::NonFinite {
            index,
            channel,
            value,
        } => {
            let i = index % (w as usize * h as usize);
            ImageIoError::NonFinite {
                path: path.to_path_buf(),
                channel: names.get(channel).unwrap_or(&"?").to_string(),
                x: (i % w as usize) as u32,
                y: (i / w as usize) as u32,
                value,
            }
        }
        RasterError::BufferSize { .. } => ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: e.to_string(),
        },
    })
}

/// Interleaved samples to planar `f32`.
fn planar<T: Copy>(interleaved: &[T], channels: usize, f: impl Fn(T) -> f32) -> Vec<f32> {
    let n = interleaved.len() / channels;
    let mut out = vec![0.0; interleaved.len()];
    for (i, px) in interleaved.chunks_exact(channels).enumerate() {
        for (c, &v) in px.iter().enumerate() {
            out[c * n + i] = f(v);
        }
    }
    out
}

/// Integer samples for an 8- or 16-bit output: clamped to [0, 1], rounded.
/// A sample in [0, 1] on an integer scale of `max`, rounded: the one quantiser of
/// every integer output.
pub(crate) fn quantise(v: f32, max: f32) -> f32 {
    (v.clamp(0.0, 1.0) * max).round()
}

/// The raster as an 8-bit `image` crate image (values clamped to [0, 1]).
pub fn to_dynamic8(raster: &Raster) -> DynamicImage {
    let data = interleave(raster, |v| quantise(v, 255.0) as u8);
    let (w, h) = (raster.width(), raster.height());
    // The buffer length matches the dimensions by construction, so `from_raw` succeeds.
    let bad = "interleaved buffer matches the raster's dimensions";
    match raster.layout() {
        ChannelLayout::Grey => {
            DynamicImage::ImageLuma8(image::ImageBuffer::from_raw(w, h, data).expect(bad))
        }
        ChannelLayout::GreyAlpha => {
            DynamicImage::ImageLumaA8(image::ImageBuffer::from_raw(w, h, data).expect(bad))
        }
        ChannelLayout::Rgb => {
            DynamicImage::ImageRgb8(image::ImageBuffer::from_raw(w, h, data).expect(bad))
        }
        ChannelLayout::Rgba => {
            DynamicImage::ImageRgba8(image::ImageBuffer::from_raw(w, h, data).expect(bad))
        }
    }
}

/// Planar raster samples to interleaved values.
fn interleave<T>(raster: &Raster, f: impl Fn(f32) -> T) -> Vec<T> {
    let n = raster.pixel_count();
    let ch = raster.layout().channels();
    let s = raster.samples();
    (0..n * ch).map(|j| f(s[(j % ch) * n + j / ch])).collect()
}

/// Encodes a raster as a file in memory (PNG at [`PngCompression::Fast`]).
pub fn encode(raster: &Raster, format: OutputFormat) -> Result<Vec<u8>, ImageIoError> {
    encode_with(raster, format, PngCompression::default())
}

/// Encodes a raster as a file in memory, PNG at the given compression.
pub fn encode_with(
    raster: &Raster,
    format: OutputFormat,
    png: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    let mem = Path::new("<memory>");
    match format {
        OutputFormat::Png8 | OutputFormat::Png16 => encode_png(raster, format, mem, png),
        OutputFormat::Exr => exr_io::write_exr(raster, mem),
    }
}

/// [`encode_with`] carrying metadata: PNG gets iCCP, eXIf and iTXt (XMP) chunks,
/// OpenEXR gets `iccProfile`, `exif` and `xmp` byte attributes.
pub fn encode_with_metadata(
    raster: &Raster,
    format: OutputFormat,
    png: PngCompression,
    meta: &Metadata,
) -> Result<Vec<u8>, ImageIoError> {
    let mem = Path::new("<memory>");
    match format {
        OutputFormat::Png8 | OutputFormat::Png16 => {
            let mut out = encode_png(raster, format, mem, png)?;
            add_png_metadata(&mut out, meta, mem)?;
            Ok(out)
        }
        OutputFormat::Exr => exr_io::write_exr_with(raster, mem, meta),
    }
}

fn add_png_metadata(png: &mut Vec<u8>, meta: &Metadata, path: &Path) -> Result<(), ImageIoError> {
    if meta.is_empty() {
        return Ok(());
    }
    crate::metadata::insert_png_chunks(png, meta).map_err(|source| ImageIoError::Metadata {
        path: path.to_path_buf(),
        source,
    })
}

/// Estimated memory of [`encode`] beside the raster itself, in bytes: the interleaved
/// samples (twice for 16-bit, which is built through a temporary) and the encoded file,
/// counted at its uncompressed size.
pub fn encode_memory(width: u32, height: u32, channels: usize, format: OutputFormat) -> u64 {
    let per_sample = match format {
        OutputFormat::Png8 => 2,
        OutputFormat::Png16 => 6,
        OutputFormat::Exr => 8,
    };
    crate::budget::bytes(
        u64::from(width) * u64::from(height),
        channels as u64,
        per_sample,
    )
}

fn encode_png(
    raster: &Raster,
    format: OutputFormat,
    path: &Path,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    let sixteen = format == OutputFormat::Png16;
    let color = png_colour(raster.layout(), sixteen);
    let bytes: Vec<u8> = if sixteen {
        // The encoder takes 16-bit samples in native byte order.
        interleave(raster, |v| (quantise(v, 65535.0) as u16).to_ne_bytes())
            .into_iter()
            .flatten()
            .collect()
    } else {
        interleave(raster, |v| quantise(v, 255.0) as u8)
    };
    write_png(&bytes, raster.width(), raster.height(), color, path, level)
}

/// The PNG colour type of a layout at 8 or 16 bits.
fn png_colour(layout: ChannelLayout, sixteen: bool) -> image::ExtendedColorType {
    use image::ExtendedColorType as C;
    match (layout, sixteen) {
        (ChannelLayout::Grey, false) => C::L8,
        (ChannelLayout::GreyAlpha, false) => C::La8,
        (ChannelLayout::Rgb, false) => C::Rgb8,
        (ChannelLayout::Rgba, false) => C::Rgba8,
        (ChannelLayout::Grey, true) => C::L16,
        (ChannelLayout::GreyAlpha, true) => C::La16,
        (ChannelLayout::Rgb, true) => C::Rgb16,
        (ChannelLayout::Rgba, true) => C::Rgba16,
    }
}

/// How hard the PNG writer compresses: speed against file size. Every level is
/// deterministic (single-threaded, fixed settings: the same samples give the same bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PngCompression {
    /// A fast deflate (about as fast as the decode itself); files somewhat larger.
    #[default]
    Fast,
    /// zlib's default level with adaptive filtering.
    Default,
    /// The smallest files, slowest.
    Best,
}

impl PngCompression {
    /// Parses `fast`, `default` or `best`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "fast" => Some(PngCompression::Fast),
            "default" => Some(PngCompression::Default),
            "best" => Some(PngCompression::Best),
            _ => None,
        }
    }
}

fn write_png(
    bytes: &[u8],
    width: u32,
    height: u32,
    color: image::ExtendedColorType,
    path: &Path,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let mut out = Vec::new();
    let (c, f) = match level {
        PngCompression::Fast => (CompressionType::Fast, FilterType::Adaptive),
        PngCompression::Default => (CompressionType::Default, FilterType::Adaptive),
        PngCompression::Best => (CompressionType::Best, FilterType::Adaptive),
    };
    PngEncoder::new_with_quality(&mut out, c, f)
        .write_image(bytes, width, height, color)
        .map_err(|e| ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: format!("PNG encoder: {e}"),
        })?;
    Ok(out)
}

/// Encodes interleaved integer samples (from [`crate::codec::decoder::decode_interleaved`])
/// as a PNG file in memory: the same bytes as [`encode_with`] of the equivalent raster
/// at the same compression.
pub fn encode_png_interleaved(
    image: &crate::codec::decoder::Interleaved,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    use crate::codec::decoder::Samples;
    let sixteen = matches!(image.samples, Samples::U16(_));
    let color = png_colour(image.layout, sixteen);
    let mem = Path::new("<memory>");
    match &image.samples {
        Samples::U8(b) => write_png(b, image.width, image.height, color, mem, level),
        Samples::U16(s) => {
            let bytes: Vec<u8> = s.iter().flat_map(|v| v.to_ne_bytes()).collect();
            write_png(&bytes, image.width, image.height, color, mem, level)
        }
    }
}

/// [`encode_png_interleaved`] carrying metadata (iCCP, eXIf and iTXt XMP chunks).
pub fn encode_png_interleaved_with(
    image: &crate::codec::decoder::Interleaved,
    level: PngCompression,
    meta: &Metadata,
) -> Result<Vec<u8>, ImageIoError> {
    let mut out = encode_png_interleaved(image, level)?;
    add_png_metadata(&mut out, meta, Path::new("<memory>"))?;
    Ok(out)
}

/// Writes a raster with the format its path's extension asks for (`.png`: 8-bit for
/// 8-bit sources, else 16-bit; `.exr`: float).
pub fn save(raster: &Raster, path: &Path) -> Result<(), ImageIoError> {
    let format = OutputFormat::for_path(path, raster.format()).ok_or_else(|| {
        ImageIoError::UnknownOutputFormat {
            path: path.to_path_buf(),
        }
    })?;
    save_as(raster, path, format)
}

/// Writes a raster in an explicit format, whatever the path's extension.
pub fn save_as(raster: &Raster, path: &Path, format: OutputFormat) -> Result<(), ImageIoError> {
    let bytes = match format {
        OutputFormat::Png8 | OutputFormat::Png16 => {
            encode_png(raster, format, path, PngCompression::default())?
        }
        OutputFormat::Exr => exr_io::write_exr(raster, path)?,
    };
    std::fs::write(path, bytes).map_err(|source| ImageIoError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// OpenEXR through the `exr` crate.
mod exr_io {
    use super::*;
    use exr::prelude::traits::*;
    use exr::prelude::{
        AnyChannel, AnyChannels, ChannelDescription, Encoding, FlatSamples, Image, Layer,
        LayerAttributes, MetaData, SmallVec, Text, Vec2,
    };

    /// Which file channel feeds each raster channel.
    struct Plan {
        layout: ChannelLayout,
        /// Index into the layer's (sorted) channel list per raster channel.
        sources: Vec<usize>,
        names: Vec<String>,
    }

    /// A channel's short name: `diffuse.R` is `R`.
    fn short(name: &Text) -> String {
        let s = name.to_string();
        s.rsplit('.').next().unwrap_or(&s).to_string()
    }

    fn plan(channels: &[ChannelDescription], path: &Path) -> Result<Plan, ImageIoError> {
        let find = |want: &str| channels.iter().position(|c| short(&c.name) == want);
        let (r, g, b, y, a) = (find("R"), find("G"), find("B"), find("Y"), find("A"));
        let (layout, sources) = match (r, g, b, y) {
            (Some(r), Some(g), Some(b), _) => match a {
                Some(a) => (ChannelLayout::Rgba, vec![r, g, b, a]),
                None => (ChannelLayout::Rgb, vec![r, g, b]),
            },
            (_, _, _, Some(y)) => match a {
                Some(a) => (ChannelLayout::GreyAlpha, vec![y, a]),
                None => (ChannelLayout::Grey, vec![y]),
            },
            _ => {
                let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
                return Err(ImageIoError::Unsupported {
                    path: path.to_path_buf(),
                    reason: format!("OpenEXR channels {names:?} have no R, G, B or Y"),
                });
            }
        };
        for &i in &sources {
            if channels[i].sampling != Vec2(1, 1) {
                return Err(ImageIoError::Unsupported {
                    path: path.to_path_buf(),
                    reason: format!("subsampled OpenEXR channel {}", channels[i].name),
                });
            }
        }
        let names = sources
            .iter()
            .map(|&i| channels[i].name.to_string())
            .collect();
        Ok(Plan {
            layout,
            sources,
            names,
        })
    }

    fn corrupt(path: &Path, e: exr::error::Error) -> ImageIoError {
        super::tidy(corrupt_words(path, e))
    }

    fn corrupt_words(path: &Path, e: exr::error::Error) -> ImageIoError {
        let path = path.to_path_buf();
        match e {
            exr::error::Error::Io(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => {
                ImageIoError::Truncated {
                    path,
                    reason: source.to_string(),
                }
            }
            exr::error::Error::Io(source) => ImageIoError::Io { path, source },
            exr::error::Error::NotSupported(what) => ImageIoError::Unsupported {
                path,
                reason: format!("OpenEXR feature: {what}"),
            },
            // The exr crate reports a short file as a chunk pointing past the end.
            other if other.to_string().contains("missing bytes") => ImageIoError::Truncated {
                path,
                reason: other.to_string(),
            },
            other => ImageIoError::Corrupt {
                path,
                reason: other.to_string(),
            },
        }
    }

    pub(super) fn read_exr<R: std::io::BufRead + Seek>(
        mut reader: R,
        path: &Path,
        limits: &LoadLimits,
    ) -> Result<Raster, ImageIoError> {
        // The header alone first: check every layer's size before any pixel block is read.
        let meta = guarded(path, || {
            MetaData::read_from_buffered(&mut reader, false).map_err(|e| corrupt(path, e))
        })?;
        let header = meta.headers.first().ok_or_else(|| ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: "OpenEXR file has no layers".into(),
        })?;
        for h in meta.headers.iter() {
            let size = (h.layer_size.0 as u64, h.layer_size.1 as u64);
            limits.check(path, size.0, size.1)?;
            let channels = h.channels.list.len() as u64;
            // Up to 4 bytes a sample as read, and the raster's 4 bytes for each of up
            // to 4 kept channels.
            limits.check_memory(path, size, 4 * channels, channels.min(4))?;
            if h.deep {
                return Err(ImageIoError::Unsupported {
                    path: path.to_path_buf(),
                    reason: "deep OpenEXR data".into(),
                });
            }
        }
        let plan = plan(&header.channels.list, path)?;
        reader.rewind().map_err(|source| ImageIoError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let image = guarded(path, || {
            read()
                .no_deep_data()
                .largest_resolution_level()
                .all_channels()
                .first_valid_layer()
                .all_attributes()
                .non_parallel()
                .from_buffered(reader)
                .map_err(|e| corrupt(path, e))
        })?;
        let layer = &image.layer_data;
        let (w, h) = (layer.size.0, layer.size.1);
        let list = &layer.channel_data.list;
        // The reader sorts channels by name just like the header lists them, but match
        // by name rather than rely on it.
        let mut samples = Vec::with_capacity(w * h * plan.sources.len());
        for name in &plan.names {
            let ch = list
                .iter()
                .find(|c| c.name.to_string() == *name)
                .ok_or_else(|| ImageIoError::Corrupt {
                    path: path.to_path_buf(),
                    reason: format!("channel {name} missing from the pixel data"),
                })?;
            let before = samples.len();
            match &ch.sample_data {
                FlatSamples::F16(v) => samples.extend(v.iter().map(|s| s.to_f32())),
                FlatSamples::F32(v) => samples.extend_from_slice(v),
                FlatSamples::U32(v) => samples.extend(v.iter().map(|&s| s as f32)),
            }
            if samples.len() - before != w * h {
                return Err(ImageIoError::Corrupt {
                    path: path.to_path_buf(),
                    reason: format!("channel {name} holds the wrong number of samples"),
                });
            }
        }
        let names: Vec<&str> = plan.names.iter().map(String::as_str).collect();
        raster_or_error(
            w as u32,
            h as u32,
            plan.layout,
            SampleFormat::F32,
            samples,
            path,
            &names,
        )
    }

    pub(super) fn write_exr(raster: &Raster, path: &Path) -> Result<Vec<u8>, ImageIoError> {
        write_exr_with(raster, path, &Metadata::default())
    }

    /// The layer attributes that carry metadata: untyped bytes with a MIME type hint.
    fn metadata_attributes(meta: &Metadata) -> LayerAttributes {
        use exr::meta::attribute::AttributeValue;
        let mut attributes = LayerAttributes::default();
        for (name, hint, item) in [
            ("iccProfile", "application/vnd.iccprofile", &meta.icc),
            ("exif", "image/tiff", &meta.exif),
            ("xmp", "application/rdf+xml", &meta.xmp),
        ] {
            if let Some(bytes) = item {
                attributes.other.insert(
                    Text::new_or_panic(name),
                    AttributeValue::Bytes {
                        type_hint: Text::new_or_panic(hint),
                        bytes: bytes.as_slice().into(),
                    },
                );
            }
        }
        attributes
    }

    /// The metadata attributes of the first layer's header.
    pub(super) fn read_metadata(bytes: &[u8], path: &Path) -> Result<Metadata, ImageIoError> {
        use exr::meta::attribute::AttributeValue;
        let meta = guarded(path, || {
            MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| corrupt(path, e))
        })?;
        let mut out = Metadata::default();
        let Some(header) = meta.headers.first() else {
            return Ok(out);
        };
        let other = &header.own_attributes.other;
        for (name, item) in [
            ("iccProfile", &mut out.icc),
            ("exif", &mut out.exif),
            ("xmp", &mut out.xmp),
        ] {
            if let Some(AttributeValue::Bytes { bytes, .. }) = other.get(&Text::new_or_panic(name))
            {
                *item = Some(bytes.to_vec());
            }
        }
        out.check_sizes().map_err(|source| ImageIoError::Metadata {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(out)
    }

    pub(super) fn write_exr_with(
        raster: &Raster,
        path: &Path,
        meta: &Metadata,
    ) -> Result<Vec<u8>, ImageIoError> {
        meta.check_sizes()
            .map_err(|source| ImageIoError::Metadata {
                path: path.to_path_buf(),
                source,
            })?;
        let names: &[&str] = match raster.layout() {
            ChannelLayout::Grey => &["Y"],
            ChannelLayout::GreyAlpha => &["Y", "A"],
            ChannelLayout::Rgb => &["R", "G", "B"],
            ChannelLayout::Rgba => &["R", "G", "B", "A"],
        };
        let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
            .iter()
            .enumerate()
            .map(|(c, name)| AnyChannel::new(*name, FlatSamples::F32(raster.plane(c).to_vec())))
            .collect();
        let layer = Layer::new(
            (raster.width() as usize, raster.height() as usize),
            metadata_attributes(meta),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        );
        let mut out = Cursor::new(Vec::new());
        Image::from_layer(layer)
            .write()
            .non_parallel()
            .to_buffered(&mut out)
            .map_err(|e| corrupt(path, e))?;
        Ok(out.into_inner())
    }
}

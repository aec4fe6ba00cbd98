//! Writing: rasters and the decoder's interleaved samples as PNG (8 or 16-bit, with
//! metadata chunks) and OpenEXR.

use std::path::Path;

use super::convert::interleave;
use super::{exr, ImageIoError, OutputFormat};
use caoen_base::metadata::Metadata;
use caoen_base::raster::{quantise, ChannelLayout, Raster};

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
        OutputFormat::Exr => exr::write_exr(raster, mem),
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
        OutputFormat::Exr => exr::write_exr_with(raster, mem, meta),
    }
}

fn add_png_metadata(png: &mut Vec<u8>, meta: &Metadata, path: &Path) -> Result<(), ImageIoError> {
    if meta.is_empty() {
        return Ok(());
    }
    caoen_base::metadata::insert_png_chunks(png, meta).map_err(|source| ImageIoError::Metadata {
        path: path.to_path_buf(),
        source,
    })
}

/// Bytes per sample of a PNG file of `bytes_per_sample` samples while it is made: the
/// deflated attempt (noise does not shrink, and its vector may be half empty), the
/// stored copy the encoder falls back to when deflating did not pay, the file, and the
/// rows each worker filters (6 bounds the peaks of noise decoded on two threads).
pub fn png_file_bytes_per_sample(bytes_per_sample: u64) -> u64 {
    6 * bytes_per_sample
}

/// Estimated memory of [`encode`] beside the raster itself, in bytes: the interleaved
/// samples (twice for 16-bit, which is built through a temporary) and the file as it
/// is made (`png_file_bytes_per_sample`; an EXR at its uncompressed size, its
/// channels as the writer lays them out and its compressed blocks).
pub fn encode_memory(width: u32, height: u32, channels: usize, format: OutputFormat) -> u64 {
    let per_sample = match format {
        OutputFormat::Png8 => 1 + png_file_bytes_per_sample(1),
        OutputFormat::Png16 => 4 + png_file_bytes_per_sample(2),
        OutputFormat::Exr => 12,
    };
    caoen_base::budget::bytes(
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

/// Encodes interleaved integer samples (from [`caoen_decoder::decoder::decode_interleaved`])
/// as a PNG file in memory: the same bytes as [`encode_with`] of the equivalent raster
/// at the same compression.
pub fn encode_png_interleaved(
    image: &caoen_decoder::decoder::Interleaved,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    use caoen_decoder::decoder::Samples;
    let (w, h, layout) = (image.width, image.height, image.layout);
    match &image.samples {
        Samples::U8(b) => encode_png8(b, w, h, layout, level),
        Samples::U16(s) => encode_png16(s, w, h, layout, level),
    }
}

/// Encodes 8-bit interleaved samples of `layout`, `width x height` pixels, as a PNG
/// file in memory.
pub fn encode_png8(
    samples: &[u8],
    width: u32,
    height: u32,
    layout: ChannelLayout,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    let color = png_colour(layout, false);
    write_png(samples, width, height, color, Path::new("<memory>"), level)
}

/// Encodes 16-bit interleaved samples of `layout`, `width x height` pixels, as a PNG
/// file in memory.
pub fn encode_png16(
    samples: &[u16],
    width: u32,
    height: u32,
    layout: ChannelLayout,
    level: PngCompression,
) -> Result<Vec<u8>, ImageIoError> {
    // The encoder takes 16-bit samples in native byte order.
    let bytes: Vec<u8> = samples.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let color = png_colour(layout, true);
    write_png(&bytes, width, height, color, Path::new("<memory>"), level)
}

/// [`encode_png_interleaved`] carrying metadata (iCCP, eXIf and iTXt XMP chunks).
pub fn encode_png_interleaved_with(
    image: &caoen_decoder::decoder::Interleaved,
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
        OutputFormat::Exr => exr::write_exr(raster, path)?,
    };
    std::fs::write(path, bytes).map_err(|source| ImageIoError::Io {
        path: path.to_path_buf(),
        source,
    })
}

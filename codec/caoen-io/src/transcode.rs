//! `.cae` files to image files in one call, as `caoen decode` does it: the file read
//! within the memory limit, the whole job checked against the limit before any of it
//! starts, PNG straight from the decoder's 8- or 16-bit samples where the identity
//! path allows it (no full-size float raster), and the file's metadata carried into
//! the output as the policy keeps it.

use std::io::Read;
use std::path::{Path, PathBuf};

use caoen_base::budget::{self, Limits};
use caoen_base::metadata::{Dropped, Metadata, MetadataPolicy};
use caoen_decoder::bitstream::{self, Header};
use caoen_decoder::decoder::{self, Depth};
use caoen_decoder::{CodecError, DecodeOptions};
use thiserror::Error;

use crate::{write, ImageIoError, OutputFormat, PngCompression};

/// Memory the allocator may hold free beside a job's working set: decoding's freed
/// buffers, kept for reuse while the output file's buffer is mapped on its own.
pub const ALLOCATOR_SLACK: u64 = 32 << 20;

/// Why a `.cae` file could not be turned into an image file.
#[derive(Debug, Error)]
pub enum TranscodeError {
    /// The `.cae` file is bad, or the decode was asked for something it refuses.
    #[error("{}: {source}", path.display())]
    Codec {
        /// The `.cae` file.
        path: PathBuf,
        /// The decoder's error.
        source: CodecError,
    },
    /// The output image could not be made or written.
    #[error(transparent)]
    Image(#[from] ImageIoError),
}

/// Which image format [`decode_to_image`] writes.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FormatChoice {
    /// The file's natural one ([`OutputFormat::natural`]).
    #[default]
    Natural,
    /// This one.
    Exactly(OutputFormat),
    /// The one this path's extension names for the file's samples
    /// ([`OutputFormat::for_path`]).
    ForPath(PathBuf),
}

/// What [`decode_to_image`] makes.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodeToImage {
    /// The decode: size, supersampling, pixel and memory limits.
    pub decode: DecodeOptions,
    /// The output size as a factor of the image's own, where `decode.size` is `None`.
    pub scale: Option<f64>,
    /// The output format.
    pub format: FormatChoice,
    /// PNG compression.
    pub png: PngCompression,
    /// Which of the file's metadata items go into the output.
    pub metadata: MetadataPolicy,
}

impl Default for DecodeToImage {
    fn default() -> Self {
        DecodeToImage {
            decode: DecodeOptions::default(),
            scale: None,
            format: FormatChoice::Natural,
            png: PngCompression::default(),
            metadata: MetadataPolicy::All,
        }
    }
}

/// An image file made from a `.cae` file.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedImage {
    /// The image file's bytes.
    pub bytes: Vec<u8>,
    /// Its format.
    pub format: OutputFormat,
    /// Its width in pixels.
    pub width: u32,
    /// Its height in pixels.
    pub height: u32,
    /// The metadata it carries.
    pub metadata: Metadata,
    /// The items of the file's metadata left out because the image file could not
    /// carry them (a profile of another colour space, an unreadable EXIF block, XMP
    /// that is not UTF-8).
    pub dropped: Vec<Dropped>,
}

/// Reads a `.cae` file from `reader` (`len`: its size where known) within `limits`.
/// The first four bytes are read on their own: a stream that does not start with the
/// magic number is returned as those bytes alone (which the decoder refuses), so
/// `/dev/zero` or an endless pipe is not read any further.
pub fn read_cae(
    mut reader: impl Read,
    len: Option<u64>,
    limits: &Limits,
) -> std::io::Result<Vec<u8>> {
    if let Some(len) = len {
        limits
            .check(|| "reading the file".into(), len)
            .map_err(std::io::Error::other)?;
    }
    let mut head = Vec::with_capacity(bitstream::MAGIC.len());
    (&mut reader)
        .take(bitstream::MAGIC.len() as u64)
        .read_to_end(&mut head)?;
    if head != bitstream::MAGIC {
        return Ok(head);
    }
    let rest = limits.read_all(reader, len.map(|l| l.saturating_sub(head.len() as u64)))?;
    head.extend(rest);
    Ok(head)
}

/// The output size a decode with `opts` makes of a file with `header`.
pub(crate) fn output_size(header: &Header, opts: &DecodeOptions) -> (u32, u32) {
    decoder::requested_size(header, opts)
}

/// The sample depth the identity path can decode to directly for `format`, if any.
pub(crate) fn direct_depth(
    header: &Header,
    opts: &DecodeOptions,
    format: OutputFormat,
) -> Option<Depth> {
    // Supersampling at the coded size is the identity (the decoder skips it).
    let identity =
        opts.supersample.is_none() || opts.size.is_none_or(|s| s == header.display_size());
    match (identity, format) {
        (true, OutputFormat::Png8) => Some(Depth::Eight),
        (true, OutputFormat::Png16) => Some(Depth::Sixteen),
        _ => None,
    }
}

/// Peak memory of decoding a file with `header` into an image file of `format`
/// (`None`: decoding only, to validate), with `metadata_bytes` of metadata copied in.
pub fn decode_to_image_memory(
    header: &Header,
    opts: &DecodeOptions,
    format: Option<OutputFormat>,
    metadata_bytes: u64,
) -> u64 {
    let (ow, oh) = output_size(header, opts);
    let channels = header.layout.channels() as u64;
    let need = match format.and_then(|f| direct_depth(header, opts, f)) {
        Some(d) => {
            let b = if d == Depth::Eight { 1 } else { 2 };
            // The samples, the file as it is made and, for 16 bits, the samples as
            // bytes.
            decoder::decode_memory(header, (ow, oh), None, b).saturating_add(budget::bytes(
                u64::from(ow) * u64::from(oh),
                channels,
                write::png_file_bytes_per_sample(b) + 2 * (b - 1),
            ))
        }
        None => decoder::decode_memory(header, (ow, oh), opts.supersample, 4).saturating_add(
            format.map_or(0, |f| write::encode_memory(ow, oh, channels as usize, f)),
        ),
    };
    // The metadata is copied into the output, and the output once more to make room.
    need.saturating_add(ALLOCATOR_SLACK)
        .saturating_add(2 * metadata_bytes)
}

/// Decodes `cae` (named `name` in messages) into an image file in memory.
pub fn decode_to_image(
    cae: &[u8],
    name: &Path,
    opts: &DecodeToImage,
) -> Result<DecodedImage, TranscodeError> {
    let parsed = bitstream::parse(cae, opts.decode.max_pixels).map_err(codec_error(name))?;
    transcode(&parsed, name, opts)
}

/// The [`TranscodeError`] of a decoder error on the file `name`.
pub(crate) fn codec_error(name: &Path) -> impl Fn(CodecError) -> TranscodeError + '_ {
    move |source| TranscodeError::Codec {
        path: name.to_path_buf(),
        source,
    }
}

/// The decode options of `parsed` written as `format`, with the metadata the policy
/// keeps and the image file can carry (and the items left out), once the memory the
/// whole job needs is known to fit.
pub(crate) fn planned(
    parsed: &bitstream::Parsed<'_>,
    opts: &DecodeToImage,
    format: OutputFormat,
) -> Result<(DecodeOptions, Metadata, Vec<Dropped>), CodecError> {
    let header = &parsed.header;
    let decode = sized(opts, header)?;
    let (metadata, dropped) = parsed
        .metadata()
        .filtered(opts.metadata)
        .fitted(header.layout.colour_channels());
    let need = decode_to_image_memory(header, &decode, Some(format), metadata.bytes());
    let (ow, oh) = output_size(header, &decode);
    decode
        .limits
        .check(|| format!("decoding to {ow}x{oh}"), need)
        .map_err(CodecError::Memory)?;
    Ok((decode, metadata, dropped))
}

/// The decode options with `scale` resolved to a size from the file's `header`.
pub(crate) fn sized(opts: &DecodeToImage, header: &Header) -> Result<DecodeOptions, CodecError> {
    match (opts.decode.size, opts.scale) {
        (None, Some(f)) => {
            if !(f.is_finite() && f > 0.0) {
                return Err(CodecError::Parameter {
                    name: "scale",
                    value: f.to_string(),
                    reason: "a positive number",
                });
            }
            // A region's own size scaled, else the image's.
            let (w, h) = match opts.decode.region {
                Some(r) => (r.x1 - r.x0, r.y1 - r.y0),
                None => {
                    let (w, h) = header.display_size();
                    (f64::from(w), f64::from(h))
                }
            };
            let side = |s: f64| ((s * f).round().min(f64::from(u32::MAX)) as u32).max(1);
            Ok(DecodeOptions {
                size: Some((side(w), side(h))),
                ..opts.decode.clone()
            })
        }
        _ => Ok(opts.decode.clone()),
    }
}

/// [`decode_to_image`] of a file already parsed.
fn transcode(
    parsed: &bitstream::Parsed<'_>,
    name: &Path,
    opts: &DecodeToImage,
) -> Result<DecodedImage, TranscodeError> {
    let codec = codec_error(name);
    let header = &parsed.header;
    let format = match &opts.format {
        FormatChoice::Natural => OutputFormat::natural(header.format),
        FormatChoice::Exactly(f) => *f,
        FormatChoice::ForPath(path) => OutputFormat::for_path(path, header.format)
            .ok_or_else(|| ImageIoError::UnknownOutputFormat { path: path.clone() })?,
    };
    let (decode, metadata, dropped) = planned(parsed, opts, format).map_err(&codec)?;
    let (bytes, (width, height)) = match direct_depth(header, &decode, format) {
        Some(depth) => {
            let img = decoder::decode_interleaved_parsed(parsed, &decode, depth).map_err(&codec)?;
            let size = (img.width, img.height);
            (
                write::encode_png_interleaved_with(&img, opts.png, &metadata)?,
                size,
            )
        }
        None => {
            let img = decoder::decode_parsed(parsed, &decode).map_err(&codec)?;
            let size = (img.width(), img.height());
            (
                write::encode_with_metadata(&img, format, opts.png, &metadata)?,
                size,
            )
        }
    };
    Ok(DecodedImage {
        bytes,
        format,
        width,
        height,
        metadata,
        dropped,
    })
}

/// Decodes `cae` to check it, without making an image file (the format, compression
/// and metadata of `opts` are not used); returns the decoded size.
pub fn validate(
    cae: &[u8],
    name: &Path,
    opts: &DecodeToImage,
) -> Result<(u32, u32), TranscodeError> {
    let codec = codec_error(name);
    let parsed = bitstream::parse(cae, opts.decode.max_pixels).map_err(&codec)?;
    let decode = sized(opts, &parsed.header).map_err(&codec)?;
    let need = decode_to_image_memory(&parsed.header, &decode, None, 0);
    let (ow, oh) = output_size(&parsed.header, &decode);
    decode
        .limits
        .check(|| format!("decoding to {ow}x{oh}"), need)
        .map_err(|e| codec(CodecError::Memory(e)))?;
    let img = decoder::decode_parsed(&parsed, &decode).map_err(&codec)?;
    Ok((img.width(), img.height()))
}

/// Decodes the `.cae` file `input` into the image file `output`, in the format its
/// extension names (`.png`, `.exr`) unless the options name one, with the metadata the
/// policy keeps. An existing
/// `output` is left alone unless `overwrite`.
pub fn decode_file(
    input: &Path,
    output: &Path,
    opts: &DecodeToImage,
    overwrite: bool,
) -> Result<DecodedImage, TranscodeError> {
    let io = |path: &Path, source| {
        TranscodeError::Image(ImageIoError::Io {
            path: path.to_path_buf(),
            source,
        })
    };
    let file = std::fs::File::open(input).map_err(|e| io(input, e))?;
    let len = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    let cae = read_cae(file, len, &opts.decode.limits).map_err(|e| io(input, e))?;
    let parsed = bitstream::parse(&cae, opts.decode.max_pixels).map_err(codec_error(input))?;
    let opts = match opts.format {
        FormatChoice::Natural => DecodeToImage {
            format: FormatChoice::ForPath(output.to_path_buf()),
            ..opts.clone()
        },
        _ => opts.clone(),
    };
    let image = transcode(&parsed, input, &opts)?;
    let mut options = std::fs::OpenOptions::new();
    options.write(true);
    if overwrite {
        options.create(true).truncate(true);
    } else {
        options.create_new(true);
    }
    let mut out = options.open(output).map_err(|e| io(output, e))?;
    std::io::Write::write_all(&mut out, &image.bytes).map_err(|e| io(output, e))?;
    Ok(image)
}

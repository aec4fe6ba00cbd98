//! Images as interleaved arrays in memory, the way array libraries (NumPy) hold them:
//! in to the encoder as the command line's own inputs would be (8- and 16-bit images
//! compact, floats as a raster, so the bytes are the same), and out of a `.cae` file
//! with the samples `caoen decode` writes into its PNG or EXR file.

use std::path::Path;

use caoen_base::metadata::Metadata;
use caoen_base::raster::{quantise, ChannelLayout, Raster, SampleFormat};
use caoen_decoder::bitstream;
use caoen_decoder::decoder::{self, Samples};
use image::{DynamicImage, ImageBuffer};

use crate::convert::{interleave, raster_or_error};
use crate::transcode::{codec_error, direct_depth, planned, DecodeToImage, TranscodeError};
use crate::{load_for_encoding, EncodeSource, ImageIoError, LoadLimits, OutputFormat};

/// Interleaved samples of one of the three sample types.
#[derive(Debug, Clone, PartialEq)]
pub enum PixelData {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
    /// Float samples (linear, any finite value).
    F32(Vec<f32>),
}

impl PixelData {
    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            PixelData::U8(v) => v.len(),
            PixelData::U16(v) => v.len(),
            PixelData::F32(v) => v.len(),
        }
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// An image as interleaved samples, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct Pixels {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channels per pixel: grey, grey and alpha, RGB, RGBA.
    pub layout: ChannelLayout,
    /// The samples, `height * width * channels` of them.
    pub data: PixelData,
}

impl Pixels {
    /// The image as the encoder reads it: 8- and 16-bit samples compact, as an
    /// image file's decoder gives them to `caoen encode`, floats as a raster. Checks
    /// the size and (for floats) that every sample is finite.
    pub fn into_source(self) -> Result<EncodeSource, ImageIoError> {
        let name = Path::new("<array>");
        let (w, h, layout) = (self.width, self.height, self.layout);
        let want = w as usize * h as usize * layout.channels();
        if self.data.len() != want || w == 0 || h == 0 {
            return Err(ImageIoError::Corrupt {
                path: name.to_path_buf(),
                reason: format!(
                    "{w}x{h} pixels of {} channels need {want} samples, got {}",
                    layout.channels(),
                    self.data.len()
                ),
            });
        }
        fn compact<P: image::Pixel>(
            w: u32,
            h: u32,
            data: Vec<P::Subpixel>,
        ) -> ImageBuffer<P, Vec<P::Subpixel>> {
            ImageBuffer::from_raw(w, h, data).expect("the length was checked")
        }
        use ChannelLayout::{Grey, GreyAlpha, Rgb, Rgba};
        let image = match (self.data, layout) {
            (PixelData::U8(d), Grey) => DynamicImage::ImageLuma8(compact(w, h, d)),
            (PixelData::U8(d), GreyAlpha) => DynamicImage::ImageLumaA8(compact(w, h, d)),
            (PixelData::U8(d), Rgb) => DynamicImage::ImageRgb8(compact(w, h, d)),
            (PixelData::U8(d), Rgba) => DynamicImage::ImageRgba8(compact(w, h, d)),
            (PixelData::U16(d), Grey) => DynamicImage::ImageLuma16(compact(w, h, d)),
            (PixelData::U16(d), GreyAlpha) => DynamicImage::ImageLumaA16(compact(w, h, d)),
            (PixelData::U16(d), Rgb) => DynamicImage::ImageRgb16(compact(w, h, d)),
            (PixelData::U16(d), Rgba) => DynamicImage::ImageRgba16(compact(w, h, d)),
            (PixelData::F32(d), _) => {
                let n = w as usize * h as usize;
                let ch = layout.channels();
                let mut planar = vec![0.0; d.len()];
                for (i, px) in d.chunks_exact(ch).enumerate() {
                    for (c, &v) in px.iter().enumerate() {
                        planar[c * n + i] = v;
                    }
                }
                let names = ["R", "G", "B", "A"];
                let raster =
                    raster_or_error(w, h, layout, SampleFormat::F32, planar, name, &names)?;
                return Ok(EncodeSource::Raster(raster));
            }
        };
        Ok(EncodeSource::Compact(image))
    }

    /// The samples of an encoder input, interleaved (a compact image as it is, a
    /// raster with its own sample format).
    pub fn of_source(source: EncodeSource) -> Pixels {
        match source {
            EncodeSource::Compact(image) => {
                use ChannelLayout::{Grey, GreyAlpha, Rgb, Rgba};
                let (width, height) = (image.width(), image.height());
                let (layout, data) = match image {
                    DynamicImage::ImageLuma8(b) => (Grey, PixelData::U8(b.into_raw())),
                    DynamicImage::ImageLumaA8(b) => (GreyAlpha, PixelData::U8(b.into_raw())),
                    DynamicImage::ImageRgb8(b) => (Rgb, PixelData::U8(b.into_raw())),
                    DynamicImage::ImageRgba8(b) => (Rgba, PixelData::U8(b.into_raw())),
                    DynamicImage::ImageLuma16(b) => (Grey, PixelData::U16(b.into_raw())),
                    DynamicImage::ImageLumaA16(b) => (GreyAlpha, PixelData::U16(b.into_raw())),
                    DynamicImage::ImageRgb16(b) => (Rgb, PixelData::U16(b.into_raw())),
                    DynamicImage::ImageRgba16(b) => (Rgba, PixelData::U16(b.into_raw())),
                    // Compact images are the eight integer types above; any other
                    // keeps its samples at 16 bits.
                    other => (Rgba, PixelData::U16(other.to_rgba16().into_raw())),
                };
                Pixels {
                    width,
                    height,
                    layout,
                    data,
                }
            }
            EncodeSource::Raster(r) => Pixels::of_raster(&r, r.format()),
        }
    }

    /// A raster's samples at `format`, quantised as its PNG file would hold them.
    fn of_raster(r: &Raster, format: SampleFormat) -> Pixels {
        let data = match format {
            SampleFormat::U8 => PixelData::U8(interleave(r, |v| quantise(v, 255.0) as u8)),
            SampleFormat::U16 => PixelData::U16(interleave(r, |v| quantise(v, 65535.0) as u16)),
            SampleFormat::F32 => PixelData::F32(interleave(r, |v| v)),
        };
        Pixels {
            width: r.width(),
            height: r.height(),
            layout: r.layout(),
            data,
        }
    }
}

/// Reads an image file as `caoen encode` reads it (upright by its EXIF orientation,
/// which the returned EXIF then says is 1), with its metadata.
pub fn load_pixels(path: &Path, limits: &LoadLimits) -> Result<(Pixels, Metadata), ImageIoError> {
    let (source, meta) = load_for_encoding(path, limits)?;
    Ok((Pixels::of_source(source), meta))
}

/// Decodes `cae` (named `name` in messages) to the samples `caoen decode` with the
/// same options writes into its natural image file (PNG at the file's depth, EXR for
/// float files), with the metadata the policy keeps.
pub fn decode_to_pixels(
    cae: &[u8],
    name: &Path,
    opts: &DecodeToImage,
) -> Result<(Pixels, Metadata), TranscodeError> {
    let codec = codec_error(name);
    let parsed = bitstream::parse(cae, opts.decode.max_pixels).map_err(&codec)?;
    let header = &parsed.header;
    let format = OutputFormat::natural(header.format);
    let (decode, metadata, _) = planned(&parsed, opts, format).map_err(&codec)?;
    let pixels = match direct_depth(header, &decode, format) {
        Some(depth) => {
            let img =
                decoder::decode_interleaved_parsed(&parsed, &decode, depth).map_err(&codec)?;
            Pixels {
                width: img.width,
                height: img.height,
                layout: img.layout,
                data: match img.samples {
                    Samples::U8(v) => PixelData::U8(v),
                    Samples::U16(v) => PixelData::U16(v),
                },
            }
        }
        None => {
            let img = decoder::decode_parsed(&parsed, &decode).map_err(&codec)?;
            Pixels::of_raster(&img, header.format)
        }
    };
    Ok((pixels, metadata))
}

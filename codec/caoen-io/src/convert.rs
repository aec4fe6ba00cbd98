//! Conversion between the `image` crate's images and rasters; images kept compact
//! (1 or 2 bytes per sample) for the encoder, converted a tile at a time.

use std::path::Path;

use image::DynamicImage;

use super::read::read_oriented;
use super::{ImageIoError, LoadLimits};
use caoen_base::metadata::{Dropped, Metadata};
use caoen_base::raster::{quantise, ChannelLayout, Raster, RasterError, SampleFormat};
use caoen_decoder::tiling::TileRect;
use caoen_encoder::PixelSource;

/// Whether images of this colour type are kept compact for encoding: the integer
/// types [`from_dynamic`] converts.
pub(super) fn is_compact(c: image::ColorType) -> bool {
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
/// [`load_with_metadata`](super::load_with_metadata), but an integer image stays in its compact decoded form,
/// counted at its own size against the budget.
pub fn load_for_encoding(
    path: &Path,
    limits: &LoadLimits,
) -> Result<(EncodeSource, Metadata), ImageIoError> {
    read_oriented(path, limits, true).map(|(image, meta, _)| (image, meta))
}

/// [`load_for_encoding`] with the metadata items left out of what it returns (damaged,
/// or not fitting the pixels), for the caller to report.
pub fn load_for_encoding_reporting(
    path: &Path,
    limits: &LoadLimits,
) -> Result<(EncodeSource, Metadata, Vec<Dropped>), ImageIoError> {
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

/// Converts a decoded `image` crate image, keeping its layout and sample format.
pub fn from_dynamic(image: DynamicImage) -> Result<Raster, ImageIoError> {
    from_dynamic_at(image, Path::new("<memory>"))
}

pub(super) fn from_dynamic_at(image: DynamicImage, path: &Path) -> Result<Raster, ImageIoError> {
    use ChannelLayout::{Grey, GreyAlpha, Rgb, Rgba};
    use SampleFormat::{F32, U16, U8};
    // Division, not multiplication by the reciprocal: `k / 255` is the correctly
    // rounded value, the one every other part of the project computes.
    let bytes = |b: &[u8], channels| planar(b, channels, |v| f32::from(v) / 255.0);
    let words = |b: &[u16], channels| planar(b, channels, |v| f32::from(v) / 65535.0);
    let floats = |b: &[f32], channels| planar(b, channels, |v| v);
    let (w, h) = (image.width(), image.height());
    let (layout, format, samples) = match image {
        DynamicImage::ImageLuma8(b) => (Grey, U8, bytes(&b, 1)),
        DynamicImage::ImageLumaA8(b) => (GreyAlpha, U8, bytes(&b, 2)),
        DynamicImage::ImageRgb8(b) => (Rgb, U8, bytes(&b, 3)),
        DynamicImage::ImageRgba8(b) => (Rgba, U8, bytes(&b, 4)),
        DynamicImage::ImageLuma16(b) => (Grey, U16, words(&b, 1)),
        DynamicImage::ImageLumaA16(b) => (GreyAlpha, U16, words(&b, 2)),
        DynamicImage::ImageRgb16(b) => (Rgb, U16, words(&b, 3)),
        DynamicImage::ImageRgba16(b) => (Rgba, U16, words(&b, 4)),
        DynamicImage::ImageRgb32F(b) => (Rgb, F32, floats(&b, 3)),
        DynamicImage::ImageRgba32F(b) => (Rgba, F32, floats(&b, 4)),
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
pub(super) fn raster_or_error(
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

/// The raster as an 8-bit `image` crate image (values clamped to [0, 1]).
pub fn to_dynamic8(raster: &Raster) -> DynamicImage {
    let data = interleave(raster, |v| quantise(v, 255.0) as u8);
    let (w, h) = (raster.width(), raster.height());
    // The buffer length matches the dimensions by construction, so `from_raw` succeeds.
    fn buffer<P: image::Pixel<Subpixel = u8>>(
        w: u32,
        h: u32,
        data: Vec<u8>,
    ) -> image::ImageBuffer<P, Vec<u8>> {
        image::ImageBuffer::from_raw(w, h, data)
            .expect("interleaved buffer matches the raster's dimensions")
    }
    match raster.layout() {
        ChannelLayout::Grey => DynamicImage::ImageLuma8(buffer(w, h, data)),
        ChannelLayout::GreyAlpha => DynamicImage::ImageLumaA8(buffer(w, h, data)),
        ChannelLayout::Rgb => DynamicImage::ImageRgb8(buffer(w, h, data)),
        ChannelLayout::Rgba => DynamicImage::ImageRgba8(buffer(w, h, data)),
    }
}

/// Planar raster samples to interleaved values.
pub(super) fn interleave<T>(raster: &Raster, f: impl Fn(f32) -> T) -> Vec<T> {
    let n = raster.pixel_count();
    let ch = raster.layout().channels();
    let s = raster.samples();
    (0..n * ch).map(|j| f(s[(j % ch) * n + j / ch])).collect()
}

//! The generated image type and its conversions, hashing and file output.

use std::io::{BufWriter, Write};
use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{DynamicImage, ImageBuffer, RgbImage};
use sha2::{Digest, Sha256};

use crate::error::CorpusError;
use crate::math::{clamp01, exp, ln, quantize, srgb_encode};

/// How the samples of a [`CorpusImage`] are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleFormat {
    /// 8-bit unsigned integers (written as 8-bit PNG).
    U8,
    /// 16-bit unsigned integers (written as 16-bit PNG).
    U16,
    /// 32-bit floats, linear light (written as OpenEXR).
    F32,
}

impl SampleFormat {
    /// Bits per sample: 8, 16 or 32.
    pub fn bit_depth(self) -> u8 {
        match self {
            SampleFormat::U8 => 8,
            SampleFormat::U16 => 16,
            SampleFormat::F32 => 32,
        }
    }

    /// File extension used for this format ("png" or "exr").
    pub fn extension(self) -> &'static str {
        match self {
            SampleFormat::F32 => "exr",
            _ => "png",
        }
    }
}

/// Interleaved sample storage, row-major, `channels` samples per pixel.
#[derive(Clone, Debug, PartialEq)]
pub enum PixelData {
    U8(Vec<u8>),
    U16(Vec<u16>),
    F32(Vec<f32>),
}

/// A generated image: 1 (gray), 2 (gray + alpha), 3 (RGB) or 4 (RGBA) channels of
/// 8-bit, 16-bit or float samples. Integer samples are sRGB-encoded display values;
/// float samples are linear scene radiance (RGB or RGBA only).
#[derive(Clone, Debug, PartialEq)]
pub struct CorpusImage {
    width: u32,
    height: u32,
    channels: u8,
    data: PixelData,
}

impl CorpusImage {
    /// Build an image from its parts, checking the invariants.
    pub fn new(
        width: u32,
        height: u32,
        channels: u8,
        data: PixelData,
    ) -> Result<CorpusImage, CorpusError> {
        if width == 0 || height == 0 {
            return Err(CorpusError::InvalidArgument(format!(
                "image size {width}x{height} has a zero side"
            )));
        }
        if !(1..=4).contains(&channels) {
            return Err(CorpusError::InvalidArgument(format!(
                "{channels} channels (must be 1 to 4)"
            )));
        }
        let n = width as usize * height as usize * channels as usize;
        let len = match &data {
            PixelData::U8(v) => v.len(),
            PixelData::U16(v) => v.len(),
            PixelData::F32(v) => v.len(),
        };
        if len != n {
            return Err(CorpusError::InvalidArgument(format!(
                "{len} samples for a {width}x{height}x{channels} image (expected {n})"
            )));
        }
        if matches!(data, PixelData::F32(_)) && channels < 3 {
            return Err(CorpusError::InvalidArgument(
                "float images must have 3 or 4 channels".into(),
            ));
        }
        Ok(CorpusImage {
            width,
            height,
            channels,
            data,
        })
    }

    pub(crate) fn from_parts(
        width: u32,
        height: u32,
        channels: u8,
        data: PixelData,
    ) -> CorpusImage {
        CorpusImage::new(width, height, channels, data)
            .expect("generator produced an inconsistent image")
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Samples per pixel: 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA.
    pub fn channels(&self) -> u8 {
        self.channels
    }
    pub fn data(&self) -> &PixelData {
        &self.data
    }
    pub fn into_data(self) -> PixelData {
        self.data
    }
    pub fn sample_format(&self) -> SampleFormat {
        match self.data {
            PixelData::U8(_) => SampleFormat::U8,
            PixelData::U16(_) => SampleFormat::U16,
            PixelData::F32(_) => SampleFormat::F32,
        }
    }
    /// 8, 16 or 32 (float).
    pub fn bit_depth(&self) -> u8 {
        self.sample_format().bit_depth()
    }
    /// True if the last channel is alpha (2 or 4 channels).
    pub fn has_alpha(&self) -> bool {
        self.channels == 2 || self.channels == 4
    }

    /// Sample `c` of pixel `(x, y)`: integer formats are normalised to `[0, 1]`,
    /// floats are returned as stored.
    pub fn sample(&self, x: u32, y: u32, c: u8) -> f32 {
        let i =
            (y as usize * self.width as usize + x as usize) * self.channels as usize + c as usize;
        match &self.data {
            PixelData::U8(v) => v[i] as f32 / 255.0,
            PixelData::U16(v) => v[i] as f32 / 65535.0,
            PixelData::F32(v) => v[i],
        }
    }

    /// One channel as f64 values (same scaling as [`CorpusImage::sample`]), row-major.
    pub fn plane(&self, c: u8) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height {
            for x in 0..self.width {
                out.push(self.sample(x, y, c) as f64);
            }
        }
        out
    }

    /// Rec. 709 luma of the colour channels (or the gray channel), row-major,
    /// in the same scaling as [`CorpusImage::sample`].
    pub fn luma_plane(&self) -> Vec<f64> {
        if self.channels < 3 {
            return self.plane(0);
        }
        let (r, g, b) = (self.plane(0), self.plane(1), self.plane(2));
        r.iter()
            .zip(&g)
            .zip(&b)
            .map(|((r, g), b)| 0.2126 * r + 0.7152 * g + 0.0722 * b)
            .collect()
    }

    /// The canonical byte serialisation of the samples that the content hash covers:
    /// row-major interleaved samples; 8-bit as is, 16-bit big-endian (as in PNG),
    /// float as IEEE-754 binary32 little-endian.
    pub fn pixel_bytes(&self) -> Vec<u8> {
        match &self.data {
            PixelData::U8(v) => v.clone(),
            PixelData::U16(v) => v.iter().flat_map(|s| s.to_be_bytes()).collect(),
            PixelData::F32(v) => v.iter().flat_map(|s| s.to_bits().to_le_bytes()).collect(),
        }
    }

    /// Lower-case hex SHA-256 of [`CorpusImage::pixel_bytes`].
    pub fn sha256(&self) -> String {
        let digest = Sha256::digest(self.pixel_bytes());
        digest.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// The image as an `image::DynamicImage` (gray, gray-alpha, RGB or RGBA; 8-bit,
    /// 16-bit, or 32-bit float RGB/RGBA).
    pub fn to_dynamic_image(&self) -> DynamicImage {
        fn buffer<P: image::Pixel>(
            w: u32,
            h: u32,
            v: &[P::Subpixel],
        ) -> ImageBuffer<P, Vec<P::Subpixel>> {
            ImageBuffer::from_raw(w, h, v.to_vec())
                .expect("buffer length checked in CorpusImage::new")
        }
        let (w, h) = (self.width, self.height);
        match (&self.data, self.channels) {
            (PixelData::U8(v), 1) => DynamicImage::ImageLuma8(buffer(w, h, v)),
            (PixelData::U8(v), 2) => DynamicImage::ImageLumaA8(buffer(w, h, v)),
            (PixelData::U8(v), 3) => DynamicImage::ImageRgb8(buffer(w, h, v)),
            (PixelData::U8(v), _) => DynamicImage::ImageRgba8(buffer(w, h, v)),
            (PixelData::U16(v), 1) => DynamicImage::ImageLuma16(buffer(w, h, v)),
            (PixelData::U16(v), 2) => DynamicImage::ImageLumaA16(buffer(w, h, v)),
            (PixelData::U16(v), 3) => DynamicImage::ImageRgb16(buffer(w, h, v)),
            (PixelData::U16(v), _) => DynamicImage::ImageRgba16(buffer(w, h, v)),
            (PixelData::F32(v), 3) => DynamicImage::ImageRgb32F(buffer(w, h, v)),
            (PixelData::F32(v), _) => DynamicImage::ImageRgba32F(buffer(w, h, v)),
        }
    }

    /// An 8-bit RGB rendition for viewing: gray is expanded, alpha is composited
    /// over a light/dark checkerboard, float (HDR) images are tone-mapped
    /// (Reinhard on luminance, exposure from the log-average, then sRGB).
    pub fn preview_rgb8(&self) -> RgbImage {
        let (w, h) = (self.width, self.height);
        let mut out = RgbImage::new(w, h);
        let key = if self.sample_format() == SampleFormat::F32 {
            self.log_average_luminance()
        } else {
            1.0
        };
        let scale = 0.18 / key.max(1e-9);
        for y in 0..h {
            for x in 0..w {
                let px = match self.sample_format() {
                    SampleFormat::F32 => {
                        let (r, g, b) = (
                            self.sample(x, y, 0) as f64,
                            self.sample(x, y, 1) as f64,
                            self.sample(x, y, 2) as f64,
                        );
                        let l = (0.2126 * r + 0.7152 * g + 0.0722 * b).max(1e-12);
                        let ls = l * scale;
                        let m = ls / (1.0 + ls) / l;
                        [r * m, g * m, b * m].map(|v| quantize(srgb_encode(v), 255) as u8)
                    }
                    _ => {
                        let c = |k: u8| self.sample(x, y, k) as f64;
                        let (mut r, mut g, mut b) = if self.channels < 3 {
                            (c(0), c(0), c(0))
                        } else {
                            (c(0), c(1), c(2))
                        };
                        if self.has_alpha() {
                            let a = c(self.channels - 1);
                            let bg = if ((x / 8) + (y / 8)) % 2 == 0 {
                                0.8
                            } else {
                                0.55
                            };
                            r = r * a + bg * (1.0 - a);
                            g = g * a + bg * (1.0 - a);
                            b = b * a + bg * (1.0 - a);
                        }
                        [r, g, b].map(|v| quantize(clamp01(v), 255) as u8)
                    }
                };
                out.put_pixel(x, y, image::Rgb(px));
            }
        }
        out
    }

    /// Geometric mean of the luminance (floats only meaningful for HDR images).
    fn log_average_luminance(&self) -> f64 {
        let l = self.luma_plane();
        let s: f64 = l.iter().map(|&v| ln(v.max(1e-9))).sum();
        exp(s / l.len() as f64)
    }

    /// File extension for [`CorpusImage::save`]: "png" or "exr".
    pub fn extension(&self) -> &'static str {
        self.sample_format().extension()
    }

    /// Write as PNG (integer formats) or OpenEXR (float, ZIP-compressed scanlines).
    /// The encoders run single-threaded, so the file bytes are reproducible too.
    pub fn save(&self, path: &Path) -> Result<(), CorpusError> {
        match &self.data {
            PixelData::F32(v) => self.save_exr(path, v),
            _ => {
                let file = std::fs::File::create(path).map_err(|e| CorpusError::io(path, e))?;
                let mut wr = BufWriter::new(file);
                let enc = PngEncoder::new_with_quality(
                    &mut wr,
                    CompressionType::Default,
                    FilterType::Adaptive,
                );
                self.to_dynamic_image()
                    .write_with_encoder(enc)
                    .map_err(|source| CorpusError::Png {
                        path: path.to_path_buf(),
                        source,
                    })?;
                wr.flush().map_err(|e| CorpusError::io(path, e))
            }
        }
    }

    fn save_exr(&self, path: &Path, v: &[f32]) -> Result<(), CorpusError> {
        use exr::image::write::layers::WritableLayers;
        use exr::prelude::*;
        /// Writes the image as ZIP-compressed scanlines on this thread.
        fn write<'i, L: WritableLayers<'i>>(
            image: &'i Image<L>,
            path: &Path,
        ) -> exr::error::UnitResult {
            image.write().non_parallel().to_file(path)
        }
        let w = self.width as usize;
        let (size, encoding) = ((w, self.height as usize), Encoding::SMALL_LOSSLESS);
        let written = if self.channels == 3 {
            let pixels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
                let i = (y * w + x) * 3;
                (v[i], v[i + 1], v[i + 2])
            });
            write(&Image::from_encoded_channels(size, encoding, pixels), path)
        } else {
            let pixels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
                let i = (y * w + x) * 4;
                (v[i], v[i + 1], v[i + 2], v[i + 3])
            });
            write(&Image::from_encoded_channels(size, encoding, pixels), path)
        };
        written.map_err(|source| CorpusError::Exr {
            path: path.to_path_buf(),
            source,
        })
    }
}

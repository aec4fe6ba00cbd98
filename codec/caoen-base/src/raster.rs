//! In-memory images: planar `f32` samples with their channel layout and the sample
//! format they came from, shared by the codec, the metrics and the texture tools.

use thiserror::Error;

/// Channel layout of an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ChannelLayout {
    /// One luminance channel.
    Grey,
    /// Luminance and alpha.
    GreyAlpha,
    /// Red, green, blue.
    Rgb,
    /// Red, green, blue, alpha.
    Rgba,
}

impl ChannelLayout {
    /// Number of channels.
    pub fn channels(self) -> usize {
        match self {
            ChannelLayout::Grey => 1,
            ChannelLayout::GreyAlpha => 2,
            ChannelLayout::Rgb => 3,
            ChannelLayout::Rgba => 4,
        }
    }

    /// Whether the last channel is alpha.
    pub fn has_alpha(self) -> bool {
        matches!(self, ChannelLayout::GreyAlpha | ChannelLayout::Rgba)
    }

    /// Number of colour (non-alpha) channels.
    pub fn colour_channels(self) -> usize {
        self.channels() - usize::from(self.has_alpha())
    }

    /// The layout with `n` channels (1 to 4), if any.
    pub fn from_channels(n: usize) -> Option<Self> {
        Some(match n {
            1 => ChannelLayout::Grey,
            2 => ChannelLayout::GreyAlpha,
            3 => ChannelLayout::Rgb,
            4 => ChannelLayout::Rgba,
            _ => return None,
        })
    }
}

/// How samples were stored in the source file, which decides how they are written back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SampleFormat {
    /// 8-bit integers; samples are normalised to [0, 1].
    U8,
    /// 16-bit integers; samples are normalised to [0, 1].
    U16,
    /// Floating point (HDR, from OpenEXR); samples are linear values of any finite size.
    F32,
}

/// Why a raster could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RasterError {
    /// Width or height is zero.
    #[error("empty image: {width}x{height}")]
    Empty {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The sample buffer does not match the dimensions.
    #[error("sample buffer holds {got} values, {width}x{height}x{channels} needs {expected}")]
    BufferSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Channel count.
        channels: usize,
        /// Required length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A sample is NaN or infinite.
    #[error("sample {index} (channel {channel}) is not finite: {value}")]
    NonFinite {
        /// Flat index into the planar buffer.
        index: usize,
        /// The channel it belongs to.
        channel: usize,
        /// The value.
        value: f32,
    },
}

/// A planar image: `samples[c * width * height + y * width + x]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    width: u32,
    height: u32,
    layout: ChannelLayout,
    format: SampleFormat,
    samples: Vec<f32>,
}

impl Raster {
    /// Builds a raster, checking dimensions and that every sample is finite.
    pub fn new(
        width: u32,
        height: u32,
        layout: ChannelLayout,
        format: SampleFormat,
        samples: Vec<f32>,
    ) -> Result<Self, RasterError> {
        Self::check_size(width, height, layout, samples.len())?;
        let plane = width as usize * height as usize;
        // Chunked so the common, all-finite case vectorises; the search below only runs
        // when something is wrong.
        let finite = samples
            .chunks(1024)
            .all(|c| c.iter().fold(true, |ok, v| ok & v.is_finite()));
        if let Some(index) = (!finite)
            .then(|| samples.iter().position(|v| !v.is_finite()))
            .flatten()
        {
            return Err(RasterError::NonFinite {
                index,
                channel: index / plane,
                value: samples[index],
            });
        }
        Ok(Raster {
            width,
            height,
            layout,
            format,
            samples,
        })
    }

    /// Non-empty dimensions and a buffer of exactly one sample per pixel and channel.
    fn check_size(
        width: u32,
        height: u32,
        layout: ChannelLayout,
        got: usize,
    ) -> Result<(), RasterError> {
        if width == 0 || height == 0 {
            return Err(RasterError::Empty { width, height });
        }
        let expected = width as usize * height as usize * layout.channels();
        if got != expected {
            return Err(RasterError::BufferSize {
                width,
                height,
                channels: layout.channels(),
                expected,
                got,
            });
        }
        Ok(())
    }

    /// Builds a raster from samples whose producer has already checked them finite
    /// (the decoder checks each band while it is in cache); the sizes are still checked.
    pub fn from_finite(
        width: u32,
        height: u32,
        layout: ChannelLayout,
        format: SampleFormat,
        samples: Vec<f32>,
    ) -> Result<Self, RasterError> {
        debug_assert!(samples.iter().all(|v| v.is_finite()));
        Self::check_size(width, height, layout, samples.len())?;
        Ok(Raster {
            width,
            height,
            layout,
            format,
            samples,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Channel layout.
    pub fn layout(&self) -> ChannelLayout {
        self.layout
    }

    /// Source sample format.
    pub fn format(&self) -> SampleFormat {
        self.format
    }

    /// All samples, planar.
    pub fn samples(&self) -> &[f32] {
        &self.samples
    }

    /// One channel's plane, row-major.
    pub fn plane(&self, c: usize) -> &[f32] {
        let n = self.pixel_count();
        &self.samples[c * n..(c + 1) * n]
    }

    /// Consumes the raster, returning its samples.
    pub fn into_samples(self) -> Vec<f32> {
        self.samples
    }

    /// The same pixels stored as another sample format (decides how they are written).
    pub fn with_format(self, format: SampleFormat) -> Self {
        Raster { format, ..self }
    }
}

/// A sample in [0, 1] on an integer scale of `max`, rounded: the one quantiser of
/// every 8- and 16-bit output (files and the decoder's interleaved samples alike).
pub fn quantise(v: f32, max: f32) -> f32 {
    (v.clamp(0.0, 1.0) * max).round()
}

//! Image files in and out of a [`Raster`](caoen_base::raster::Raster): everything the `image` crate reads (PNG,
//! JPEG, BMP, GIF, TIFF, WebP, PNM, TGA, QOI, Radiance HDR; 8/16-bit, grey, grey+alpha,
//! RGB, RGBA) and OpenEXR (float, through the `exr` crate); PNG (8 or 16-bit) and
//! OpenEXR (32-bit float) out; and `.cae` files read by the `image` crate itself once
//! [`register_image_hooks`] has run.
//!
//! Reading checks the header's dimensions against [`LoadLimits`] before any pixel
//! buffer is allocated, so a hostile header cannot make us allocate gigabytes, and
//! every decoder failure becomes an [`ImageIoError`], never a panic.

mod convert;
mod error;
mod exr;
mod hooks;
mod pixels;
mod read;
pub mod transcode;
mod write;

pub use convert::{
    from_dynamic, load_for_encoding, load_for_encoding_reporting, to_dynamic8, EncodeSource,
};
pub use error::ImageIoError;
pub use hooks::{register_image_hooks, CaeDecoder};
pub use pixels::{decode_to_pixels, load_pixels, PixelData, Pixels};
pub use read::{
    load, load_from_memory, load_from_memory_with_metadata, load_with_limits, load_with_metadata,
    read_metadata,
};
pub use transcode::{
    decode_file, decode_to_image, DecodeToImage, DecodedImage, FormatChoice, TranscodeError,
};
pub use write::{
    encode, encode_memory, encode_png16, encode_png8, encode_png_interleaved,
    encode_png_interleaved_with, encode_with, encode_with_metadata, save, save_as, PngCompression,
};

use std::path::Path;

use caoen_base::budget::Limits;
use caoen_base::raster::SampleFormat;

/// Default limit on either side, matching the codec's [`caoen_decoder::MAX_SIDE`].
pub const DEFAULT_MAX_SIDE: u32 = caoen_decoder::MAX_SIDE;
/// Default limit on pixels of images read as textures, slices and references (2^26);
/// the encoder reads up to [`caoen_decoder::DEFAULT_MAX_PIXELS`].
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 26;

/// The four bytes every OpenEXR file starts with.
pub const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Size limits checked against an image's header before its pixels are decoded, and
/// the memory limit the decode is checked against.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadLimits {
    /// Largest accepted width or height.
    pub max_side: u32,
    /// Largest accepted `width * height`.
    pub max_pixels: u64,
    /// The memory the load may take (with what its job already holds).
    pub memory: Limits,
}

impl Default for LoadLimits {
    fn default() -> Self {
        LoadLimits {
            max_side: DEFAULT_MAX_SIDE,
            max_pixels: DEFAULT_MAX_PIXELS,
            memory: Limits::default(),
        }
    }
}

impl LoadLimits {
    /// The default sizes within the memory limit `memory`.
    pub fn within(memory: &Limits) -> Self {
        LoadLimits {
            memory: memory.clone(),
            ..LoadLimits::default()
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
        let need = caoen_base::budget::bytes(width, height, decoded_bytes + 4 * channels);
        self.memory
            .check(|| format!("decoding {width}x{height}"), need)
            .map_err(|source| ImageIoError::Memory {
                path: path.to_path_buf(),
                source,
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
        limits.max_alloc = Some(alloc.min(self.memory.max_memory));
        limits
    }
}

/// Whether `caoen encode` reads a file by its name: the extension of a format the
/// `image` crate was built to read, or OpenEXR (`.cae` files are not inputs).
pub fn is_image_name(path: &Path) -> bool {
    let Some(ext) = path.extension().and_then(|e| e.to_str()) else {
        return false;
    };
    let ext = ext.to_ascii_lowercase();
    ext == "exr" || image::ImageFormat::from_extension(&ext).is_some_and(|f| f.reading_enabled())
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

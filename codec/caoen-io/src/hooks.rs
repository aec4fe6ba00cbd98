//! `.cae` files for the `image` crate: an [`image::ImageDecoder`] and the hooks that let
//! `image::open` read them in any program after one call to [`register_image_hooks`].

use std::io::Read;

use image::error::{
    DecodingError, ImageFormatHint, LimitError, LimitErrorKind, ParameterError, ParameterErrorKind,
};
use image::{ColorType, ImageDecoder, ImageError, ImageResult};

use caoen_base::metadata::Metadata;
use caoen_base::raster::{ChannelLayout, SampleFormat};
use caoen_decoder::bitstream::{Header, MAGIC};
use caoen_decoder::decoder::{decode_interleaved, Depth, Samples};
use caoen_decoder::{decode, inspect, CodecError, DecodeOptions};

/// The extension the hooks register, as the `image` crate names formats by it.
const EXTENSION: &str = "cae";

/// Registers `.cae` with the `image` crate: the extension and the magic bytes, so that
/// `image::open("photo.cae")` and format guessing read caoen files. Returns `false`
/// when a decoding hook for the extension was already registered (by an earlier call
/// or by someone else); calling it again is harmless.
pub fn register_image_hooks() -> bool {
    let fresh = image::hooks::register_decoding_hook(
        EXTENSION.into(),
        Box::new(|reader| Ok(Box::new(CaeDecoder::new(reader)?))),
    );
    // The detection hooks are a list, not a map: only the call that registered the
    // decoder adds the signature, so repeated calls do not grow it.
    if fresh {
        image::hooks::register_format_detection_hook(EXTENSION.into(), &MAGIC, None);
    }
    fresh
}

/// A `.cae` file as an [`image::ImageDecoder`]: decoded at its coded size, 8- and 16-bit
/// images in their own depth and channels (the samples `caoen decode` writes to PNG),
/// float images as 32-bit float RGB or RGBA.
#[derive(Debug)]
pub struct CaeDecoder {
    bytes: Vec<u8>,
    header: Header,
    metadata: Metadata,
    options: DecodeOptions,
}

impl CaeDecoder {
    /// Reads a whole `.cae` file (counted against the memory budget) and checks its
    /// container; the pixels are decoded by `read_image`.
    pub fn new(mut reader: impl Read) -> ImageResult<CaeDecoder> {
        let bytes = caoen_base::budget::Limits::default()
            .read_all(&mut reader, None)
            .map_err(ImageError::IoError)?;
        let parsed = inspect(&bytes).map_err(image_error)?;
        let (header, metadata) = (parsed.header.clone(), parsed.metadata());
        Ok(CaeDecoder {
            bytes,
            header,
            metadata,
            options: DecodeOptions::default(),
        })
    }

    /// Decodes with these options' limits (the output size is always the coded size).
    pub fn with_options(mut self, options: DecodeOptions) -> CaeDecoder {
        self.options = DecodeOptions {
            size: None,
            supersample: None,
            region: None,
            ..options
        };
        self
    }
}

/// A codec error in the `image` crate's terms: limits as limits, the rest as a
/// decoding error with the codec's error as its source.
fn image_error(e: CodecError) -> ImageError {
    match e {
        CodecError::Memory(_) => {
            ImageError::Limits(LimitError::from_kind(LimitErrorKind::InsufficientMemory))
        }
        CodecError::Limit { .. } => {
            ImageError::Limits(LimitError::from_kind(LimitErrorKind::DimensionError))
        }
        e => ImageError::Decoding(DecodingError::new(
            ImageFormatHint::Name(EXTENSION.into()),
            e,
        )),
    }
}

impl ImageDecoder for CaeDecoder {
    fn dimensions(&self) -> (u32, u32) {
        self.header.display_size()
    }

    fn color_type(&self) -> ColorType {
        use ChannelLayout as L;
        match (self.header.format, self.header.layout) {
            (SampleFormat::U8, L::Grey) => ColorType::L8,
            (SampleFormat::U8, L::GreyAlpha) => ColorType::La8,
            (SampleFormat::U8, L::Rgb) => ColorType::Rgb8,
            (SampleFormat::U8, L::Rgba) => ColorType::Rgba8,
            (SampleFormat::U16, L::Grey) => ColorType::L16,
            (SampleFormat::U16, L::GreyAlpha) => ColorType::La16,
            (SampleFormat::U16, L::Rgb) => ColorType::Rgb16,
            (SampleFormat::U16, L::Rgba) => ColorType::Rgba16,
            // The `image` crate has no grey float type: grey repeats into RGB.
            (SampleFormat::F32, L::Grey | L::Rgb) => ColorType::Rgb32F,
            (SampleFormat::F32, L::GreyAlpha | L::Rgba) => ColorType::Rgba32F,
        }
    }

    fn icc_profile(&mut self) -> ImageResult<Option<Vec<u8>>> {
        Ok(self.metadata.icc.clone())
    }

    fn exif_metadata(&mut self) -> ImageResult<Option<Vec<u8>>> {
        Ok(self.metadata.exif.clone())
    }

    fn xmp_metadata(&mut self) -> ImageResult<Option<Vec<u8>>> {
        Ok(self.metadata.xmp.clone())
    }

    fn read_image(self, buf: &mut [u8]) -> ImageResult<()> {
        if buf.len() as u64 != self.total_bytes() {
            return Err(ImageError::Parameter(ParameterError::from_kind(
                ParameterErrorKind::DimensionMismatch,
            )));
        }
        let depth = match self.header.format {
            SampleFormat::U8 => Some(Depth::Eight),
            SampleFormat::U16 => Some(Depth::Sixteen),
            SampleFormat::F32 => None,
        };
        if let Some(depth) = depth {
            let image =
                decode_interleaved(&self.bytes, &self.options, depth).map_err(image_error)?;
            match image.samples {
                Samples::U8(s) => buf.copy_from_slice(&s),
                Samples::U16(s) => {
                    for (out, v) in buf.chunks_exact_mut(2).zip(s) {
                        out.copy_from_slice(&v.to_ne_bytes());
                    }
                }
            }
            return Ok(());
        }
        let raster = decode(&self.bytes, &self.options).map_err(image_error)?;
        let n = raster.pixel_count();
        let planes: Vec<&[f32]> = (0..raster.layout().channels())
            .map(|c| raster.plane(c))
            .collect();
        // Output channel -> raster plane: grey repeats into R, G and B.
        let sources: &[usize] = match raster.layout() {
            ChannelLayout::Grey => &[0, 0, 0],
            ChannelLayout::GreyAlpha => &[0, 0, 0, 1],
            ChannelLayout::Rgb => &[0, 1, 2],
            ChannelLayout::Rgba => &[0, 1, 2, 3],
        };
        let planes = &planes;
        let samples = (0..n).flat_map(|i| sources.iter().map(move |&c| planes[c][i]));
        for (out, v) in buf.chunks_exact_mut(4).zip(samples) {
            out.copy_from_slice(&v.to_ne_bytes());
        }
        Ok(())
    }

    fn read_image_boxed(self: Box<Self>, buf: &mut [u8]) -> ImageResult<()> {
        (*self).read_image(buf)
    }
}

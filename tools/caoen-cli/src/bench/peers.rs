//! Peer codecs (feature `peers`): real libraries, each decoded by its own decoder.
//!
//! - `jpeg`: libjpeg-turbo behaviour through the mozjpeg library in its "fastest"
//!   profile (`jpeg_set_defaults` of libjpeg 6b: baseline, 4:2:0), with optimised
//!   Huffman tables: what `cjpeg -optimize` or Pillow's `optimize=True` write. The
//!   reference JPEG of the design notes.
//! - `mozjpeg`: mozjpeg's own defaults (trellis quantisation, progressive, optimised
//!   scans): the strongest classic JPEG encoder.
//! - `jpeg-image`: the `image` crate's pure-Rust encoder, decoded by its decoder.
//! - `webp`: libwebp, lossy, method 6 (slowest, best), quality knob.
//!
//! All take 8-bit input: 16-bit images are rounded to 8 bits (the error counts
//! against the codec), float images are skipped. JPEG has no alpha, so images with
//! alpha are skipped for the JPEG peers.

use caoen::raster::Raster;

use super::codecs::{eight_bit_only, interleaved_u8, raster_from_u8, Codec, Setting};

/// The peer called `name` (one of [`super::codecs::PEER_NAMES`]).
pub fn by_name(name: &str) -> Option<Box<dyn Codec>> {
    Some(match name {
        "jpeg" => Box::new(Jpeg(JpegLibrary::Turbo)),
        "mozjpeg" => Box::new(Jpeg(JpegLibrary::Moz)),
        "jpeg-image" => Box::new(Jpeg(JpegLibrary::Image)),
        "webp" => Box::new(WebP),
        _ => return None,
    })
}

fn quality_of(setting: Setting) -> Result<f32, String> {
    match setting {
        Setting::Quality(q) => Ok(q.clamp(0.0, 100.0)),
        Setting::Bpp(_) => Err("no native rate control".into()),
    }
}

fn no_alpha(image: &Raster) -> Result<(), String> {
    eight_bit_only(image)?;
    if image.layout().has_alpha() {
        Err("JPEG has no alpha channel".into())
    } else {
        Ok(())
    }
}

/// Runs C library code whose errors unwind (mozjpeg's error manager panics),
/// turning a panic into an error.
fn guarded<T>(what: &str, f: impl FnOnce() -> std::io::Result<T>) -> Result<T, String> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(format!("{what}: {e}")),
        Err(p) => Err(format!(
            "{what} failed: {}",
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "library error".into())
        )),
    }
}

const JPEG_QUALITIES: [f32; 8] = [5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0];

/// The library that writes and reads a JPEG peer's files.
#[derive(Clone, Copy, PartialEq, Eq)]
enum JpegLibrary {
    /// mozjpeg with libjpeg-turbo-compatible settings (its "fastest" profile).
    Turbo,
    /// mozjpeg with its own defaults.
    Moz,
    /// The `image` crate.
    Image,
}

/// JPEG through one of the libraries.
struct Jpeg(JpegLibrary);

impl Codec for Jpeg {
    fn name(&self) -> &'static str {
        match self.0 {
            JpegLibrary::Turbo => "jpeg",
            JpegLibrary::Moz => "mozjpeg",
            JpegLibrary::Image => "jpeg-image",
        }
    }

    fn description(&self) -> String {
        match self.0 {
            JpegLibrary::Turbo => {
                "libjpeg-turbo settings (mozjpeg library, JCP_FASTEST profile): baseline, \
                 4:2:0, optimised Huffman; decoded by the same library"
            }
            JpegLibrary::Moz => {
                "mozjpeg defaults: trellis quantisation, progressive, optimised scans, 4:2:0; \
                 decoded by the same library"
            }
            JpegLibrary::Image => {
                "image crate 0.25 JPEG encoder (baseline, 4:2:0, standard Huffman tables); \
                 decoded by the image crate (zune-jpeg)"
            }
        }
        .into()
    }

    fn extension(&self) -> &'static str {
        "jpg"
    }

    fn supports(&self, image: &Raster) -> Result<(), String> {
        no_alpha(image)
    }

    fn default_qualities(&self) -> Vec<f32> {
        JPEG_QUALITIES.to_vec()
    }

    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
        match self.0 {
            JpegLibrary::Image => encode_image_jpeg(image, setting),
            library => encode_mozjpeg(image, setting, library == JpegLibrary::Turbo),
        }
    }

    fn decode(&self, bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
        match self.0 {
            JpegLibrary::Image => decode_image_jpeg(bytes, reference),
            _ => decode_mozjpeg(bytes, reference),
        }
    }
}

/// Encodes with mozjpeg, with libjpeg-turbo-compatible settings if `fastest`.
fn encode_mozjpeg(image: &Raster, setting: Setting, fastest: bool) -> Result<Vec<u8>, String> {
    let q = quality_of(setting)?.max(1.0);
    let grey = image.layout().colour_channels() == 1;
    let data = interleaved_u8(image, false);
    let (w, h) = (image.width() as usize, image.height() as usize);
    guarded("mozjpeg encode", move || {
        let space = if grey {
            mozjpeg::ColorSpace::JCS_GRAYSCALE
        } else {
            mozjpeg::ColorSpace::JCS_RGB
        };
        let mut c = mozjpeg::Compress::new(space);
        if fastest {
            c.set_fastest_defaults();
        }
        c.set_size(w, h);
        c.set_quality(q);
        c.set_optimize_coding(true);
        let mut started = c.start_compress(Vec::new())?;
        started.write_scanlines(&data)?;
        started.finish()
    })
}

/// Decodes with mozjpeg, grey if `reference` is.
fn decode_mozjpeg(bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
    let grey = reference.layout().colour_channels() == 1;
    let (data, w, h) = guarded("mozjpeg decode", || {
        let d = mozjpeg::Decompress::new_mem(bytes)?;
        let mut started = if grey { d.grayscale()? } else { d.rgb()? };
        let (w, h) = (started.width(), started.height());
        let data = started.read_scanlines::<u8>()?;
        started.finish()?;
        Ok((data, w, h))
    })?;
    raster_from_u8(
        &data,
        if grey { 1 } else { 3 },
        w as u32,
        h as u32,
        reference,
    )
}

/// Encodes with the `image` crate's JPEG encoder.
fn encode_image_jpeg(image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
    use image::codecs::jpeg::JpegEncoder;
    use image::ImageEncoder;
    let q = quality_of(setting)?.round().clamp(1.0, 100.0) as u8;
    let grey = image.layout().colour_channels() == 1;
    let data = interleaved_u8(image, false);
    let color = if grey {
        image::ExtendedColorType::L8
    } else {
        image::ExtendedColorType::Rgb8
    };
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, q)
        .write_image(&data, image.width(), image.height(), color)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// Decodes with the `image` crate, grey if `reference` is.
fn decode_image_jpeg(bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Jpeg)
        .map_err(|e| e.to_string())?;
    let (w, h) = (img.width(), img.height());
    if reference.layout().colour_channels() == 1 {
        raster_from_u8(img.to_luma8().as_raw(), 1, w, h, reference)
    } else {
        raster_from_u8(img.to_rgb8().as_raw(), 3, w, h, reference)
    }
}

/// libwebp, lossy.
struct WebP;

impl Codec for WebP {
    fn name(&self) -> &'static str {
        "webp"
    }

    fn description(&self) -> String {
        "libwebp (libwebp-sys 0.9), lossy, method 6, default filters; alpha lossless; \
         grey stored as RGB; decoded by libwebp"
            .into()
    }

    fn extension(&self) -> &'static str {
        "webp"
    }

    fn supports(&self, image: &Raster) -> Result<(), String> {
        eight_bit_only(image)?;
        if image.width() > 16383 || image.height() > 16383 {
            return Err("WebP is limited to 16383 pixels per side".into());
        }
        Ok(())
    }

    fn default_qualities(&self) -> Vec<f32> {
        vec![0.0, 10.0, 25.0, 40.0, 55.0, 70.0, 85.0, 95.0]
    }

    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
        let q = quality_of(setting)?;
        let alpha = image.layout().has_alpha();
        let data = interleaved_u8(image, true);
        let layout = if alpha {
            webp::PixelLayout::Rgba
        } else {
            webp::PixelLayout::Rgb
        };
        let mut config =
            webp::WebPConfig::new().map_err(|_| "libwebp: configuration failed".to_string())?;
        config.quality = q;
        config.method = 6;
        let encoder = webp::Encoder::new(&data, layout, image.width(), image.height());
        let out = encoder
            .encode_advanced(&config)
            .map_err(|e| format!("libwebp: {e:?}"))?;
        Ok(out.to_vec())
    }

    fn decode(&self, bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
        let img = webp::Decoder::new(bytes)
            .decode()
            .ok_or_else(|| "libwebp could not decode the file".to_string())?;
        let channels = if img.is_alpha() { 4 } else { 3 };
        raster_from_u8(&img, channels, img.width(), img.height(), reference)
    }
}

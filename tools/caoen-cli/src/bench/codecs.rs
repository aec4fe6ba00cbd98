//! The codecs a benchmark runs: a common interface, caoen through its facade, and
//! the registry of names (`caoen`; the command-line peers `avif`, `avif444`, `jxl` when
//! their tools are installed; with the `peers` feature `jpeg`, `mozjpeg`, `jpeg-image`,
//! `webp`).

use std::time::Instant;

use caoen::codec::{self, DecodeOptions, EncodeOptions, RateTarget};
use caoen::raster::{Raster, SampleFormat};

use super::external::EXTERNAL_NAMES;

/// One point of a codec's settings sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Setting {
    /// The codec's quality knob (0..=100 for every codec here).
    Quality(f32),
    /// A target in bits per pixel, for codecs with their own rate control.
    Bpp(f64),
}

/// A codec under test: a real encoder and its own decoder.
pub trait Codec: Send + Sync {
    /// Short name used on the command line and in reports.
    fn name(&self) -> &'static str;
    /// Library, version and settings, for the report.
    fn description(&self) -> String;
    /// Extension of its files (for `--keep`).
    fn extension(&self) -> &'static str;
    /// `Err(reason)` if the codec cannot represent this image (it is then skipped).
    fn supports(&self, image: &Raster) -> Result<(), String>;
    /// Whether [`Setting::Bpp`] is handled by the codec itself; otherwise the
    /// harness searches the quality knob.
    fn native_rate_control(&self) -> bool {
        false
    }
    /// Quality settings swept when no rates are given: chosen to span roughly
    /// 0.1 to 2 bits per pixel on the corpus's photo-like classes.
    fn default_qualities(&self) -> Vec<f32>;
    /// Encodes with the given setting.
    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String>;
    /// Decodes with the codec's own decoder, into the reference image's colour
    /// layout (a codec that stores grey as RGB converts back).
    fn decode(&self, bytes: &[u8], reference: &Raster) -> Result<Raster, String>;
    /// Encodes and times the encoder, ms: the whole call, unless the codec has parts
    /// that are not its encoder's (a command-line peer's file hand-over).
    fn encode_timed(&self, image: &Raster, setting: Setting) -> Result<(Vec<u8>, f64), String> {
        let start = Instant::now();
        let bytes = self.encode(image, setting)?;
        Ok((bytes, start.elapsed().as_secs_f64() * 1e3))
    }
    /// Decodes and times the decoder, ms, as [`Codec::encode_timed`] does.
    fn decode_timed(&self, bytes: &[u8], reference: &Raster) -> Result<(Raster, f64), String> {
        let start = Instant::now();
        let image = self.decode(bytes, reference)?;
        Ok((image, start.elapsed().as_secs_f64() * 1e3))
    }
}

/// caoen through `caoen::codec::{encode, decode}`.
#[derive(Debug, Clone, Default)]
pub struct Caoen {
    /// Encoder effort (1..=9); `None` for the codec's default.
    pub effort: Option<u8>,
}

impl Codec for Caoen {
    fn name(&self) -> &'static str {
        "caoen"
    }

    fn description(&self) -> String {
        let effort = self
            .effort
            .unwrap_or_else(|| EncodeOptions::default().effort);
        format!(
            "caoen {} (this build), effort {effort}, decoded at S = 1",
            env!("CARGO_PKG_VERSION")
        )
    }

    fn extension(&self) -> &'static str {
        "cae"
    }

    fn supports(&self, _image: &Raster) -> Result<(), String> {
        Ok(())
    }

    fn native_rate_control(&self) -> bool {
        true
    }

    fn default_qualities(&self) -> Vec<f32> {
        vec![20.0, 30.0, 40.0, 50.0, 58.0, 65.0, 72.0, 90.0]
    }

    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
        let mut opts = EncodeOptions::default();
        if let Some(e) = self.effort {
            opts.effort = e;
        }
        match setting {
            Setting::Quality(q) => opts.quality = q,
            Setting::Bpp(b) => opts.target = Some(RateTarget::BitsPerPixel(b)),
        }
        codec::encode(image, &opts).map_err(|e| e.to_string())
    }

    fn decode(&self, bytes: &[u8], _reference: &Raster) -> Result<Raster, String> {
        codec::decode(bytes, &DecodeOptions::default()).map_err(|e| e.to_string())
    }
}

/// Names of every codec this build has (the command-line peers need their tools).
pub fn available() -> Vec<&'static str> {
    let peers: &[&'static str] = if cfg!(feature = "peers") {
        &PEER_NAMES
    } else {
        &[]
    };
    std::iter::once("caoen")
        .chain(peers.iter().copied())
        .chain(EXTERNAL_NAMES)
        .collect()
}

/// Names of the peer codecs the `peers` feature adds.
pub const PEER_NAMES: [&str; 4] = ["jpeg", "mozjpeg", "jpeg-image", "webp"];

/// The codec called `name`, configured from the benchmark's options.
pub fn by_name(name: &str, caoen_effort: Option<u8>) -> Result<Box<dyn Codec>, String> {
    if name == "caoen" {
        return Ok(Box::new(Caoen {
            effort: caoen_effort,
        }));
    }
    if let Some(c) = super::external::by_name(name)? {
        return Ok(c);
    }
    #[cfg(feature = "peers")]
    if let Some(c) = super::peers::by_name(name) {
        return Ok(c);
    }
    if PEER_NAMES.contains(&name) {
        return Err(format!(
            "codec `{name}` needs the peer codecs, which this build leaves out: rebuild \
             with `cargo build --release --features peers` (or run \
             `cargo run --release --features peers -- bench ...`)"
        ));
    }
    Err(format!(
        "unknown codec `{name}` (known: caoen, {}, {})",
        PEER_NAMES.join(", "),
        EXTERNAL_NAMES.join(", ")
    ))
}

/// Planar raster samples as interleaved 8-bit values (clamped, rounded), for the
/// 8-bit peers; grey is replicated to RGB when `rgb` is set (alpha kept last).
pub fn interleaved_u8(image: &Raster, rgb: bool) -> Vec<u8> {
    let n = image.pixel_count();
    let colour = image.layout().colour_channels();
    let alpha = image.layout().has_alpha();
    let src: Vec<usize> = if rgb && colour == 1 {
        vec![0, 0, 0]
    } else {
        (0..colour).collect()
    };
    let src: Vec<usize> = src.into_iter().chain(alpha.then_some(colour)).collect();
    let s = image.samples();
    let mut out = Vec::with_capacity(n * src.len());
    for i in 0..n {
        for &c in &src {
            out.push((s[c * n + i].clamp(0.0, 1.0) * 255.0).round() as u8);
        }
    }
    out
}

/// An 8-bit decoded image (interleaved, `channels` per pixel: 1 grey, 3 RGB, 4 RGBA)
/// as a raster in the reference's layout; RGB output for a grey reference becomes
/// BT.601 luma, rounded to 8 bits.
pub fn raster_from_u8(
    data: &[u8],
    channels: usize,
    width: u32,
    height: u32,
    reference: &Raster,
) -> Result<Raster, String> {
    let n = width as usize * height as usize;
    if data.len() != n * channels {
        return Err(format!(
            "decoder returned {} bytes for {width}x{height}x{channels}",
            data.len()
        ));
    }
    let layout = reference.layout();
    let colour = layout.colour_channels();
    let mut samples = vec![0.0f32; n * layout.channels()];
    for i in 0..n {
        let px = &data[i * channels..(i + 1) * channels];
        let c_in = if channels >= 3 { 3 } else { 1 };
        if colour == 1 && c_in == 3 {
            let y = 0.299 * f32::from(px[0]) + 0.587 * f32::from(px[1]) + 0.114 * f32::from(px[2]);
            samples[i] = y.round() / 255.0;
        } else if colour == 3 && c_in == 1 {
            for c in 0..3 {
                samples[c * n + i] = f32::from(px[0]) / 255.0;
            }
        } else {
            for c in 0..colour {
                samples[c * n + i] = f32::from(px[c]) / 255.0;
            }
        }
        if layout.has_alpha() {
            let a = if channels == 2 || channels == 4 {
                f32::from(px[channels - 1]) / 255.0
            } else {
                1.0
            };
            samples[colour * n + i] = a;
        }
    }
    Raster::new(width, height, layout, SampleFormat::U8, samples).map_err(|e| e.to_string())
}

/// Rejects what no 8-bit peer can represent: float (HDR) images.
pub fn eight_bit_only(image: &Raster) -> Result<(), String> {
    if image.format() == SampleFormat::F32 {
        Err("HDR (float) input; this codec stores 8-bit samples".into())
    } else {
        Ok(())
    }
}

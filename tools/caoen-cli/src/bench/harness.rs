//! Running the sweep: every image through every codec at every rate point, each
//! point encoded, decoded by the codec's own decoder and measured on the decoded
//! pixels. Sizes are the encoded byte counts; no number comes from a codec's claims.
//!
//! Jobs run one after another, so a codec's timings are not disturbed by another
//! job; a codec may use the rayon pool (`-j`) internally.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use caoen::image_io::{self, OutputFormat};
use caoen::metrics;
use caoen::raster::Raster;
use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};

use super::codecs::{Codec, Setting};
use super::corpus::BenchImage;

/// One requested rate point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RatePoint {
    /// A target in bits per pixel (`0.5`): native rate control, or a search of the
    /// quality knob for the setting whose size is closest in log-rate.
    Bpp(f64),
    /// A quality setting for every codec (`q75`).
    Quality(f32),
}

impl fmt::Display for RatePoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RatePoint::Bpp(b) => write!(f, "{b}bpp"),
            RatePoint::Quality(q) => write!(f, "q{q}"),
        }
    }
}

/// The sweep of rate points.
#[derive(Debug, Clone, PartialEq)]
pub enum Rates {
    /// Each codec's own quality ladder ([`Codec::default_qualities`]).
    Auto,
    /// The same points for every codec.
    Points(Vec<RatePoint>),
}

impl FromStr for Rates {
    type Err = String;

    /// `auto`, or a comma-separated list of bits-per-pixel targets (`0.25`,
    /// `0.5bpp`) and quality settings (`q75`).
    fn from_str(s: &str) -> Result<Rates, String> {
        if s.trim() == "auto" {
            return Ok(Rates::Auto);
        }
        let points = s
            .split(',')
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .map(|p| {
                if let Some(q) = p.strip_prefix('q') {
                    match q.parse::<f32>() {
                        Ok(v) if (0.0..=100.0).contains(&v) => Ok(RatePoint::Quality(v)),
                        _ => Err(format!("bad quality `{p}` (expected q0 to q100)")),
                    }
                } else {
                    let b = p.strip_suffix("bpp").unwrap_or(p);
                    match b.parse::<f64>() {
                        Ok(v) if v > 0.0 && v <= 64.0 => Ok(RatePoint::Bpp(v)),
                        _ => Err(format!(
                            "bad rate `{p}` (expected bits per pixel in (0, 64], or qN)"
                        )),
                    }
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        if points.is_empty() {
            return Err("no rate points given".into());
        }
        Ok(Rates::Points(points))
    }
}

/// Benchmark settings.
pub struct Config {
    /// The codecs, in report order.
    pub codecs: Vec<Box<dyn Codec>>,
    /// The rate points.
    pub rates: Rates,
    /// Timed runs of each final encode and of each decode (the median is reported).
    pub repeat: usize,
    /// Directory to write every encoded file and its decoded image into.
    pub keep: Option<PathBuf>,
    /// How kept files are written: replacing files of the same names (the keep
    /// directory is the bench's), never a corpus image.
    pub keep_outputs: crate::output::Outputs,
}

/// One encoded and measured point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Image name.
    pub image: String,
    /// Image class.
    pub class: String,
    /// Codec name.
    pub codec: String,
    /// The requested point (`q75`, `0.5bpp`).
    pub target: String,
    /// `fixed` (a quality setting), `search` (quality searched for a bpp target) or
    /// `native` (the codec's own rate control).
    pub rate_control: String,
    /// The quality setting used, when there was one.
    pub quality: Option<f32>,
    /// Encoded size in bytes.
    pub bytes: u64,
    /// Bits per pixel of the encoded file.
    pub bpp: f64,
    /// RGB PSNR in dB; `null` when the decoded image is identical (infinite PSNR).
    pub psnr: Option<f64>,
    /// Luma PSNR in dB; `null` when identical.
    pub psnr_y: Option<f64>,
    /// SSIM of the luma plane.
    pub ssim: f64,
    /// MS-SSIM of the luma plane.
    #[serde(default)]
    pub ms_ssim: Option<f64>,
    /// SSIMULACRA2, when defined (not for HDR or images under 8x8).
    pub ssimulacra2: Option<f64>,
    /// Metric scale: `display` or `log-hdr` (see `caoen::metrics`).
    pub scale: String,
    /// Median encode wall time, ms.
    pub encode_ms: f64,
    /// Median decode wall time, ms.
    pub decode_ms: f64,
    /// Every timed encode run, ms.
    pub encode_runs_ms: Vec<f64>,
    /// Every timed decode run, ms.
    pub decode_runs_ms: Vec<f64>,
    /// The kept encoded file (`--keep`), relative to the keep directory.
    pub file: Option<String>,
    /// The kept decoded image (`--keep`), relative to the keep directory.
    pub decoded_file: Option<String>,
}

/// An image a codec cannot represent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skip {
    /// Image name.
    pub image: String,
    /// Codec name.
    pub codec: String,
    /// Why.
    pub reason: String,
}

/// A point that failed to encode, decode or measure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// Image name.
    pub image: String,
    /// Codec name.
    pub codec: String,
    /// The requested point.
    pub target: String,
    /// What went wrong.
    pub error: String,
}

/// Everything a run measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outcome {
    /// Measured points.
    pub measurements: Vec<Measurement>,
    /// Skipped image/codec pairs.
    pub skipped: Vec<Skip>,
    /// Failed points.
    pub failures: Vec<Failure>,
}

/// Median of a non-empty list (mean of the middle two for even lengths).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) / 2.0
    }
}

/// Number of rate points a codec runs per image.
pub fn points_per_image(codec: &dyn Codec, rates: &Rates) -> usize {
    match rates {
        Rates::Auto => codec.default_qualities().len(),
        Rates::Points(p) => p.len(),
    }
}

/// An encode of one image by one codec, with the encodes done so far: a quality
/// search reuses them across targets.
struct Encoder<'a> {
    codec: &'a dyn Codec,
    image: &'a Raster,
    pixels: f64,
    /// Quality (in hundredths) -> (bytes, wall time in ms).
    cache: std::collections::BTreeMap<u32, (Vec<u8>, f64)>,
}

impl Encoder<'_> {
    fn at_quality(&mut self, q: f32) -> Result<(Vec<u8>, f64), String> {
        let key = (q * 100.0).round() as u32;
        if let Some(hit) = self.cache.get(&key) {
            return Ok(hit.clone());
        }
        let (bytes, ms) = self.codec.encode_timed(self.image, Setting::Quality(q))?;
        let entry = (bytes, ms);
        self.cache.insert(key, entry.clone());
        Ok(entry)
    }

    fn bpp(&mut self, q: f32) -> Result<f64, String> {
        Ok(self.at_quality(q)?.0.len() as f64 * 8.0 / self.pixels)
    }

    /// The integer quality whose size is closest to `target` bpp in log-rate
    /// (bisection: sizes grow with quality).
    fn search(&mut self, target: f64) -> Result<f32, String> {
        let (mut lo, mut hi) = (0.0f32, 100.0f32);
        if self.bpp(hi)? <= target {
            return Ok(hi);
        }
        if self.bpp(lo)? >= target {
            return Ok(lo);
        }
        while hi - lo > 1.0 {
            let mid = ((lo + hi) / 2.0).floor();
            if self.bpp(mid)? <= target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let gap = |b: f64| (b.ln() - target.ln()).abs();
        Ok(if gap(self.bpp(lo)?) <= gap(self.bpp(hi)?) {
            lo
        } else {
            hi
        })
    }
}

/// File-name label of a rate point.
fn label(point: &RatePoint) -> String {
    match point {
        RatePoint::Bpp(b) => format!("{b:.3}bpp"),
        RatePoint::Quality(q) => format!("q{q}"),
    }
}

/// Runs the whole sweep. `progress` advances once per rate point.
pub fn run(images: &[BenchImage], config: &Config, progress: &ProgressBar) -> Outcome {
    let mut out = Outcome::default();
    for image in images {
        for codec in &config.codecs {
            let codec = codec.as_ref();
            let n = points_per_image(codec, &config.rates) as u64;
            progress.set_message(format!("{} {}", codec.name(), image.name));
            if let Err(reason) = codec.supports(&image.raster) {
                out.skipped.push(Skip {
                    image: image.name.clone(),
                    codec: codec.name().into(),
                    reason,
                });
                progress.inc(n);
                continue;
            }
            run_pair(image, codec, config, progress, &mut out);
        }
    }
    out
}

fn run_pair(
    image: &BenchImage,
    codec: &dyn Codec,
    config: &Config,
    progress: &ProgressBar,
    out: &mut Outcome,
) {
    let points: Vec<RatePoint> = match &config.rates {
        Rates::Auto => codec
            .default_qualities()
            .into_iter()
            .map(RatePoint::Quality)
            .collect(),
        Rates::Points(p) => p.clone(),
    };
    let mut enc = Encoder {
        codec,
        image: &image.raster,
        pixels: image.raster.pixel_count() as f64,
        cache: Default::default(),
    };
    let mut seen: Vec<Vec<u8>> = Vec::new();
    for point in &points {
        let result = measure_point(image, codec, config, &mut enc, point, &mut seen);
        match result {
            Ok(Some(m)) => out.measurements.push(m),
            Ok(None) => {} // the same file as an earlier point: measured once
            Err(error) => out.failures.push(Failure {
                image: image.name.clone(),
                codec: codec.name().into(),
                target: point.to_string(),
                error,
            }),
        }
        progress.inc(1);
    }
}

fn measure_point(
    image: &BenchImage,
    codec: &dyn Codec,
    config: &Config,
    enc: &mut Encoder<'_>,
    point: &RatePoint,
    seen: &mut Vec<Vec<u8>>,
) -> Result<Option<Measurement>, String> {
    let repeat = config.repeat.max(1);
    let (bytes, first_ms, quality, rate_control) = match *point {
        RatePoint::Quality(q) => {
            let (b, ms) = enc.at_quality(q)?;
            (b, ms, Some(q), "fixed")
        }
        RatePoint::Bpp(t) if codec.native_rate_control() => {
            let (b, ms) = codec.encode_timed(&image.raster, Setting::Bpp(t))?;
            (b, ms, None, "native")
        }
        RatePoint::Bpp(t) => {
            let q = enc.search(t)?;
            let (b, ms) = enc.at_quality(q)?;
            (b, ms, Some(q), "search")
        }
    };
    if seen.contains(&bytes) {
        return Ok(None);
    }
    seen.push(bytes.clone());
    let setting = match (*point, quality) {
        (_, Some(q)) => Setting::Quality(q),
        (RatePoint::Bpp(t), None) => Setting::Bpp(t),
        (RatePoint::Quality(q), None) => Setting::Quality(q),
    };
    let mut encode_runs = vec![first_ms];
    for _ in 1..repeat {
        let (again, ms) = codec.encode_timed(&image.raster, setting)?;
        encode_runs.push(ms);
        if again != bytes {
            return Err("the encoder is not deterministic: a repeated encode differs".into());
        }
    }
    let mut decode_runs = Vec::with_capacity(repeat);
    let mut decoded = None;
    for _ in 0..repeat {
        let (d, ms) = codec.decode_timed(&bytes, &image.raster)?;
        decode_runs.push(ms);
        decoded = Some(d);
    }
    let decoded = decoded.expect("at least one decode ran");
    let c = metrics::compare(&image.raster, &decoded).map_err(|e| format!("decoded image: {e}"))?;
    let (file, decoded_file) = match &config.keep {
        Some(dir) => {
            let base = std::path::Path::new(&image.name)
                .file_stem()
                .map_or(image.name.clone(), |s| s.to_string_lossy().into_owned());
            let stem = format!("{base}.{}.{}", codec.name(), label(point));
            let file = format!("{stem}.{}", codec.extension());
            let out = &config.keep_outputs;
            out.write_path(&dir.join(&file), &bytes)
                .map_err(|e| e.to_string())?;
            let format = OutputFormat::natural(decoded.format());
            let dec = format!("{stem}.decoded.{}", format.extension());
            let dec_bytes = image_io::encode(&decoded, format).map_err(|e| e.to_string())?;
            out.write_path(&dir.join(&dec), &dec_bytes)
                .map_err(|e| e.to_string())?;
            (Some(file), Some(dec))
        }
        None => (None, None),
    };
    let finite = |v: f64| v.is_finite().then_some(v);
    Ok(Some(Measurement {
        image: image.name.clone(),
        class: image.class.clone(),
        codec: codec.name().into(),
        target: point.to_string(),
        rate_control: rate_control.into(),
        quality,
        bytes: bytes.len() as u64,
        bpp: bytes.len() as f64 * 8.0 / image.raster.pixel_count() as f64,
        psnr: finite(c.psnr),
        psnr_y: finite(c.psnr_y),
        ssim: c.ssim,
        ms_ssim: Some(c.ms_ssim),
        ssimulacra2: c.ssimulacra2,
        scale: c.scale.name().into(),
        encode_ms: median(&encode_runs),
        decode_ms: median(&decode_runs),
        encode_runs_ms: encode_runs,
        decode_runs_ms: decode_runs,
        file,
        decoded_file,
    }))
}

//! Statistics over the measurements: per-image RD curves and Bjontegaard deltas
//! against the reference codec, and per-class PSNR at fixed rates, mean deltas and
//! median times.

use serde::{Deserialize, Serialize};

use super::bd_rate::{bd_quality, bd_rate, quality_at_rate, RdPoint};
use super::corpus::class_rank;
use super::harness::{median, Measurement};

/// Rates (bits per pixel) at which each class's PSNR is interpolated.
pub const PSNR_RATES: [f64; 4] = [0.1, 0.25, 0.5, 1.0];

/// Name of the pseudo-class covering every image.
pub const ALL_CLASSES: &str = "all";

/// One codec on one image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageSummary {
    /// Image name.
    pub image: String,
    /// Image class.
    pub class: String,
    /// Codec name.
    pub codec: String,
    /// Measured points.
    pub points: usize,
    /// Median over the points of the encode time, ms.
    pub encode_ms: f64,
    /// Median over the points of the decode time, ms.
    pub decode_ms: f64,
    /// BD-rate (RGB PSNR) against the reference codec, percent; negative saves bits.
    pub bd_rate: Option<f64>,
    /// BD-PSNR (RGB) against the reference codec, dB.
    pub bd_psnr: Option<f64>,
    /// BD-rate on Y-PSNR, percent.
    pub bd_rate_y: Option<f64>,
    /// Why the deltas are missing, if they are (and this is not the reference).
    pub bd_note: Option<String>,
}

/// PSNR of a class at one rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsnrAt {
    /// Bits per pixel.
    pub bpp: f64,
    /// Mean over the images whose curve reaches this rate.
    pub psnr: Option<f64>,
    /// How many images that mean covers.
    pub images: usize,
}

/// One codec on one class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClassSummary {
    /// Class name (`all` for the whole corpus).
    pub class: String,
    /// Codec name.
    pub codec: String,
    /// Images with at least one measurement.
    pub images: usize,
    /// Interpolated RGB PSNR at [`PSNR_RATES`].
    pub psnr_at: Vec<PsnrAt>,
    /// Mean BD-rate against the reference over `bd_images`, percent.
    pub bd_rate: Option<f64>,
    /// Mean BD-PSNR against the reference over `bd_images`, dB.
    pub bd_psnr: Option<f64>,
    /// Mean Y-PSNR BD-rate, percent.
    pub bd_rate_y: Option<f64>,
    /// Images the BD means cover.
    pub bd_images: usize,
    /// Median of the images' median encode times, ms.
    pub encode_ms: f64,
    /// Median of the images' median decode times, ms.
    pub decode_ms: f64,
}

/// RD points of one image and codec, with a quality picked from a measurement.
pub fn curve(ms: &[&Measurement], quality: impl Fn(&Measurement) -> Option<f64>) -> Vec<RdPoint> {
    ms.iter()
        .filter_map(|m| {
            quality(m).map(|q| RdPoint {
                rate: m.bpp,
                quality: q,
            })
        })
        .collect()
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Per-image summaries, in measurement order of images and the given codec order.
pub fn per_image(
    measurements: &[Measurement],
    codecs: &[String],
    reference: &str,
) -> Vec<ImageSummary> {
    let mut images: Vec<(&str, &str)> = Vec::new();
    for m in measurements {
        if !images.iter().any(|(i, _)| *i == m.image) {
            images.push((&m.image, &m.class));
        }
    }
    let of = |image: &str, codec: &str| -> Vec<&Measurement> {
        measurements
            .iter()
            .filter(|m| m.image == image && m.codec == codec)
            .collect()
    };
    let mut out = Vec::new();
    for (image, class) in images {
        let reference_ms = of(image, reference);
        for codec in codecs {
            let ms = of(image, codec);
            if ms.is_empty() {
                continue;
            }
            let (mut bd_rate_v, mut bd_psnr_v, mut bd_rate_y, mut bd_note) =
                (None, None, None, None);
            if codec != reference {
                if reference_ms.is_empty() {
                    bd_note = Some(format!("no {reference} measurements for this image"));
                } else {
                    let rgb = |m: &Measurement| m.psnr;
                    let y = |m: &Measurement| m.psnr_y;
                    let (r, t) = (curve(&reference_ms, rgb), curve(&ms, rgb));
                    match (bd_rate(&r, &t), bd_quality(&r, &t)) {
                        (Ok(a), Ok(b)) => {
                            bd_rate_v = Some(a);
                            bd_psnr_v = Some(b);
                        }
                        (Err(e), _) | (_, Err(e)) => bd_note = Some(e.to_string()),
                    }
                    bd_rate_y = bd_rate(&curve(&reference_ms, y), &curve(&ms, y)).ok();
                }
            }
            let enc: Vec<f64> = ms.iter().map(|m| m.encode_ms).collect();
            let dec: Vec<f64> = ms.iter().map(|m| m.decode_ms).collect();
            out.push(ImageSummary {
                image: image.into(),
                class: class.into(),
                codec: codec.clone(),
                points: ms.len(),
                encode_ms: median(&enc),
                decode_ms: median(&dec),
                bd_rate: bd_rate_v,
                bd_psnr: bd_psnr_v,
                bd_rate_y,
                bd_note,
            });
        }
    }
    out
}

/// Classes present, in corpus order.
pub fn classes(measurements: &[Measurement]) -> Vec<String> {
    let mut c: Vec<String> = Vec::new();
    for m in measurements {
        if !c.contains(&m.class) {
            c.push(m.class.clone());
        }
    }
    c.sort_by_key(|a| class_rank(a));
    c
}

/// Per-class summaries (each class, then [`ALL_CLASSES`]), codecs in the given order.
pub fn per_class(
    measurements: &[Measurement],
    images: &[ImageSummary],
    codecs: &[String],
) -> Vec<ClassSummary> {
    let mut names = classes(measurements);
    names.push(ALL_CLASSES.into());
    let mut out = Vec::new();
    for class in &names {
        let in_class = |c: &str| class == ALL_CLASSES || c == class;
        for codec in codecs {
            let summaries: Vec<&ImageSummary> = images
                .iter()
                .filter(|s| in_class(&s.class) && &s.codec == codec)
                .collect();
            if summaries.is_empty() {
                continue;
            }
            let psnr_at = PSNR_RATES
                .iter()
                .map(|&bpp| {
                    let v: Vec<f64> = summaries
                        .iter()
                        .filter_map(|s| {
                            let ms: Vec<&Measurement> = measurements
                                .iter()
                                .filter(|m| m.image == s.image && &m.codec == codec)
                                .collect();
                            quality_at_rate(&curve(&ms, |m| m.psnr), bpp)
                        })
                        .collect();
                    PsnrAt {
                        bpp,
                        psnr: mean(&v),
                        images: v.len(),
                    }
                })
                .collect();
            let pick = |f: fn(&ImageSummary) -> Option<f64>| -> Vec<f64> {
                summaries.iter().filter_map(|s| f(s)).collect()
            };
            let rates = pick(|s| s.bd_rate);
            let enc: Vec<f64> = summaries.iter().map(|s| s.encode_ms).collect();
            let dec: Vec<f64> = summaries.iter().map(|s| s.decode_ms).collect();
            out.push(ClassSummary {
                class: class.clone(),
                codec: codec.clone(),
                images: summaries.len(),
                psnr_at,
                bd_rate: mean(&rates),
                bd_psnr: mean(&pick(|s| s.bd_psnr)),
                bd_rate_y: mean(&pick(|s| s.bd_rate_y)),
                bd_images: rates.len(),
                encode_ms: median(&enc),
                decode_ms: median(&dec),
            });
        }
    }
    out
}

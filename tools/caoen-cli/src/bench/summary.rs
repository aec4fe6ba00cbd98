//! Statistics over the measurements: per-image RD curves and Bjontegaard deltas
//! against the reference codec (over the whole overlap and per rate window), and
//! per-class PSNR at fixed rates, mean deltas and median times.

use serde::{Deserialize, Serialize};

use super::bd_rate::{bd_quality, bd_rate, bd_rate_window, quality_at_rate, RdPoint};
use super::corpus::class_rank;
use super::harness::{median, Measurement};

/// Rates (bits per pixel) at which each class's PSNR is interpolated.
pub const PSNR_RATES: [f64; 4] = [0.1, 0.25, 0.5, 1.0];

/// Rate windows (bits per pixel, `[lo, hi]`) of the windowed BD-rates: low, middle
/// and high rates, where codecs often rank differently. Each is placed on the
/// reference codec's curve; see [`bd_rate_window`].
pub const BD_WINDOWS: [(f64, f64); 3] = [(0.05, 0.3), (0.3, 0.8), (0.8, 2.0)];

/// The quality a measurement gives a metric, when it has one.
pub type QualityOf = fn(&Measurement) -> Option<f64>;

/// The perceptual metrics with BD-rates beside RGB PSNR: each name and the quality
/// a measurement gives it, increasing with fidelity. MS-SSIM goes in decibels,
/// `-10 log10(1 - MS-SSIM)`, as BD-rates by MS-SSIM usually are (a perfect score has
/// none); SSIMULACRA2 as its score.
pub const PERCEPTUAL: [(&str, QualityOf); 2] = [
    ("ms-ssim", |m| {
        m.ms_ssim
            .map(|v| -10.0 * (1.0 - v).log10())
            .filter(|v| v.is_finite())
    }),
    ("ssimulacra2", |m| m.ssimulacra2),
];

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
    /// BD-rate (RGB PSNR) in each of [`BD_WINDOWS`].
    #[serde(default)]
    pub bd_rate_windows: Vec<WindowBdRate>,
    /// BD-rates by each of [`PERCEPTUAL`]'s metrics, overall and per window.
    #[serde(default)]
    pub perceptual: Vec<MetricBdRate>,
}

/// BD-rate of one image by one perceptual metric.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricBdRate {
    /// Metric name (one of [`PERCEPTUAL`]).
    pub metric: String,
    /// Percent over the curves' overlap; `None` for the reference or without overlap.
    pub bd_rate: Option<f64>,
    /// In each of [`BD_WINDOWS`].
    pub windows: Vec<WindowBdRate>,
}

/// Mean BD-rate of a class by one perceptual metric.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricBdMean {
    /// Metric name (one of [`PERCEPTUAL`]).
    pub metric: String,
    /// Mean over the images with a figure, percent.
    pub bd_rate: Option<f64>,
    /// How many images that mean covers.
    pub images: usize,
    /// In each of [`BD_WINDOWS`].
    pub windows: Vec<WindowBdMean>,
}

/// BD-rate of one image in one rate window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowBdRate {
    /// Lower end of the window, bits per pixel.
    pub lo: f64,
    /// Upper end of the window, bits per pixel.
    pub hi: f64,
    /// Percent; `None` when the window's PSNR interval is empty or shorter than
    /// [`MIN_WINDOW_SPAN`](super::bd_rate::MIN_WINDOW_SPAN), and for the reference.
    pub bd_rate: Option<f64>,
}

/// Mean BD-rate of a class in one rate window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowBdMean {
    /// Lower end of the window, bits per pixel.
    pub lo: f64,
    /// Upper end of the window, bits per pixel.
    pub hi: f64,
    /// Mean over the images with a figure in this window, percent.
    pub bd_rate: Option<f64>,
    /// How many images that mean covers.
    pub images: usize,
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
    /// Mean BD-rate in each of [`BD_WINDOWS`].
    #[serde(default)]
    pub bd_rate_windows: Vec<WindowBdMean>,
    /// Mean BD-rates by each of [`PERCEPTUAL`]'s metrics, overall and per window.
    #[serde(default)]
    pub perceptual: Vec<MetricBdMean>,
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

/// Figures for each of [`BD_WINDOWS`], in order.
fn window_rates(rates: [Option<f64>; BD_WINDOWS.len()]) -> Vec<WindowBdRate> {
    BD_WINDOWS
        .iter()
        .zip(rates)
        .map(|(&(lo, hi), bd_rate)| WindowBdRate { lo, hi, bd_rate })
        .collect()
}

/// Class means of per-image window figures: `window(s, i)` is image `s`'s figure in
/// window `i`.
fn window_means(
    summaries: &[&ImageSummary],
    window: impl Fn(&ImageSummary, usize) -> Option<f64>,
) -> Vec<WindowBdMean> {
    BD_WINDOWS
        .iter()
        .enumerate()
        .map(|(i, &(lo, hi))| {
            let v: Vec<f64> = summaries.iter().filter_map(|s| window(s, i)).collect();
            WindowBdMean {
                lo,
                hi,
                bd_rate: mean(&v),
                images: v.len(),
            }
        })
        .collect()
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
            let mut windows = [None; BD_WINDOWS.len()];
            let mut perceptual: Vec<MetricBdRate> = PERCEPTUAL
                .iter()
                .map(|(metric, _)| MetricBdRate {
                    metric: metric.to_string(),
                    bd_rate: None,
                    windows: window_rates([None; BD_WINDOWS.len()]),
                })
                .collect();
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
                    for (w, &(lo, hi)) in windows.iter_mut().zip(&BD_WINDOWS) {
                        *w = bd_rate_window(&r, &t, lo, hi).ok();
                    }
                    for (p, (_, quality)) in perceptual.iter_mut().zip(PERCEPTUAL) {
                        let (r, t) = (curve(&reference_ms, quality), curve(&ms, quality));
                        p.bd_rate = bd_rate(&r, &t).ok();
                        p.windows = window_rates(
                            BD_WINDOWS.map(|(lo, hi)| bd_rate_window(&r, &t, lo, hi).ok()),
                        );
                    }
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
                bd_rate_windows: window_rates(windows),
                perceptual,
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
            let bd_rate_windows = window_means(&summaries, |s, i| {
                s.bd_rate_windows.get(i).and_then(|w| w.bd_rate)
            });
            let perceptual = PERCEPTUAL
                .iter()
                .enumerate()
                .map(|(k, (metric, _))| {
                    let v: Vec<f64> = summaries
                        .iter()
                        .filter_map(|s| s.perceptual.get(k).and_then(|p| p.bd_rate))
                        .collect();
                    MetricBdMean {
                        metric: metric.to_string(),
                        bd_rate: mean(&v),
                        images: v.len(),
                        windows: window_means(&summaries, |s, i| {
                            s.perceptual
                                .get(k)
                                .and_then(|p| p.windows.get(i))
                                .and_then(|w| w.bd_rate)
                        }),
                    }
                })
                .collect();
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
                bd_rate_windows,
                perceptual,
                encode_ms: median(&enc),
                decode_ms: median(&dec),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATES: [f64; 6] = [0.08, 0.2, 0.45, 0.9, 1.5, 2.4];
    const PSNR: [f64; 6] = [25.0, 28.4, 31.5, 34.6, 36.9, 39.0];

    fn point(image: &str, codec: &str, bpp: f64, psnr: f64) -> Measurement {
        Measurement {
            image: image.into(),
            class: "scene".into(),
            codec: codec.into(),
            target: String::new(),
            rate_control: "fixed".into(),
            quality: None,
            bytes: 0,
            bpp,
            psnr: Some(psnr),
            psnr_y: Some(psnr),
            ssim: 1.0,
            ms_ssim: None,
            ssimulacra2: None,
            scale: "display".into(),
            encode_ms: 1.0,
            decode_ms: 1.0,
            encode_runs_ms: vec![1.0],
            decode_runs_ms: vec![1.0],
            file: None,
            decoded_file: None,
        }
    }

    /// `codec` on `image`: the points of `RATES` up to `max_rate`, each rate times `k`.
    fn scaled(image: &str, codec: &str, k: f64, max_rate: f64) -> Vec<Measurement> {
        RATES
            .iter()
            .zip(PSNR)
            .filter(|&(&r, _)| r <= max_rate)
            .map(|(r, q)| point(image, codec, r * k, q))
            .collect()
    }

    #[test]
    fn window_figures_per_image_and_their_class_means() {
        let mut ms = scaled("a", "ref", 1.0, 10.0);
        ms.extend(scaled("a", "test", 1.2, 10.0));
        // Image b's curves stop at 0.45 bpp on the reference: the top window clamps
        // to that single rate and holds nothing.
        ms.extend(scaled("b", "ref", 1.0, 0.45));
        ms.extend(scaled("b", "test", 0.5, 0.45));
        let codecs = ["ref".to_string(), "test".to_string()];
        let images = per_image(&ms, &codecs, "ref");

        let windows = |image: &str, codec: &str| -> Vec<Option<f64>> {
            let s = images
                .iter()
                .find(|s| s.image == image && s.codec == codec)
                .unwrap();
            let bounds: Vec<(f64, f64)> = s.bd_rate_windows.iter().map(|w| (w.lo, w.hi)).collect();
            assert_eq!(bounds, BD_WINDOWS);
            s.bd_rate_windows.iter().map(|w| w.bd_rate).collect()
        };
        assert_eq!(windows("a", "ref"), [None; 3]);
        for w in windows("a", "test") {
            assert!((w.unwrap() - 20.0).abs() < 1e-9, "{w:?}");
        }
        let b = windows("b", "test");
        for w in &b[..2] {
            assert!((w.unwrap() - -50.0).abs() < 1e-9, "{b:?}");
        }
        assert_eq!(b[2], None, "{b:?}");

        let classes = per_class(&ms, &images, &codecs);
        let test = classes
            .iter()
            .find(|c| c.class == ALL_CLASSES && c.codec == "test")
            .unwrap();
        let means: Vec<(Option<f64>, usize)> = test
            .bd_rate_windows
            .iter()
            .map(|w| (w.bd_rate.map(|v| (v * 1e6).round() / 1e6), w.images))
            .collect();
        assert_eq!(means, [(Some(-15.0), 2), (Some(-15.0), 2), (Some(20.0), 1)]);
        let reference = classes.iter().find(|c| c.codec == "ref").unwrap();
        assert!(reference
            .bd_rate_windows
            .iter()
            .all(|w| w.bd_rate.is_none() && w.images == 0));
    }
}

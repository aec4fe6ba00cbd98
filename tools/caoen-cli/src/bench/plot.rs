//! RD plots (RGB PSNR against bits per pixel), one per class, as PNG or SVG, drawn by
//! plotters with a bundled font (DejaVu Sans, `tools/caoen-cli/assets/`), so no system
//! font or fontconfig is needed and the pictures are the same on every machine.
//!
//! Rates are on a log axis. Each codec's curve is the class average: every image's PCHIP curve (in ln rate)
//! sampled on a common grid of rates that all the class's images reach, then
//! averaged. Where the images share no range the curves of the single images are
//! drawn instead.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::bd_rate::{quality_at_rate, RdPoint};
use super::harness::Measurement;
use super::summary::{classes, curve};

/// The bundled font (a Latin-1 subset of DejaVu Sans; licence beside it).
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans-subset.ttf");
/// Font family name every text in the plots uses.
const FAMILY: &str = "sans-serif";
/// Picture size in pixels (SVG user units).
const SIZE: (u32, u32) = (800, 560);
/// Points per averaged curve.
const GRID: usize = 40;

/// Series colours, by codec position (colour-blind-safe Okabe-Ito palette).
const COLOURS: [RGBColor; 7] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are compiled in and known good; a failure would show as missing
        // text, which the tests catch.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// The file for one class: `rd.png` becomes `rd-scene.png`.
pub fn class_path(base: &Path, class: &str) -> PathBuf {
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "rd".into());
    let ext = base
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "png".into());
    base.with_file_name(format!("{stem}-{class}.{ext}"))
}

/// One line of a plot.
struct Series {
    codec: String,
    colour: RGBColor,
    /// Solid averaged curve, or thin per-image curves.
    averaged: bool,
    lines: Vec<Vec<(f64, f64)>>,
}

/// The series of one class.
fn class_series(measurements: &[Measurement], class: &str, codecs: &[String]) -> Vec<Series> {
    let mut out = Vec::new();
    for (i, codec) in codecs.iter().enumerate() {
        let mut images: Vec<&str> = Vec::new();
        for m in measurements {
            if m.class == class && &m.codec == codec && !images.contains(&m.image.as_str()) {
                images.push(&m.image);
            }
        }
        let curves: Vec<Vec<RdPoint>> = images
            .iter()
            .map(|img| {
                let ms: Vec<&Measurement> = measurements
                    .iter()
                    .filter(|m| &m.image == img && &m.codec == codec)
                    .collect();
                super::bd_rate::monotone_curve(&curve(&ms, |m| m.psnr))
            })
            .filter(|c| !c.is_empty())
            .collect();
        if curves.is_empty() {
            continue;
        }
        let lo = curves.iter().map(|c| c[0].rate).fold(f64::MIN, f64::max);
        let hi = curves
            .iter()
            .map(|c| c[c.len() - 1].rate)
            .fold(f64::MAX, f64::min);
        let colour = COLOURS[i % COLOURS.len()];
        if hi > lo && curves.iter().all(|c| c.len() >= 2) {
            let line = (0..GRID)
                .filter_map(|k| {
                    let r = (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (GRID - 1) as f64).exp();
                    let qs: Vec<f64> = curves
                        .iter()
                        .filter_map(|c| quality_at_rate(c, r))
                        .collect();
                    (qs.len() == curves.len())
                        .then(|| (r, qs.iter().sum::<f64>() / qs.len() as f64))
                })
                .collect();
            out.push(Series {
                codec: codec.clone(),
                colour,
                averaged: true,
                lines: vec![line],
            });
        } else {
            out.push(Series {
                codec: codec.clone(),
                colour,
                averaged: false,
                lines: curves
                    .iter()
                    .map(|c| c.iter().map(|p| (p.rate, p.quality)).collect())
                    .collect(),
            });
        }
    }
    out
}

/// Writes one RD plot per class next to `base`; returns the files written.
pub fn write_plots(
    outputs: &crate::output::Outputs,
    base: &Path,
    measurements: &[Measurement],
    codecs: &[String],
) -> Result<Vec<PathBuf>, String> {
    register_font();
    let svg = base
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    let mut written = Vec::new();
    for class in classes(measurements) {
        let series = class_series(measurements, &class, codecs);
        if series.is_empty() {
            continue;
        }
        let path = class_path(base, &class);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let title = format!("{class}: RGB PSNR vs rate");
        if svg {
            let mut text = String::new();
            {
                let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
                draw(&root, &title, &series).map_err(|e| format!("plot {class}: {e}"))?;
            }
            outputs
                .write_path(&path, text.as_bytes())
                .map_err(|e| e.to_string())?;
        } else {
            let mut buf = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            {
                let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
                draw(&root, &title, &series).map_err(|e| format!("plot {class}: {e}"))?;
            }
            let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf)
                .ok_or("plot buffer has the wrong size")?;
            let mut png = Vec::new();
            image::DynamicImage::ImageRgb8(img)
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| e.to_string())?;
            outputs.write_path(&path, &png).map_err(|e| e.to_string())?;
        }
        written.push(path);
    }
    Ok(written)
}

/// Tick values for a log axis over `[lo, hi]`: finer steps for narrow ranges, only
/// the decades for ranges of more than three. Built from decimal strings, so the
/// labels print as `0.2`, not `0.20000000000000004`.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let steps: &[&str] = if hi / lo > 1000.0 {
        &["1"]
    } else if hi / lo > 10.0 {
        &["1", "2", "5"]
    } else {
        &["1", "1.5", "2", "3", "4", "5", "7"]
    };
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (first..=last)
        .flat_map(|k| steps.iter().map(move |m| format!("{m}e{k}")))
        .filter_map(|t| t.parse::<f64>().ok())
        .filter(|&t| t >= lo * 0.999_999 && t <= hi * 1.000_001)
        .collect()
}

/// The 1-2-5 value at or below `v` (`below`) or at or above it.
fn snap125(v: f64, below: bool) -> f64 {
    let k = v.log10().floor() as i32;
    let cands: Vec<f64> = (k - 1..=k + 1)
        .flat_map(|e| ["1", "2", "5"].map(|m| format!("{m}e{e}")))
        .filter_map(|t| t.parse::<f64>().ok())
        .collect();
    // NaN as the fold's start: `max`/`min` return the other operand.
    let pick = if below {
        cands
            .into_iter()
            .filter(|&c| c <= v)
            .fold(f64::NAN, f64::max)
    } else {
        cands
            .into_iter()
            .filter(|&c| c >= v)
            .fold(f64::NAN, f64::min)
    };
    if pick.is_nan() {
        v
    } else {
        pick
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    series: &[Series],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let pts = series.iter().flat_map(|s| s.lines.iter().flatten());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 20.0, 40.0);
    }
    // Rate on a log axis: BD deltas live in log-rate, and the corpus spans tiny images
    // whose headers cost hundreds of bits per pixel as well as 0.05 bpp photos.
    let (x0, x1) = (snap125(x0, true), snap125(x1.max(x0 * 1.5), false));
    let pad = ((y1 - y0) * 0.05).max(0.5);
    let (y0, y1) = ((y0 - pad).floor(), (y1 + pad).ceil());
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(56)
        .build_cartesian_2d(
            (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
            y0..y1,
        )?;
    chart
        .configure_mesh()
        .x_desc("bits per pixel (log scale)")
        .x_label_formatter(&|v| format!("{v}"))
        .y_desc("RGB PSNR (dB)")
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for s in series {
        let colour = s.colour;
        let width = if s.averaged { 2 } else { 1 };
        let mut first = true;
        for line in &s.lines {
            let drawn = chart.draw_series(LineSeries::new(
                line.iter().copied(),
                colour.stroke_width(width),
            ))?;
            if first {
                let label = if s.averaged {
                    s.codec.clone()
                } else {
                    format!("{} (per image)", s.codec)
                };
                drawn.label(label).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], colour.stroke_width(2))
                });
                first = false;
            }
            if !s.averaged {
                chart.draw_series(line.iter().map(|&p| Circle::new(p, 2, colour.filled())))?;
            }
        }
    }
    chart
        .configure_series_labels()
        .label_font((FAMILY, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    root.present()
}

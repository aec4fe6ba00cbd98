//! The benchmark report: a JSON document with every measurement and the summaries,
//! and its Markdown rendering (per corpus class, a table and its BD-rates by rate
//! window).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::harness::{Failure, Measurement, Skip};
use super::summary::{ClassSummary, ImageSummary, WindowBdMean, ALL_CLASSES};

/// Value of the report's `format` field.
pub const FORMAT: &str = "caoen-bench/1";

/// What the quality numbers mean, stored in every report.
pub const METRICS_NOTE: &str = "psnr: RGB PSNR pooled over the colour channels (alpha \
excluded), peak 1.0 on the stored 8/16-bit values; float (HDR) images on a fixed log2 \
scale (caoen::metrics). psnr_y: BT.601 luma of the stored values (HDR: log BT.709 \
luminance). ssim: Wang et al. on that luma, 11x11 Gaussian window, sigma 1.5. \
ssimulacra2: the ssimulacra2 crate, 8/16-bit images of at least 8x8. A null PSNR means \
identical images. bpp: 8 x encoded bytes / pixels. BD-rate/BD-PSNR: Bjontegaard with PCHIP \
in ln(rate) over the overlap of the two curves, per image against the reference codec, \
averaged arithmetically. bd_rate_windows: BD-rate per rate window [lo, hi] bpp: the PSNR \
interval the reference codec's curve (PCHIP of PSNR over ln(rate)) spans between rates lo \
and hi, clamped to the reference's measured rates, intersected with the two curves' PSNR \
overlap; the ln-rate gap averaged over that interval as for BD-rate; no figure for an \
image when the interval is empty or under 0.05 dB; per class the arithmetic mean over the \
images with a figure (images: their count). ms_ssim: MS-SSIM of the same luma (Wang et \
al. 2003, five scales). perceptual: BD-rates and window BD-rates as above with MS-SSIM in \
dB (-10 log10(1 - MS-SSIM)) or the SSIMULACRA2 score in place of PSNR.";

/// A codec in the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CodecInfo {
    /// Name.
    pub name: String,
    /// Library and settings.
    pub description: String,
}

/// An image in the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageInfo {
    /// Name.
    pub name: String,
    /// Class.
    pub class: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `grey`, `grey-alpha`, `rgb` or `rgba`.
    pub layout: String,
    /// `u8`, `u16` or `f32`.
    pub sample_format: String,
}

/// The whole report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// [`FORMAT`].
    pub format: String,
    /// Version of the `caoen` tool that wrote it.
    pub version: String,
    /// Where the images came from.
    pub corpus: String,
    /// The rate points as requested (`auto` or the list).
    pub rates: String,
    /// Timed runs per encode and decode.
    pub repeat: usize,
    /// The reference codec of the deltas.
    pub reference: String,
    /// What the metrics mean.
    pub metrics: String,
    /// The codecs, in the order asked for.
    pub codecs: Vec<CodecInfo>,
    /// The images, in corpus order.
    pub images: Vec<ImageInfo>,
    /// Every measured point.
    pub measurements: Vec<Measurement>,
    /// Image/codec pairs the codec cannot represent.
    pub skipped: Vec<Skip>,
    /// Points that failed.
    pub failures: Vec<Failure>,
    /// Per image and codec: times and deltas.
    pub per_image: Vec<ImageSummary>,
    /// Per class and codec (and `all`): PSNR at fixed rates, mean deltas, times.
    pub classes: Vec<ClassSummary>,
}

impl Report {
    /// The report as pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("the report is plain data");
        s.push('\n');
        s
    }

    /// Markdown: per class (and for the whole corpus) a table and the BD-rates by
    /// rate window, then notes on skipped and failed points.
    pub fn to_markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(md, "Corpus: {}; rates: {}.\n", self.corpus, self.rates);
        for c in &self.codecs {
            let _ = writeln!(md, "- `{}`: {}", c.name, c.description);
        }
        md.push('\n');
        let mut classes: Vec<&str> = Vec::new();
        for c in &self.classes {
            if !classes.contains(&c.class.as_str()) {
                classes.push(&c.class);
            }
        }
        for class in classes {
            let rows: Vec<&ClassSummary> =
                self.classes.iter().filter(|c| c.class == class).collect();
            let images = rows.iter().map(|r| r.images).max().unwrap_or(0);
            let title = if class == ALL_CLASSES {
                "all classes".to_string()
            } else {
                class.to_string()
            };
            let _ = writeln!(md, "### {title} ({images} images)\n");
            let rates: Vec<String> = rows[0]
                .psnr_at
                .iter()
                .map(|p| format!("PSNR@{:?}", p.bpp))
                .collect();
            let _ = writeln!(
                md,
                "| codec | {} | BD-rate vs {} | BD-PSNR | encode ms | decode ms |",
                rates.join(" | "),
                self.reference
            );
            let _ = writeln!(md, "|---|{}---|---|---|---|", "---|".repeat(rates.len()));
            for &r in &rows {
                let psnr: Vec<String> = r
                    .psnr_at
                    .iter()
                    .map(|p| match p.psnr {
                        None => "–".into(),
                        Some(v) if p.images < r.images => {
                            format!("{v:.2} ({}/{})", p.images, r.images)
                        }
                        Some(v) => format!("{v:.2}"),
                    })
                    .collect();
                let partial = |s: String| {
                    if r.bd_images < r.images {
                        format!("{s} ({}/{})", r.bd_images, r.images)
                    } else {
                        s
                    }
                };
                let (bd_rate, bd_psnr) = if r.codec == self.reference {
                    ("(reference)".to_string(), String::new())
                } else {
                    (
                        r.bd_rate
                            .map_or("–".into(), |v| partial(format!("{v:+.1}%"))),
                        r.bd_psnr.map_or("–".into(), |v| format!("{v:+.2} dB")),
                    )
                };
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {} | {} | {} |",
                    r.codec,
                    psnr.join(" | "),
                    bd_rate,
                    bd_psnr,
                    fmt_ms(r.encode_ms),
                    fmt_ms(r.decode_ms)
                );
            }
            md.push('\n');
            self.window_table(&mut md, &rows);
            self.metric_table(&mut md, &rows);
        }
        if !self.skipped.is_empty() {
            let _ = writeln!(md, "Skipped (the codec cannot represent the image):\n");
            for s in &self.skipped {
                let _ = writeln!(md, "- {} on {}: {}", s.codec, s.image, s.reason);
            }
            md.push('\n');
        }
        if !self.failures.is_empty() {
            // Grouped by codec and message: a codec that cannot encode at all fails the
            // same way on every point, and one line says so.
            let _ = writeln!(md, "Failed points:\n");
            let mut groups: Vec<(&str, &str, Vec<&str>)> = Vec::new();
            for f in &self.failures {
                match groups
                    .iter_mut()
                    .find(|(c, e, _)| *c == f.codec && *e == f.error)
                {
                    Some((_, _, images)) => images.push(&f.image),
                    None => groups.push((&f.codec, &f.error, vec![&f.image])),
                }
            }
            for (codec, error, images) in groups {
                let mut distinct = images.clone();
                distinct.dedup();
                let _ = writeln!(
                    md,
                    "- {codec}, {} points on {} images ({}): {error}",
                    images.len(),
                    distinct.len(),
                    distinct.join(", ")
                );
            }
            md.push('\n');
        }
        md
    }

    /// The class's BD-rates by rate window, one row per codec other than the
    /// reference (nothing when there is none).
    fn window_table(&self, md: &mut String, rows: &[&ClassSummary]) {
        let keep = |r: &ClassSummary| !r.bd_rate_windows.is_empty();
        let Some(rows) = self.reference_table(md, rows, keep, "by rate window", &["codec"]) else {
            return;
        };
        for r in rows {
            let cells = window_cells(&r.bd_rate_windows);
            let _ = writeln!(md, "| {} | {} |", r.codec, cells.join(" | "));
        }
        md.push('\n');
    }

    /// The rows of a table of BD-rates against the reference: those of the codecs
    /// other than the reference that `keep` takes. Writes the table's title (`what`)
    /// and head, the columns `leading` and then the rate windows'; nothing, and no
    /// rows, when `keep` takes none.
    fn reference_table<'a>(
        &self,
        md: &mut String,
        rows: &[&'a ClassSummary],
        keep: impl Fn(&ClassSummary) -> bool,
        what: &str,
        leading: &[&str],
    ) -> Option<Vec<&'a ClassSummary>> {
        let rows: Vec<&ClassSummary> = rows
            .iter()
            .copied()
            .filter(|r| r.codec != self.reference && keep(r))
            .collect();
        let heads = window_heads(rows.first()?);
        let _ = writeln!(md, "BD-rate vs {} {what}:\n", self.reference);
        let _ = writeln!(md, "| {} | {} |", leading.join(" | "), heads.join(" | "));
        let columns = leading.len() + heads.len();
        let _ = writeln!(md, "|{}", "---|".repeat(columns));
        Some(rows)
    }
}

impl Report {
    /// The class's BD-rates by each metric, overall and by rate window, one row per
    /// codec other than the reference and metric (nothing when there is none).
    fn metric_table(&self, md: &mut String, rows: &[&ClassSummary]) {
        let keep = |r: &ClassSummary| !r.perceptual.is_empty();
        let leading = ["codec", "metric", "overall"];
        let Some(rows) = self.reference_table(md, rows, keep, "by metric", &leading) else {
            return;
        };
        for r in rows {
            let psnr = window_cells(&r.bd_rate_windows);
            let _ = writeln!(
                md,
                "| {} | RGB PSNR | {} | {} |",
                r.codec,
                bd_cell(r.bd_rate, r.bd_images),
                psnr.join(" | ")
            );
            for p in &r.perceptual {
                let windows = window_cells(&p.windows);
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {} |",
                    r.codec,
                    metric_title(&p.metric),
                    bd_cell(p.bd_rate, p.images),
                    windows.join(" | ")
                );
            }
        }
        md.push('\n');
    }
}

/// The column heads of the rate windows.
fn window_heads(row: &ClassSummary) -> Vec<String> {
    row.bd_rate_windows
        .iter()
        .map(|w| format!("{}–{} bpp", w.lo, w.hi))
        .collect()
}

/// The BD-rate cells of the rate windows.
fn window_cells(windows: &[WindowBdMean]) -> Vec<String> {
    windows
        .iter()
        .map(|w| bd_cell(w.bd_rate, w.images))
        .collect()
}

/// A BD-rate cell: the percentage and how many images it covers, or a dash.
fn bd_cell(v: Option<f64>, images: usize) -> String {
    match v {
        Some(v) => format!("{v:+.1}% ({images})"),
        None => "–".into(),
    }
}

/// How a metric is named in the tables.
fn metric_title(name: &str) -> &str {
    match name {
        "ms-ssim" => "MS-SSIM",
        "ssimulacra2" => "SSIMULACRA2",
        other => other,
    }
}

/// Times with sensible precision.
fn fmt_ms(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v < 10.0 {
        format!("{v:.2}")
    } else if v < 100.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.0}")
    }
}

#[cfg(test)]
mod tests {
    use super::super::summary::{WindowBdMean, BD_WINDOWS};
    use super::*;

    fn row(codec: &str, windows: [(Option<f64>, usize); 3]) -> ClassSummary {
        ClassSummary {
            class: "scene".into(),
            codec: codec.into(),
            images: 3,
            psnr_at: Vec::new(),
            bd_rate: None,
            bd_psnr: None,
            bd_rate_y: None,
            bd_images: 0,
            bd_rate_windows: BD_WINDOWS
                .iter()
                .zip(windows)
                .map(|(&(lo, hi), (bd_rate, images))| WindowBdMean {
                    lo,
                    hi,
                    bd_rate,
                    images,
                })
                .collect(),
            perceptual: Vec::new(),
            encode_ms: 1.0,
            decode_ms: 1.0,
        }
    }

    #[test]
    fn window_table_has_a_row_per_compared_codec() {
        let report = Report {
            format: FORMAT.into(),
            version: String::new(),
            corpus: String::new(),
            rates: String::new(),
            repeat: 1,
            reference: "jpeg".into(),
            metrics: METRICS_NOTE.into(),
            codecs: Vec::new(),
            images: Vec::new(),
            measurements: Vec::new(),
            skipped: Vec::new(),
            failures: Vec::new(),
            per_image: Vec::new(),
            classes: vec![
                row("jpeg", [(None, 0); 3]),
                row("webp", [(Some(12.34), 3), (Some(-5.0), 2), (None, 0)]),
            ],
        };
        let md = report.to_markdown();
        let table = "BD-rate vs jpeg by rate window:\n\n\
                     | codec | 0.05–0.3 bpp | 0.3–0.8 bpp | 0.8–2 bpp |\n\
                     |---|---|---|---|\n\
                     | webp | +12.3% (3) | -5.0% (2) | – |\n";
        assert!(md.contains(table), "{md}");

        // The reference alone: no window table.
        let mut alone = report.clone();
        alone.classes.truncate(1);
        assert!(!alone.to_markdown().contains("by rate window"));
    }
}

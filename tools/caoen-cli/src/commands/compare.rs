//! `caoen compare A B`: quality of B against the reference A (PSNR, Y-PSNR, SSIM,
//! SSIMULACRA2). Either may be an image file or a caoen file (`.cae`, decoded first).

use std::path::Path;

use caoen::codec::{self, DecodeOptions};
use caoen::metrics::{self, Comparison};
use caoen::raster::{ChannelLayout, Raster, SampleFormat};
use serde_json::json;

use crate::cli::{CompareArgs, GlobalArgs};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::print;

/// Extension of caoen files.
pub const CAE_EXTENSION: &str = "cae";

/// Whether a path names a caoen file (by its `.cae` extension).
pub fn is_cae(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(CAE_EXTENSION))
}

/// Reads an image file, or decodes a caoen file, into a raster.
pub fn load_any(path: &Path, limits: &caoen::Limits) -> CliResult<Raster> {
    if is_cae(path) {
        let bytes = limits.read(path).map_err(|e| CliError::io(path, e))?;
        codec::decode(&bytes, &DecodeOptions::default())
            .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))
    } else {
        // Upright by the EXIF orientation, as `caoen encode` reads it.
        crate::commands::codec::load_image(path, limits)
    }
}

/// A short description of a raster: `512x384 RGB 8-bit`.
pub fn describe(r: &Raster) -> String {
    let layout = match r.layout() {
        ChannelLayout::Grey => "grey",
        ChannelLayout::GreyAlpha => "grey+alpha",
        ChannelLayout::Rgb => "RGB",
        ChannelLayout::Rgba => "RGBA",
    };
    let format = match r.format() {
        SampleFormat::U8 => "8-bit",
        SampleFormat::U16 => "16-bit",
        SampleFormat::F32 => "float",
    };
    format!("{}x{} {layout} {format}", r.width(), r.height())
}

/// A number for JSON: non-finite values (an identical image's PSNR) become `null`.
fn finite(v: f64) -> serde_json::Value {
    if v.is_finite() {
        json!(v)
    } else {
        serde_json::Value::Null
    }
}

/// The JSON object of a comparison (the `--json` output without the file names).
pub fn comparison_json(c: &Comparison) -> serde_json::Value {
    json!({
        "scale": c.scale.name(),
        "identical": c.mse == 0.0 && c.mse_y == 0.0,
        "psnr": finite(c.psnr),
        "psnr_y": finite(c.psnr_y),
        "ssim": c.ssim,
        "ms_ssim": c.ms_ssim,
        "ssimulacra2": c.ssimulacra2,
        "psnr_alpha": c.psnr_alpha.map(finite),
        "mse": c.mse,
        "mse_y": c.mse_y,
    })
}

/// Formats a PSNR for people: `inf` when identical.
fn db(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3} dB")
    } else {
        "inf dB (identical)".into()
    }
}

/// Runs `caoen compare`.
pub fn run(global: &GlobalArgs, args: &CompareArgs) -> CliResult {
    let a = load_any(&args.reference, &global.limits)?;
    let b = load_any(&args.test, &global.limits)?;
    note(
        global,
        format!(
            "{} ({}) vs {} ({})",
            args.reference.display(),
            describe(&a),
            args.test.display(),
            describe(&b)
        ),
    );
    let c = metrics::compare(&a, &b).map_err(|e| {
        CliError::Failed(format!(
            "cannot compare {} with {}: {e}",
            args.reference.display(),
            args.test.display()
        ))
    })?;
    let mut text = String::new();
    if args.json {
        let mut v = comparison_json(&c);
        v["reference"] = json!(args.reference.display().to_string());
        v["test"] = json!(args.test.display().to_string());
        v["width"] = json!(a.width());
        v["height"] = json!(a.height());
        outln!(
            text,
            "{}",
            serde_json::to_string_pretty(&v).expect("json of plain values")
        );
    } else {
        let scale = match c.scale {
            metrics::Scale::Display => "",
            metrics::Scale::LogHdr => " (HDR: log scale)",
        };
        outln!(text, "PSNR         {}{scale}", db(c.psnr));
        outln!(text, "Y-PSNR       {}", db(c.psnr_y));
        outln!(text, "SSIM         {:.6}", c.ssim);
        outln!(text, "MS-SSIM      {:.6}", c.ms_ssim);
        match c.ssimulacra2 {
            Some(s) => outln!(text, "SSIMULACRA2  {s:.3}"),
            None => outln!(text, "SSIMULACRA2  n/a (HDR or smaller than 8x8)"),
        }
        if let Some(p) = c.psnr_alpha {
            outln!(text, "alpha PSNR   {}", db(p));
        }
    }
    print(text)
}

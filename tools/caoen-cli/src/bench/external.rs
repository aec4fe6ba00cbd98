//! Peer codecs run as their command-line tools, as users run them: AVIF through
//! libavif's `avifenc`/`avifdec` (Debian `libavif-bin`) and JPEG XL through `cjxl`/`djxl`
//! (Debian `libjxl-tools`).
//!
//! - `avif`: `avifenc -c aom -s 6 -y 420 --min Q --max Q` (constant quantiser Q in 0..=63;
//!   the quality knob q maps to `Q = round(63 (100 - q) / 100)`), decoded by `avifdec`
//!   (its default AV1 decoder) to an 8-bit PNG.
//! - `avif444`: the same with full-resolution chroma (`-y 444`).
//! - `jxl`: `cjxl -e 7 -q q`, decoded by `djxl` to a PNG; q is raised to at least
//!   [`JXL_MIN_QUALITY`] (below it cjxl 0.7 refuses the distance the quality maps to).
//!
//! Each tool runs with one thread (`-j 1`, `--num_threads=1`), so the times compare with
//! the in-process peers' single-threaded libraries. The input is handed over as an 8-bit
//! PNG written before the clock starts; the times are those of the processes alone, from
//! spawn to exit (a decoder's time includes writing its PNG, as a user's would). Grey
//! images go in as grey PNGs (AVIF then codes 4:0:0).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use caoen::raster::Raster;

use super::codecs::{eight_bit_only, interleaved_u8, raster_from_u8, Codec, Setting};

/// Names of the command-line peers.
pub const EXTERNAL_NAMES: [&str; 3] = ["avif", "avif444", "jxl"];

/// The command-line peer called `name`: `Ok(None)` for another name, an error naming the
/// missing program and its Debian package when a tool is not installed.
pub fn by_name(name: &str) -> Result<Option<Box<dyn Codec>>, String> {
    let codec: Box<dyn Codec> = match name {
        "avif" => Box::new(Avif { chroma_444: false }),
        "avif444" => Box::new(Avif { chroma_444: true }),
        "jxl" => Box::new(Jxl),
        _ => return Ok(None),
    };
    let (tools, package) = match name {
        "jxl" => (["cjxl", "djxl"], "libjxl-tools"),
        _ => (["avifenc", "avifdec"], "libavif-bin"),
    };
    for tool in tools {
        if find_program(tool).is_none() {
            return Err(format!(
                "codec `{name}` is not available: `{tool}` is not on PATH (install the \
                 Debian package {package})"
            ));
        }
    }
    Ok(Some(codec))
}

/// The first executable called `name` in `PATH`.
fn find_program(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|p| p.is_file())
}

/// Runs `program` with `args`, returning the wall time in ms, or its stderr's last line
/// as the error.
fn run_tool(program: &str, args: &[&std::ffi::OsStr]) -> Result<f64, String> {
    let start = Instant::now();
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|e| format!("{program}: {e}"))?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    if out.status.success() {
        Ok(ms)
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        let out_text = String::from_utf8_lossy(&out.stdout);
        let line = err
            .lines()
            .chain(out_text.lines())
            .rfind(|l| !l.trim().is_empty())
            .unwrap_or("no message")
            .trim()
            .to_string();
        Err(format!("{program} failed ({}): {line}", out.status))
    }
}

/// A scratch folder for one call, removed when dropped.
fn scratch() -> Result<tempfile::TempDir, String> {
    tempfile::Builder::new()
        .prefix("caoen-bench-")
        .tempdir()
        .map_err(|e| format!("temporary folder: {e}"))
}

/// The image as an 8-bit PNG file (grey, grey+alpha, RGB or RGBA as the raster is).
fn write_png(image: &Raster, path: &Path) -> Result<(), String> {
    let data = interleaved_u8(image, false);
    let colour = match (image.layout().colour_channels(), image.layout().has_alpha()) {
        (1, false) => image::ExtendedColorType::L8,
        (1, true) => image::ExtendedColorType::La8,
        (_, false) => image::ExtendedColorType::Rgb8,
        (_, true) => image::ExtendedColorType::Rgba8,
    };
    image::save_buffer_with_format(
        path,
        &data,
        image.width(),
        image.height(),
        colour,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("writing the input PNG: {e}"))
}

/// A decoder's PNG output as a raster in the reference's layout.
fn read_png(path: &Path, reference: &Raster) -> Result<Raster, String> {
    let img = image::open(path).map_err(|e| format!("reading the decoded PNG: {e}"))?;
    let (w, h) = (img.width(), img.height());
    let layout = reference.layout();
    match (layout.colour_channels(), layout.has_alpha()) {
        (1, false) => raster_from_u8(img.to_luma8().as_raw(), 1, w, h, reference),
        (1, true) => raster_from_u8(img.to_luma_alpha8().as_raw(), 2, w, h, reference),
        (_, false) => raster_from_u8(img.to_rgb8().as_raw(), 3, w, h, reference),
        (_, true) => raster_from_u8(img.to_rgba8().as_raw(), 4, w, h, reference),
    }
}

fn quality_of(setting: Setting) -> Result<f32, String> {
    match setting {
        Setting::Quality(q) => Ok(q.clamp(0.0, 100.0)),
        Setting::Bpp(_) => Err("no native rate control".into()),
    }
}

/// Encodes through `encode_args(input, output)` with `program`, timing the process.
fn encode_with(
    image: &Raster,
    extension: &str,
    program: &str,
    encode_args: impl FnOnce(&Path, &Path) -> Vec<std::ffi::OsString>,
) -> Result<(Vec<u8>, f64), String> {
    let dir = scratch()?;
    let (input, output) = (
        dir.path().join("in.png"),
        dir.path().join(format!("out.{extension}")),
    );
    write_png(image, &input)?;
    let args = encode_args(&input, &output);
    let refs: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_os_str()).collect();
    let ms = run_tool(program, &refs)?;
    let bytes = std::fs::read(&output).map_err(|e| format!("{program} output: {e}"))?;
    Ok((bytes, ms))
}

/// Decodes `bytes` with `program input output.png [extra...]`, timing the process.
fn decode_with(
    bytes: &[u8],
    reference: &Raster,
    extension: &str,
    program: &str,
    extra: &[&str],
) -> Result<(Raster, f64), String> {
    let dir = scratch()?;
    let (input, output) = (
        dir.path().join(format!("in.{extension}")),
        dir.path().join("out.png"),
    );
    std::fs::write(&input, bytes).map_err(|e| format!("writing the encoded file: {e}"))?;
    let mut args: Vec<&std::ffi::OsStr> = extra.iter().map(std::ffi::OsStr::new).collect();
    args.push(input.as_os_str());
    args.push(output.as_os_str());
    let ms = run_tool(program, &args)?;
    Ok((read_png(&output, reference)?, ms))
}

/// AVIF through libavif's tools with the aom encoder.
struct Avif {
    /// Full-resolution chroma instead of 4:2:0.
    chroma_444: bool,
}

impl Avif {
    /// The constant quantiser for quality `q`.
    fn quantiser(q: f32) -> u32 {
        (63.0 * (100.0 - q) / 100.0).round().clamp(0.0, 63.0) as u32
    }
}

impl Codec for Avif {
    fn name(&self) -> &'static str {
        if self.chroma_444 {
            "avif444"
        } else {
            "avif"
        }
    }

    fn description(&self) -> String {
        format!(
            "avifenc (libavif, aom) speed 6, {}, constant quantiser, one thread; decoded by \
             avifdec; whole processes",
            if self.chroma_444 { "4:4:4" } else { "4:2:0" }
        )
    }

    fn extension(&self) -> &'static str {
        "avif"
    }

    fn supports(&self, image: &Raster) -> Result<(), String> {
        eight_bit_only(image)
    }

    fn default_qualities(&self) -> Vec<f32> {
        // Quantisers 60, 54, 47, 40, 33, 26, 19, 12.
        [60u32, 54, 47, 40, 33, 26, 19, 12]
            .iter()
            .map(|&q| 100.0 - q as f32 * 100.0 / 63.0)
            .collect()
    }

    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
        self.encode_timed(image, setting).map(|(b, _)| b)
    }

    fn encode_timed(&self, image: &Raster, setting: Setting) -> Result<(Vec<u8>, f64), String> {
        let q = Self::quantiser(quality_of(setting)?).to_string();
        let grey = image.layout().colour_channels() == 1;
        let yuv = if self.chroma_444 { "444" } else { "420" };
        encode_with(image, "avif", "avifenc", |input, output| {
            let mut a: Vec<std::ffi::OsString> = ["-c", "aom", "-s", "6", "-j", "1", "-d", "8"]
                .iter()
                .map(Into::into)
                .collect();
            if !grey {
                a.extend(["-y".into(), yuv.into()]);
            }
            a.extend([
                "--min".into(),
                q.clone().into(),
                "--max".into(),
                q.into(),
                input.into(),
                output.into(),
            ]);
            a
        })
    }

    fn decode(&self, bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
        self.decode_timed(bytes, reference).map(|(r, _)| r)
    }

    fn decode_timed(&self, bytes: &[u8], reference: &Raster) -> Result<(Raster, f64), String> {
        decode_with(bytes, reference, "avif", "avifdec", &["-j", "1", "-d", "8"])
    }
}

/// The lowest quality cjxl accepts (distance 25).
pub const JXL_MIN_QUALITY: f32 = 5.0;

/// JPEG XL through libjxl's tools.
struct Jxl;

impl Codec for Jxl {
    fn name(&self) -> &'static str {
        "jxl"
    }

    fn description(&self) -> String {
        "cjxl (libjxl) effort 7, quality knob, one thread; decoded by djxl; whole processes".into()
    }

    fn extension(&self) -> &'static str {
        "jxl"
    }

    fn supports(&self, image: &Raster) -> Result<(), String> {
        eight_bit_only(image)
    }

    fn default_qualities(&self) -> Vec<f32> {
        vec![10.0, 25.0, 40.0, 55.0, 70.0, 80.0, 88.0, 95.0]
    }

    fn encode(&self, image: &Raster, setting: Setting) -> Result<Vec<u8>, String> {
        self.encode_timed(image, setting).map(|(b, _)| b)
    }

    fn encode_timed(&self, image: &Raster, setting: Setting) -> Result<(Vec<u8>, f64), String> {
        let q = format!("{}", quality_of(setting)?.max(JXL_MIN_QUALITY));
        encode_with(image, "jxl", "cjxl", |input, output| {
            vec![
                input.into(),
                output.into(),
                "-e".into(),
                "7".into(),
                "-q".into(),
                q.into(),
                "--num_threads=1".into(),
                "--quiet".into(),
            ]
        })
    }

    fn decode(&self, bytes: &[u8], reference: &Raster) -> Result<Raster, String> {
        self.decode_timed(bytes, reference).map(|(r, _)| r)
    }

    fn decode_timed(&self, bytes: &[u8], reference: &Raster) -> Result<(Raster, f64), String> {
        decode_with(
            bytes,
            reference,
            "jxl",
            "djxl",
            &["--num_threads=1", "--quiet"],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantisers_span_the_range_and_the_ladder_maps_back() {
        assert_eq!(Avif::quantiser(100.0), 0);
        assert_eq!(Avif::quantiser(0.0), 63);
        let ladder: Vec<u32> = Avif { chroma_444: false }
            .default_qualities()
            .into_iter()
            .map(Avif::quantiser)
            .collect();
        assert_eq!(ladder, [60, 54, 47, 40, 33, 26, 19, 12]);
    }
}

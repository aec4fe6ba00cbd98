//! `caoen demo` (and `caoen` with no command): the main job on built-in data.
//!
//! Encodes a built-in corpus image (a 768x512 photo-like scene, generated, so no input
//! file is needed), decodes it, writes the original, the `.cae` file and the decoded
//! image, and prints size, bits per pixel, PSNR and times.

use std::time::Instant;

use caoen::codec::{DecodeOptions, EncodeOptions};
use caoen::image_io;
use caoen::metrics;
use caoen_corpus::Class;

use crate::cli::{DemoArgs, GlobalArgs};
use crate::failure::{CliError, CliResult};
use crate::output::{print, replace_file};

/// Runs the demo into `args.out_dir`; its own files there are replaced without
/// `--force`, as regenerating them is the demo's job.
pub fn run(global: &GlobalArgs, args: &DemoArgs) -> CliResult {
    let dir = &args.out_dir;
    let corpus = caoen_corpus::generate(Class::Scene, 768, 512, 4);
    let original = image_io::from_dynamic(corpus.to_dynamic_image())
        .map_err(|e| CliError::Failed(format!("built-in image: {e}")))?;
    let save = |name: &str, raster: &caoen::raster::Raster| -> CliResult<std::path::PathBuf> {
        let path = dir.join(name);
        let bytes = image_io::encode(raster, image_io::OutputFormat::natural(raster.format()))
            .map_err(|e| crate::commands::codec::encode_error(&path, e))?;
        replace_file(&path, &bytes)?;
        Ok(path)
    };
    let orig_path = save("scene-original.png", &original)?;
    let opts = EncodeOptions::default();
    let t = Instant::now();
    let bytes =
        caoen::codec::encode(&original, &opts).map_err(|e| CliError::Failed(e.to_string()))?;
    let encode_s = t.elapsed().as_secs_f64();
    let cae_path = dir.join("scene.cae");
    replace_file(&cae_path, &bytes)?;
    let t = Instant::now();
    let decoded = caoen::codec::decode(&bytes, &DecodeOptions::default())
        .map_err(|e| CliError::Failed(e.to_string()))?;
    let decode_s = t.elapsed().as_secs_f64();
    let dec_path = save("scene-decoded.png", &decoded)?;
    let psnr = metrics::psnr(&original, &decoded).map_err(|e| CliError::Failed(e.to_string()))?;
    let bpp = bytes.len() as f64 * 8.0 / original.pixel_count() as f64;
    let threads = rayon::current_num_threads();
    let mut text = String::new();
    outln!(
        text,
        "built-in image: corpus scene #4, {}x{} RGB",
        original.width(),
        original.height()
    );
    outln!(text, "wrote {} (original)", orig_path.display());
    outln!(
        text,
        "wrote {} ({} bytes, {bpp:.3} bpp at quality {})",
        cae_path.display(),
        bytes.len(),
        opts.quality
    );
    outln!(text, "wrote {} (decoded)", dec_path.display());
    outln!(
        text,
        "PSNR {psnr:.2} dB; encode {encode_s:.2} s, decode {decode_s:.3} s on {threads} threads"
    );
    print(text)?;
    if !global.quiet {
        eprintln!("next: caoen encode your.png -o your.cae; caoen decode your.cae -o back.png; caoen --help");
    }
    Ok(())
}

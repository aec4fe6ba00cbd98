//! Folders: `caoen encode DIR -o OUT` and `caoen decode DIR -o OUT` on every file of a
//! tree. Each file is coded exactly as the single-file command codes it (the same
//! functions, the same options, a budget of `--max-memory` of its own, so the same
//! bytes), files run in parallel on the command's threads, one progress bar counts
//! files and bytes, and a file that fails is reported while the rest go on.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use caoen::codec::{Limits, PixelSource};
use caoen::image_io::{self, FormatChoice, OutputFormat};
use rayon::prelude::*;
use serde_json::json;

use crate::cli::{DecodeArgs, EncodeArgs, GlobalArgs};
use crate::commands::{codec, note};
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, print, Outputs, Target};

/// One input file of the tree.
struct Job {
    /// The file.
    input: PathBuf,
    /// Its path below the input folder.
    rel: PathBuf,
    /// Its size in bytes.
    bytes: u64,
}

/// What became of one file.
enum Outcome {
    /// Written now.
    Done(Written),
    /// Already complete (`--resume`).
    Skipped(Written),
    /// Not written: the output, where it was known, and why.
    Failed(Option<PathBuf>, String),
}

/// An output file and what it holds.
struct Written {
    output: PathBuf,
    /// The output's bytes.
    bytes: u64,
    /// The `.cae` file's bytes (the output's when encoding, the input's when decoding).
    cae_bytes: u64,
    /// The image's pixels.
    pixels: u64,
    /// Seconds spent on the file.
    seconds: f64,
}

/// Whether a file is a `.cae` file by its name.
fn is_cae(path: &Path) -> bool {
    extension_lowercase(path).is_some_and(|ext| ext == "cae")
}

/// The files under `root` that `wanted` accepts, in name order. Symbolic links to
/// files are followed, links to folders are not (no loops), and the output folder is
/// not entered when it lies inside the input's tree.
fn walk(root: &Path, out: &Path, wanted: fn(&Path) -> bool) -> CliResult<Vec<Job>> {
    let out_real = std::fs::canonicalize(out).ok();
    let root_real = std::fs::canonicalize(root).map_err(|e| CliError::io(root, e))?;
    let mut jobs = Vec::new();
    let mut dirs = vec![root.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|e| CliError::io(&dir, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| CliError::io(&dir, e))?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| CliError::io(&path, e))?;
            if kind.is_dir() {
                let real = std::fs::canonicalize(&path).ok();
                if real.is_none() || real != out_real || real.as_ref() == Some(&root_real) {
                    dirs.push(path);
                }
                continue;
            }
            let meta = match std::fs::metadata(&path) {
                Ok(m) if m.is_file() => m,
                _ => continue,
            };
            if wanted(&path) {
                let rel = path.strip_prefix(root).unwrap_or(&path).to_path_buf();
                jobs.push(Job {
                    input: path,
                    rel,
                    bytes: meta.len(),
                });
            }
        }
    }
    jobs.sort_by(|a, b| a.rel.cmp(&b.rel));
    Ok(jobs)
}

/// The output folder of a folder command: `-o` is required and must be a folder
/// (created if missing).
fn output_folder(output: Option<&Path>, command: &str) -> CliResult<PathBuf> {
    let out = output.ok_or_else(|| {
        CliError::Usage(format!(
            "caoen {command} DIR needs -o OUT_DIR, the folder to write into"
        ))
    })?;
    if out.as_os_str() == "-" {
        return Err(CliError::Usage(format!(
            "caoen {command} DIR writes files: -o must name a folder, not standard output"
        )));
    }
    if out.exists() && !out.is_dir() {
        return Err(CliError::Usage(format!(
            "{}: is not a folder; a folder input needs an output folder",
            out.display()
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| CliError::io(out, e))?;
    Ok(out.to_path_buf())
}

/// The message of a failure on `input`, naming the file once.
fn failure_text(input: &Path, e: &CliError) -> String {
    let chain = e.chain();
    let name = input.display().to_string();
    if chain.contains(&name) {
        chain
    } else {
        format!("{name}: {chain}")
    }
}

/// Writes `bytes` to `output` under the output rule, creating its folder.
fn write(outputs: &Outputs, output: &Path, bytes: &[u8]) -> CliResult {
    if let Some(parent) = output.parent() {
        std::fs::create_dir_all(parent).map_err(|e| CliError::io(parent, e))?;
    }
    outputs.write(&Target::Named(output.to_path_buf()), bytes)
}

/// The pixels of `output` if it is a whole `.cae` file: every section present, every
/// CRC right.
fn complete_cae(output: &Path) -> Option<u64> {
    let bytes = std::fs::read(output).ok()?;
    let parsed = caoen::codec::inspect(&bytes).ok()?;
    let (w, h) = parsed.header.display_size();
    Some(u64::from(w) * u64::from(h))
}

/// The pixels of `output` if it is a whole image file that decodes.
fn complete_image(output: &Path, budget: u64) -> Option<u64> {
    let limits = image_io::LoadLimits {
        max_pixels: caoen::codec::DEFAULT_MAX_PIXELS,
        ..image_io::LoadLimits::within(&Limits::new(budget))
    };
    let raster = image_io::load_with_limits(output, &limits).ok()?;
    Some(raster.pixel_count() as u64)
}

/// The size of a file, 0 if unknown.
fn size_of(path: &Path) -> u64 {
    std::fs::metadata(path).map_or(0, |m| m.len())
}

/// `caoen encode DIR -o OUT`: every image in the tree, as `OUT/<same path>.cae`.
pub fn encode(global: &GlobalArgs, a: &EncodeArgs) -> CliResult {
    if a.keypoint_map.is_some() {
        return Err(CliError::Usage(
            "--keypoint-map is for a single image, not a folder".into(),
        ));
    }
    // A contradictory request is the same for every file: refused once, up front.
    codec::encode_request(global, a, Default::default())
        .options(0)
        .map_err(|e| crate::failure::codec(&a.input, e))?;
    let out = output_folder(a.output.as_deref(), "encode")?;
    let jobs = walk(&a.input, &out, image_io::is_image_name)?;
    let outputs_of: Vec<PathBuf> = jobs
        .iter()
        .map(|j| out.join(&j.rel).with_extension("cae"))
        .collect();
    // Two inputs with one output (`a.png`, `a.jpg`): the first in name order has it.
    let mut first = std::collections::HashMap::new();
    let first_of: Vec<usize> = (0..jobs.len())
        .map(|i| *first.entry(&outputs_of[i]).or_insert(i))
        .collect();
    run(global, &jobs, "encoded", a.json, |i, job| {
        let output = outputs_of[i].clone();
        if first_of[i] != i {
            let other = jobs[first_of[i]].input.display();
            return Outcome::Failed(
                Some(output),
                format!("{}: has the same output as {other}", job.input.display()),
            );
        }
        if a.resume {
            if let Some(pixels) = complete_cae(&output) {
                let bytes = size_of(&output);
                return Outcome::Skipped(Written {
                    output,
                    bytes,
                    cae_bytes: bytes,
                    pixels,
                    seconds: 0.0,
                });
            }
        }
        let start = Instant::now();
        let done = (|| -> CliResult<(u64, u64)> {
            let mut outputs = Outputs::new(global.force).input(&job.input);
            outputs.check(&Target::Named(output.clone()))?;
            let limits = Limits::new(global.max_memory);
            let loaded = codec::load_for_encode(global, a, &job.input, &limits)?;
            let pixels = u64::from(loaded.img.width()) * u64::from(loaded.img.height());
            let (bytes, _) = codec::encode_loaded(global, &loaded, &job.input, |_, _| {})?;
            write(&outputs, &output, &bytes)?;
            Ok((bytes.len() as u64, pixels))
        })();
        match done {
            Ok((bytes, pixels)) => Outcome::Done(Written {
                output,
                bytes,
                cae_bytes: bytes,
                pixels,
                seconds: start.elapsed().as_secs_f64(),
            }),
            Err(e) => Outcome::Failed(Some(output), failure_text(&job.input, &e)),
        }
    })
}

/// `caoen decode DIR -o OUT`: every `.cae` file in the tree, as `OUT/<same path>.png`
/// (`.exr` for float files).
pub fn decode(global: &GlobalArgs, a: &DecodeArgs) -> CliResult {
    codec::decode_request(global, a, FormatChoice::Natural)?;
    let out = output_folder(a.output.as_deref(), "decode")?;
    let jobs = walk(&a.input, &out, is_cae)?;
    run(global, &jobs, "decoded", a.json, |_, job| {
        let start = Instant::now();
        let mut output = None;
        let done = (|| -> CliResult<Outcome> {
            let limits = Limits::new(global.max_memory);
            let cae = codec::read_input(&job.input, &limits)?;
            let header = caoen::codec::inspect(&cae)
                .map_err(|e| crate::failure::codec(&job.input, e))?
                .header;
            let format = OutputFormat::natural(header.format);
            let path = out.join(&job.rel).with_extension(format.extension());
            output = Some(path.clone());
            if a.resume {
                if let Some(pixels) = complete_image(&path, global.max_memory) {
                    return Ok(Outcome::Skipped(Written {
                        bytes: size_of(&path),
                        output: path,
                        cae_bytes: cae.len() as u64,
                        pixels,
                        seconds: 0.0,
                    }));
                }
            }
            let mut outputs = Outputs::new(global.force).input(&job.input);
            outputs.check(&Target::Named(path.clone()))?;
            let mut opts = codec::decode_request(global, a, FormatChoice::Natural)?;
            opts.decode.limits = limits;
            let image = image_io::decode_to_image(&cae, &job.input, &opts)?;
            write(&outputs, &path, &image.bytes)?;
            for d in &image.dropped {
                eprintln!("warning: {}: {d}", job.input.display());
            }
            let (w, h) = header.display_size();
            Ok(Outcome::Done(Written {
                output: path,
                bytes: image.bytes.len() as u64,
                cae_bytes: cae.len() as u64,
                pixels: u64::from(w) * u64::from(h),
                seconds: start.elapsed().as_secs_f64(),
            }))
        })();
        done.unwrap_or_else(|e| Outcome::Failed(output, failure_text(&job.input, &e)))
    })
}

/// The progress bar of a folder: files done and bytes read, with the time left.
fn progress(global: &GlobalArgs, jobs: &[Job]) -> indicatif::ProgressBar {
    if global.quiet {
        return indicatif::ProgressBar::hidden();
    }
    let total: u64 = jobs.iter().map(|j| j.bytes).sum();
    let pb = indicatif::ProgressBar::with_draw_target(
        Some(total),
        indicatif::ProgressDrawTarget::stderr(),
    );
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {binary_bytes}/{binary_total_bytes} {elapsed}, ETA {eta}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    pb.set_message(format!("0/{} files", jobs.len()));
    pb
}

/// Runs `work` on every job in parallel, reports failures as they happen, prints the
/// summary, and fails (exit 1) naming the files that failed.
fn run(
    global: &GlobalArgs,
    jobs: &[Job],
    verb: &str,
    json: bool,
    work: impl Fn(usize, &Job) -> Outcome + Sync,
) -> CliResult {
    let start = Instant::now();
    let pb = progress(global, jobs);
    let finished = AtomicUsize::new(0);
    let outcomes: Vec<Outcome> = jobs
        .par_iter()
        .enumerate()
        .map(|(i, job)| {
            let outcome = work(i, job);
            if let Outcome::Failed(_, why) = &outcome {
                // Failures are printed even with --quiet: they are the run's errors.
                pb.suspend(|| eprintln!("error: {}", caoen::surface::error::printable(why)));
            }
            let n = finished.fetch_add(1, Ordering::Relaxed) + 1;
            pb.inc(job.bytes);
            pb.set_message(format!("{n}/{} files", jobs.len()));
            outcome
        })
        .collect();
    pb.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let failed: Vec<&Path> = jobs
        .iter()
        .zip(&outcomes)
        .filter(|(_, o)| matches!(o, Outcome::Failed(..)))
        .map(|(j, _)| j.input.as_path())
        .collect();
    let (mut done, mut skipped, mut bytes_in, mut bytes_out, mut cae, mut pixels) =
        (0, 0, 0u64, 0u64, 0u64, 0u64);
    let mut files = Vec::with_capacity(jobs.len());
    for (job, outcome) in jobs.iter().zip(&outcomes) {
        let entry = match outcome {
            Outcome::Done(w) | Outcome::Skipped(w) => {
                let is_done = matches!(outcome, Outcome::Done(_));
                if is_done {
                    done += 1;
                } else {
                    skipped += 1;
                }
                bytes_in += job.bytes;
                bytes_out += w.bytes;
                cae += w.cae_bytes;
                pixels += w.pixels;
                json!({"input": job.input, "output": w.output,
                    "status": if is_done { verb } else { "skipped" },
                    "bytes_in": job.bytes, "bytes_out": w.bytes,
                    "bpp": w.cae_bytes as f64 * 8.0 / w.pixels.max(1) as f64,
                    "seconds": w.seconds})
            }
            Outcome::Failed(output, why) => json!({"input": job.input, "output": output,
                "status": "failed", "bytes_in": job.bytes, "error": why}),
        };
        files.push(entry);
    }
    if json {
        let v = json!({"files": files, "totals": {"files": jobs.len(), verb: done,
            "skipped": skipped, "failed": failed.len(), "bytes_in": bytes_in,
            "bytes_out": bytes_out, "bpp": cae as f64 * 8.0 / pixels.max(1) as f64,
            "seconds": seconds}});
        print(serde_json::to_string_pretty(&v).expect("json") + "\n")?;
    }
    note(
        global,
        format!(
            "{verb} {done} of {} files ({skipped} already complete, {} failed): {bytes_in} bytes -> {bytes_out} bytes in {seconds:.2} s",
            jobs.len(),
            failed.len()
        ),
    );
    if failed.is_empty() {
        return Ok(());
    }
    let names: Vec<String> = failed.iter().map(|p| p.display().to_string()).collect();
    Err(CliError::Failed(format!(
        "{} of {} files failed: {}",
        failed.len(),
        jobs.len(),
        names.join(", ")
    )))
}

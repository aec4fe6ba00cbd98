//! The `caoen-corpus` / `caoen corpus` command line.
//!
//! The main `caoen` binary embeds [`CorpusArgs`] as a subcommand and calls [`run`];
//! the `caoen-corpus` binary is a thin wrapper around the same two items.

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::error::CorpusError;
use crate::manifest::{Entry, Manifest, MANIFEST_NAME};
use crate::{contact, corpus, Class, Spec, MAX_SIDE};

/// Largest accepted `--seeds`.
pub const MAX_SEEDS: u64 = 10_000;

/// Generate the procedural test corpus (PNG/EXR files plus manifest.json).
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct CorpusArgs {
    /// Output directory (created if missing). A non-empty directory without a
    /// manifest.json written by caoen-corpus is refused unless --force.
    #[arg(long, value_name = "DIR", required_unless_present = "list")]
    pub out: Option<PathBuf>,

    /// Nominal image size: most images are SIZE x SIZE, wide scenes 1.5*SIZE x SIZE.
    #[arg(long, default_value_t = 512, value_name = "N")]
    pub size: u32,

    /// Comma-separated classes to generate [default: all].
    #[arg(long, value_delimiter = ',', value_name = "CLASS,...")]
    pub classes: Vec<Class>,

    /// Seeds per class (0..N) [default: per class, 43 images in all].
    #[arg(long, value_name = "N")]
    pub seeds: Option<u64>,

    /// Also write a contact sheet (PNG grid of labelled thumbnails) to this path.
    #[arg(long, value_name = "PNG")]
    pub contact_sheet: Option<PathBuf>,

    /// Overwrite files that this tool did not write. Set by the front end's own
    /// `-f/--force` (skipped here so that `caoen`'s global flag owns it).
    #[arg(skip)]
    pub force: bool,

    /// Worker threads [default: all cores]. Does not change any output. Set by the
    /// front end's own `-j/--threads` (skipped here so `caoen`'s global flag owns it).
    #[arg(skip)]
    pub threads: Option<usize>,

    /// Print the images that would be generated, then exit.
    #[arg(long)]
    pub list: bool,

    /// No progress bar or summary on stderr. Set by the front end's own `-q/--quiet`.
    #[arg(skip)]
    pub quiet: bool,
}

impl Default for CorpusArgs {
    fn default() -> Self {
        CorpusArgs {
            out: None,
            size: 512,
            classes: Vec::new(),
            seeds: None,
            contact_sheet: None,
            force: false,
            threads: None,
            list: false,
            quiet: false,
        }
    }
}

impl CorpusArgs {
    /// The specs these arguments select (validated).
    pub fn specs(&self) -> Result<Vec<Spec>, CorpusError> {
        if self.size == 0 || self.size > MAX_SIDE * 2 / 3 {
            return Err(CorpusError::InvalidArgument(format!(
                "--size {} out of range (1 to {})",
                self.size,
                MAX_SIDE * 2 / 3
            )));
        }
        if let Some(n) = self.seeds {
            if n == 0 || n > MAX_SEEDS {
                return Err(CorpusError::InvalidArgument(format!(
                    "--seeds {n} out of range (1 to {MAX_SEEDS})"
                )));
            }
        }
        if self.threads == Some(0) {
            return Err(CorpusError::InvalidArgument(
                "--threads must be at least 1".into(),
            ));
        }
        let mut classes: Vec<Class> = Vec::new();
        for c in if self.classes.is_empty() {
            Class::ALL.to_vec()
        } else {
            self.classes.clone()
        } {
            if !classes.contains(&c) {
                classes.push(c);
            }
        }
        Ok(corpus(self.size, &classes, self.seeds))
    }
}

/// The path an error on standard output names (`caoen corpus --list | head`).
pub const STDOUT: &str = "standard output";

/// Run the command: generate, write files and manifest, optionally a contact sheet.
pub fn run(args: &CorpusArgs) -> Result<(), CorpusError> {
    let specs = args.specs()?;
    if args.list {
        let stdout_error = |source| CorpusError::Io {
            path: STDOUT.into(),
            source,
        };
        let mut out = std::io::stdout().lock();
        for s in &specs {
            writeln!(out, "{}\t{}", s.file_name(), s.class.variant_name(s.seed))
                .map_err(stdout_error)?;
        }
        return out.flush().map_err(stdout_error);
    }
    let out = args
        .out
        .as_deref()
        .ok_or_else(|| CorpusError::InvalidArgument("--out DIR is required".into()))?;
    let opts = WriteOptions {
        force: args.force,
        quiet: args.quiet,
        contact_sheet: args.contact_sheet.clone(),
        size: args.size,
    };
    let job = || write_corpus(out, &specs, &opts);
    let start = Instant::now();
    let manifest = match args.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(CorpusError::ThreadPool)?
            .install(job)?,
        None => job()?,
    };
    if !args.quiet {
        eprintln!(
            "caoen-corpus: wrote {} images and {} to {} in {:.1} s",
            specs.len(),
            MANIFEST_NAME,
            out.display(),
            start.elapsed().as_secs_f64()
        );
        if let Some(sheet) = &args.contact_sheet {
            eprintln!("caoen-corpus: contact sheet {}", sheet.display());
        }
    }
    let _ = manifest;
    Ok(())
}

/// Options of [`write_corpus`].
#[derive(Clone, Debug, Default)]
pub struct WriteOptions {
    /// Overwrite files not written by us.
    pub force: bool,
    /// No progress bar.
    pub quiet: bool,
    /// Write a contact sheet to this path.
    pub contact_sheet: Option<PathBuf>,
    /// Nominal size recorded in the manifest.
    pub size: u32,
}

fn is_inside(dir: &Path, file: &Path) -> Option<String> {
    let parent = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let (a, b) = (
        std::fs::canonicalize(parent).ok()?,
        std::fs::canonicalize(dir).ok()?,
    );
    if a == b {
        file.file_name().map(|n| n.to_string_lossy().into_owned())
    } else {
        None
    }
}

/// Generate `specs` into `dir` (in parallel on the current rayon pool) and write
/// `manifest.json`. Refuses, before writing anything, to touch a non-empty
/// directory that has no manifest of ours, or any existing file our manifest does
/// not list, unless `force`.
pub fn write_corpus(
    dir: &Path,
    specs: &[Spec],
    opts: &WriteOptions,
) -> Result<Manifest, CorpusError> {
    // --- Checks, before anything is written.
    if dir.exists() && !dir.is_dir() {
        return Err(CorpusError::InvalidArgument(format!(
            "--out {} exists and is not a directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| CorpusError::io(dir, e))?;
    let old = Manifest::read_from_dir(dir)?;
    if !opts.force && old.is_none() {
        let mut entries = std::fs::read_dir(dir).map_err(|e| CorpusError::io(dir, e))?;
        if entries.next().is_some() {
            return Err(CorpusError::ForeignDirectory(dir.to_path_buf()));
        }
    }
    let owned = |name: &str| old.as_ref().is_some_and(|m| m.owns(name));
    let mut names = HashSet::new();
    for s in specs {
        let name = s.file_name();
        if !names.insert(name.clone()) {
            return Err(CorpusError::InvalidArgument(format!(
                "duplicate output file {name}"
            )));
        }
        let path = dir.join(&name);
        if !opts.force && path.exists() && !owned(&name) {
            return Err(CorpusError::WouldOverwrite(path));
        }
    }
    let sheet_in_dir = opts.contact_sheet.as_ref().and_then(|p| {
        if let Some(parent) = p.parent().filter(|p| !p.as_os_str().is_empty()) {
            let _ = std::fs::create_dir_all(parent);
        }
        is_inside(dir, p)
    });
    if let Some(sheet) = &opts.contact_sheet {
        if sheet
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.eq_ignore_ascii_case("png"))
            != Some(true)
        {
            return Err(CorpusError::InvalidArgument(format!(
                "--contact-sheet {} must end in .png",
                sheet.display()
            )));
        }
        let ours = sheet_in_dir.as_deref().is_some_and(owned);
        if !opts.force && sheet.exists() && !ours {
            return Err(CorpusError::WouldOverwrite(sheet.clone()));
        }
        if sheet_in_dir
            .as_deref()
            .is_some_and(|n| names.contains(n) || n == MANIFEST_NAME)
        {
            return Err(CorpusError::InvalidArgument(format!(
                "--contact-sheet {} collides with a corpus file",
                sheet.display()
            )));
        }
    }

    // --- Generate and write, in parallel; results keep spec order.
    let pb = if opts.quiet {
        ProgressBar::hidden()
    } else {
        let pb =
            ProgressBar::with_draw_target(Some(specs.len() as u64), ProgressDrawTarget::stderr());
        pb.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} {msg}",
            )
            .expect("valid progress template"),
        );
        pb
    };
    let want_thumbs = opts.contact_sheet.is_some();
    let results: Vec<Result<(Entry, Option<image::RgbImage>), CorpusError>> = specs
        .par_iter()
        .map(|spec| {
            let img = crate::try_generate(spec.class, spec.width, spec.height, spec.seed)?;
            let name = spec.file_name();
            let path = dir.join(&name);
            let tmp = dir.join(format!(".{name}.tmp"));
            img.save(&tmp)?;
            std::fs::rename(&tmp, &path).map_err(|e| CorpusError::io(&path, e))?;
            let thumb = want_thumbs.then(|| contact::thumbnail(&img));
            pb.inc(1);
            pb.set_message(name);
            Ok((Entry::new(spec, &img), thumb))
        })
        .collect();
    pb.finish_and_clear();
    let mut entries = Vec::with_capacity(results.len());
    let mut thumbs = Vec::new();
    for r in results {
        let (e, t) = r?;
        if let Some(t) = t {
            thumbs.push((format!("{}-{:02}", e.class.name(), e.seed), t));
        }
        entries.push(e);
    }

    // --- Manifest: the new entries, plus earlier entries whose files are still there.
    let mut manifest = Manifest::new(opts.size, entries);
    if let Some(old) = &old {
        for e in &old.images {
            if !names.contains(&e.file) && dir.join(&e.file).exists() {
                manifest.images.push(e.clone());
            }
        }
        if opts.contact_sheet.is_none() {
            manifest.contact_sheet = old.contact_sheet.clone().filter(|f| dir.join(f).exists());
        }
    }
    if let Some(sheet) = &opts.contact_sheet {
        let img = contact::compose(&thumbs);
        img.save(sheet).map_err(|source| CorpusError::Png {
            path: sheet.clone(),
            source,
        })?;
        if sheet_in_dir.is_some() {
            manifest.contact_sheet = sheet_in_dir;
        }
    }
    manifest.write_to_dir(dir)?;
    Ok(manifest)
}

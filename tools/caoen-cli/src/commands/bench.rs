//! `caoen bench`: runs the RD benchmark and writes its report, tables and plots.

use std::time::{Duration, Instant};

use caoen::raster::{ChannelLayout, SampleFormat};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::bench::codecs::{self, Codec};
use crate::bench::corpus::{self, Source};
use crate::bench::harness::{self, Config, Rates};
use crate::bench::report::{CodecInfo, ImageInfo, Report, FORMAT, METRICS_NOTE};
use crate::bench::{plot, summary, BenchArgs};
use crate::cli::GlobalArgs;
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::{print, Outputs};

/// The codecs benchmarked when `--codecs` is not given.
fn default_codecs() -> Vec<String> {
    if cfg!(feature = "peers") {
        vec!["caoen".into(), "jpeg".into(), "webp".into()]
    } else {
        vec!["caoen".into()]
    }
}

/// Markers delimiting the generated tables inside a hand-written Markdown file.
pub const MARKDOWN_BEGIN: &str = "<!-- caoen bench: begin -->";
/// See [`MARKDOWN_BEGIN`].
pub const MARKDOWN_END: &str = "<!-- caoen bench: end -->";

/// The new contents of a `--markdown` file: an existing file holding both markers
/// keeps everything outside them (so `docs/benchmarks.md` is regenerated in place),
/// any other file is replaced by the tables.
fn splice_markdown(old: &str, tables: &str) -> String {
    match (old.find(MARKDOWN_BEGIN), old.find(MARKDOWN_END)) {
        (Some(b), Some(e)) if b < e => {
            format!("{}{MARKDOWN_BEGIN}\n\n{tables}{}", &old[..b], &old[e..])
        }
        _ => tables.to_string(),
    }
}

/// Refuses a `--markdown` file whose markers cannot be spliced: one without the
/// other, or the end before the beginning. Replacing it would drop the user's text
/// around the one marker, so it is refused before any work.
fn check_markers(path: &std::path::Path, old: &str) -> CliResult {
    let (b, e) = (old.find(MARKDOWN_BEGIN), old.find(MARKDOWN_END));
    let problem = match (b, e) {
        (None, None) => return Ok(()),
        (Some(b), Some(e)) if b < e => return Ok(()),
        (Some(_), None) => "the begin marker but no end marker",
        (None, Some(_)) => "the end marker but no begin marker",
        _ => "the end marker before the begin marker",
    };
    Err(CliError::Usage(format!(
        "--markdown {}: the file has {problem} ({MARKDOWN_BEGIN} ... {MARKDOWN_END}); \
         the tables go between the two, so fix the markers or choose another file",
        path.display()
    )))
}

/// What `caoen bench`'s arguments ask for, checked before any work.
struct Plan {
    codecs: Vec<Box<dyn Codec>>,
    names: Vec<String>,
    reference: String,
    rates: Rates,
    source: Source,
    classes: Vec<String>,
    existing_markdown: String,
}

/// Checks the arguments and turns them into a [`Plan`].
fn plan(global: &GlobalArgs, args: &BenchArgs) -> CliResult<Plan> {
    let names = args.codecs.clone().unwrap_or_else(default_codecs);
    let mut codecs: Vec<Box<dyn Codec>> = Vec::new();
    for name in &names {
        if codecs.iter().any(|c| c.name() == name) {
            return Err(CliError::Usage(format!("codec `{name}` given twice")));
        }
        codecs.push(codecs::by_name(name, args.effort).map_err(CliError::Usage)?);
    }
    if !cfg!(feature = "peers") {
        note(
            global,
            "note: this build has no peer codecs; for JPEG and WebP beside caoen run \
             `cargo run --release --features peers -- bench ...`",
        );
    }
    let reference = match &args.reference {
        Some(r) if names.contains(r) => r.clone(),
        Some(r) => {
            return Err(CliError::Usage(format!(
                "reference codec `{r}` is not among --codecs ({})",
                names.join(",")
            )))
        }
        None if names.iter().any(|n| n == "jpeg") => "jpeg".into(),
        None => names[0].clone(),
    };
    let rates: Rates = args.rates.parse().map_err(CliError::Usage)?;
    if let Some(p) = &args.plot {
        let ok = p
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png") || e.eq_ignore_ascii_case("svg"));
        if !ok {
            return Err(CliError::Usage(format!(
                "--plot {}: use a .png or .svg file name",
                p.display()
            )));
        }
    }
    let source = match &args.corpus {
        Some(dir) => Source::Dir(dir.clone()),
        None => {
            for c in &args.classes {
                c.parse::<caoen_corpus::Class>()
                    .map_err(|e| CliError::Usage(e.to_string()))?;
            }
            Source::Generated {
                size: args.size,
                seeds: args.seeds,
            }
        }
    };
    // Accept class aliases (`flat`, `edge`) by mapping them to the corpus names.
    let classes: Vec<String> = args
        .classes
        .iter()
        .map(|c| {
            c.parse::<caoen_corpus::Class>()
                .map(|k| k.name().to_string())
                .unwrap_or_else(|_| c.clone())
        })
        .collect();
    let existing_markdown = match &args.markdown {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(text) => {
                check_markers(path, &text)?;
                text
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(CliError::io(path, e)),
        },
        None => String::new(),
    };
    if let (Some(keep), Source::Dir(corpus)) = (&args.keep, &source) {
        let same = |a: &std::path::Path, b: &std::path::Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
        if same(keep, corpus) {
            return Err(CliError::Usage(format!(
                "--keep {}: that is the corpus folder; the encoded and decoded files go to \
                 a folder of their own",
                keep.display()
            )));
        }
    }
    if let Some(dir) = &args.keep {
        std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, e))?;
    }
    Ok(Plan {
        codecs,
        names,
        reference,
        rates,
        source,
        classes,
        existing_markdown,
    })
}

/// Runs `caoen bench`.
pub fn run(global: &GlobalArgs, args: &BenchArgs) -> CliResult {
    let plan = plan(global, args)?;

    let started = Instant::now();
    note(
        global,
        format!("loading images: {}", plan.source.describe()),
    );
    let images = corpus::load(&plan.source, &plan.classes).map_err(CliError::Failed)?;
    let corpus_files: Vec<std::path::PathBuf> = images
        .iter()
        .filter_map(|i| i.file.clone())
        .chain(match &plan.source {
            Source::Dir(dir) => Some(dir.join(caoen_corpus::manifest::MANIFEST_NAME)),
            Source::Generated { .. } => None,
        })
        .collect();
    let reading = |force| {
        corpus_files
            .iter()
            .fold(Outputs::new(force), |o, f| o.input(f))
    };
    let mut outputs = reading(global.force);
    for path in [&args.report, &args.markdown].into_iter().flatten() {
        outputs.check_path(path)?;
    }
    if let Some(base) = &args.plot {
        let mut classes: Vec<&str> = images.iter().map(|i| i.class.as_str()).collect();
        classes.sort_unstable();
        classes.dedup();
        for class in classes {
            outputs.check_path(&plot::class_path(base, class))?;
        }
    }
    let total: u64 = images.len() as u64
        * plan
            .codecs
            .iter()
            .map(|c| harness::points_per_image(c.as_ref(), &plan.rates) as u64)
            .sum::<u64>();
    note(
        global,
        format!(
            "benchmarking {} images x {} ({total} points)",
            images.len(),
            plan.names.join(", ")
        ),
    );
    let bar = if global.quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template(
                "{bar:30} {pos}/{len} points, {elapsed} elapsed, ETA {eta}  {msg}",
            )
            .expect("valid template"),
        );
        b.enable_steady_tick(Duration::from_millis(250));
        b
    };
    let config = Config {
        codecs: plan.codecs,
        rates: plan.rates,
        repeat: args.repeat as usize,
        keep: args.keep.clone(),
        keep_outputs: reading(true),
    };
    let outcome = harness::run(&images, &config, &bar);
    bar.finish_and_clear();

    let report = build_report(
        args,
        &plan.source,
        plan.reference,
        &config,
        &images,
        outcome,
    );
    let markdown = report.to_markdown();
    print(&markdown)?;
    if let Some(path) = &args.report {
        outputs.write_path(path, report.to_json().as_bytes())?;
        note(global, format!("wrote {}", path.display()));
    }
    if let Some(path) = &args.markdown {
        outputs.write_path(
            path,
            splice_markdown(&plan.existing_markdown, &markdown).as_bytes(),
        )?;
        note(global, format!("wrote {}", path.display()));
    }
    if let Some(base) = &args.plot {
        for p in plot::write_plots(&outputs, base, &report.measurements, &plan.names)
            .map_err(CliError::Failed)?
        {
            note(global, format!("wrote {}", p.display()));
        }
    }
    note(
        global,
        format!(
            "{} points measured, {} skipped pairs, {} failed, in {:.1} s",
            report.measurements.len(),
            report.skipped.len(),
            report.failures.len(),
            started.elapsed().as_secs_f64()
        ),
    );
    if let Some(first) = report.failures.first() {
        return Err(CliError::Failed(format!(
            "{} points failed (listed in the report and the tables); the first: {} on {} at {}: {}",
            report.failures.len(),
            first.codec,
            first.image,
            first.target,
            first.error
        )));
    }
    Ok(())
}

/// The report of a run: its settings, the images, the measurements and their summaries.
fn build_report(
    args: &BenchArgs,
    source: &Source,
    reference: String,
    config: &Config,
    images: &[corpus::BenchImage],
    outcome: harness::Outcome,
) -> Report {
    let names: Vec<String> = config.codecs.iter().map(|c| c.name().to_string()).collect();
    let per_image = summary::per_image(&outcome.measurements, &names, &reference);
    let classes = summary::per_class(&outcome.measurements, &per_image, &names);
    Report {
        format: FORMAT.into(),
        version: env!("CARGO_PKG_VERSION").into(),
        corpus: source.describe(),
        rates: args.rates.clone(),
        repeat: config.repeat,
        reference,
        metrics: METRICS_NOTE.into(),
        codecs: config
            .codecs
            .iter()
            .map(|c| CodecInfo {
                name: c.name().into(),
                description: c.description(),
            })
            .collect(),
        images: images
            .iter()
            .map(|i| ImageInfo {
                name: i.name.clone(),
                class: i.class.clone(),
                width: i.raster.width(),
                height: i.raster.height(),
                layout: match i.raster.layout() {
                    ChannelLayout::Grey => "grey",
                    ChannelLayout::GreyAlpha => "grey-alpha",
                    ChannelLayout::Rgb => "rgb",
                    ChannelLayout::Rgba => "rgba",
                }
                .into(),
                sample_format: match i.raster.format() {
                    SampleFormat::U8 => "u8",
                    SampleFormat::U16 => "u16",
                    SampleFormat::F32 => "f32",
                }
                .into(),
            })
            .collect(),
        measurements: outcome.measurements,
        skipped: outcome.skipped,
        failures: outcome.failures,
        per_image,
        classes,
    }
}

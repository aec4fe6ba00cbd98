//! Command implementations, one module per command group.

/// Appends a formatted line to a `String` of command output, printed at the end with
/// [`crate::output::print`] so that a failed write to stdout fails the command.
macro_rules! outln {
    ($buf:expr, $($arg:tt)*) => {{
        use std::fmt::Write as _;
        // Formatting into a String cannot fail.
        let _ = writeln!($buf, $($arg)*);
    }};
}

pub mod bench;
pub mod codec;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod examples;
pub mod folder;
pub mod frep;
pub mod morph;
pub mod print;
pub mod render;
pub mod surface;
pub mod texture;
pub mod view;

use crate::cli::{Cli, Command};
use crate::failure::{CliError, CliResult};

/// Runs a parsed command line.
pub fn run(cli: Cli) -> CliResult {
    let mut global = cli.global.clone();
    global.limits = caoen::Limits::new(global.max_memory);
    let limits = global.limits.clone();
    let job = move || match cli.command {
        None => demo::run(&global, &crate::cli::DemoArgs::default()),
        Some(cmd) => run_command(&global, cmd),
    };
    let result = match cli.global.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build()
            .map_err(CliError::library)?
            .install(job),
        None => job(),
    };
    // For measuring the estimates against the peak (tests/memory_peak.rs).
    if std::env::var_os("CAOEN_REPORT_BUDGET").is_some() {
        eprintln!(
            "budget: largest estimate {} bytes",
            limits.largest_checked()
        );
    }
    result
}

fn run_command(global: &crate::cli::GlobalArgs, cmd: Command) -> CliResult {
    let global = global.clone();
    check_folders(&cmd)?;
    match cmd {
        Command::Demo(args) => demo::run(&global, &args),
        Command::Encode(args) => codec::encode(&global, &args),
        Command::Decode(args) => codec::decode(&global, &args),
        Command::Info(args) => codec::info(&global, &args),
        Command::View(args) => view::run(&global, &args),
        Command::Surface(cmd) => surface::run(&global, cmd),
        Command::Corpus(args) => {
            let args = caoen_corpus::cli::CorpusArgs {
                quiet: global.quiet,
                force: global.force,
                ..args
            };
            caoen_corpus::cli::run(&args).map_err(|e| match e {
                caoen_corpus::CorpusError::Io { path, source }
                    if path == std::path::Path::new(caoen_corpus::cli::STDOUT) =>
                {
                    CliError::io(crate::output::STDOUT, source)
                }
                e => CliError::Failed(e.to_string()),
            })
        }
        Command::Examples(args) => examples::run(&global, &args),
        Command::Compare(args) => compare::run(&global, &args),
        Command::Bench(args) => bench::run(&global, &args),
        Command::Distort(args) => texture::distort(&global, &args),
        Command::Transfer(args) => texture::transfer(&global, &args),
        Command::Frep(cmd) => frep::run(&global, cmd),
        Command::Heightfield(args) => frep::heightfield(&global, &args),
        Command::Morph(args) => morph::run(&global, &args),
        Command::Relief(args) => frep::picture(&global, &args, frep::PictureUse::Relief),
        Command::Carve(args) => frep::picture(&global, &args, frep::PictureUse::Carve),
        Command::Lithophane(args) => print::lithophane(&global, &args),
        Command::Convert(args) => convert::convert(&global, &args),
        Command::Deviation(args) => convert::deviation(&global, &args),
    }
}

/// Refuses `-` for outputs that are folders (or several files named after one), before
/// any work: standard output takes one file.
fn check_folders(cmd: &Command) -> CliResult {
    use crate::output::{folder_output, is_stdout};
    match cmd {
        Command::Examples(a) => folder_output(&a.out, "caoen examples"),
        Command::Demo(a) => folder_output(&a.out_dir, "caoen demo"),
        Command::Corpus(a) => a
            .out
            .as_deref()
            .map_or(Ok(()), |o| folder_output(o, "caoen corpus")),
        Command::Bench(a) => {
            if let Some(k) = &a.keep {
                folder_output(k, "caoen bench --keep")?;
            }
            if a.plot.as_deref().is_some_and(is_stdout) {
                return Err(CliError::Usage(
                    "--plot -: the plots are one file per class, not standard output; name a file such as rd.png".into(),
                ));
            }
            if [&a.report, &a.markdown]
                .into_iter()
                .flatten()
                .any(|p| is_stdout(p))
            {
                return Err(CliError::Usage(
                    "--report/--markdown -: standard output carries the report's tables; name a file"
                        .into(),
                ));
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// Prints an informational line on stderr unless quiet.
pub(crate) fn note(global: &crate::cli::GlobalArgs, msg: impl std::fmt::Display) {
    if !global.quiet {
        eprintln!("{msg}");
    }
}

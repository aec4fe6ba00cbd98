//! `caoen-corpus`: thin wrapper around [`caoen_corpus::cli::run`].

use std::process::ExitCode;

use caoen_corpus::cli::{run, CorpusArgs};
use clap::Parser;

/// Generate caoen's procedural, bit-reproducible test-image corpus.
#[derive(Parser, Debug)]
#[command(name = "caoen-corpus", version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    args: CorpusArgs,
    /// No progress bar or summary on stderr.
    #[arg(short, long)]
    quiet: bool,
    /// Worker threads [default: all cores]. Does not change any output.
    #[arg(short = 'j', long, value_name = "N")]
    threads: Option<usize>,
    /// Overwrite files that this tool did not write.
    #[arg(short, long)]
    force: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let args = CorpusArgs {
        quiet: cli.quiet,
        threads: cli.threads,
        force: cli.force,
        ..cli.args
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that went away (`caoen-corpus --list | head`) chose to stop reading.
        Err(caoen_corpus::CorpusError::Io { source, .. })
            if source.kind() == std::io::ErrorKind::BrokenPipe =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("caoen-corpus: error: {e}");
            ExitCode::FAILURE
        }
    }
}

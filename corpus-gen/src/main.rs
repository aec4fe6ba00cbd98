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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli.args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("caoen-corpus: error: {e}");
            ExitCode::FAILURE
        }
    }
}

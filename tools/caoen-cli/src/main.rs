//! The `caoen` command line.
#![deny(unsafe_code)]

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

fn fail(e: &caoen_cli::failure::CliError) -> ExitCode {
    let mut message = e.chain();
    // The library states the need and the budget; how to raise the budget is this
    // program's to say, since the budget is its option.
    if message.contains(caoen::budget::OVER_BUDGET) {
        message.push_str(" (raise it with --max-memory)");
    }
    // One line, whatever a file put into the message.
    eprintln!("error: {}", caoen::surface::error::printable(&message));
    ExitCode::from(e.exit_code())
}

/// Keeps freed memory for reuse: the encoder works tile by tile, and glibc's defaults
/// return each tile's buffers to the system and fault fresh zeroed pages in for the
/// next (on an 8192x8192 image a third of the encoder's time). Blocks of 32 MiB and
/// more are still mapped and unmapped on their own, and at most 256 MiB of free memory
/// is kept.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
fn tune_allocator() {
    // SAFETY: mallopt only sets allocator parameters; it is called once, before any
    // other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_allocator() {}

fn main() -> ExitCode {
    tune_allocator();
    let cli = caoen_cli::cli::Cli::parse();
    let result = caoen_cli::commands::run(cli);
    // Output still buffered in stdout must reach it, or the command failed.
    let result = result.and_then(|()| {
        std::io::stdout()
            .flush()
            .map_err(|e| caoen_cli::failure::CliError::io(caoen_cli::output::STDOUT, e))
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => fail(&e),
    }
}
